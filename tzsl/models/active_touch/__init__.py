"""Active touch: which exploratory procedure (EP) to do next, and when to stop.

The room of a per-EP model or an EP policy. The fitted model is :class:`PerEPAttributeModel` (per-EP
attribute classifiers, :class:`tzsl.models.LogisticAttribute` by default; also at the top of
:mod:`tzsl.models`). Here: the EPs' durations and feature blocks
(:data:`PHAC2_EP_SECONDS`, :func:`ep_column_blocks`), the confusion model
(:func:`binned_confusion`), the tempered sequential posterior (:data:`TEMPERINGS`,
:func:`fit_posterior_exponents`, :func:`sequential_log_posterior`, :func:`done_subset_index`),
the expected information gain of the next EP (:func:`outcome_log_likelihoods`,
:func:`expected_information_gain`), the policy with its stopping rule (:func:`run_policy`,
:func:`stop_reasons`) and the next-EP suggestion for one object (:func:`suggest_next_ep`).
"""

from tzsl.models.active_touch._per_ep import PHAC2_EP_SECONDS, PerEPAttributeModel, ep_column_blocks
from tzsl.models.active_touch._policy import (
    TEMPERINGS,
    binned_confusion,
    done_subset_index,
    expected_information_gain,
    fit_posterior_exponents,
    outcome_log_likelihoods,
    run_policy,
    sequential_log_posterior,
    stop_reasons,
)
from tzsl.models.active_touch._suggest import suggest_next_ep

__all__ = [
    "PerEPAttributeModel",
    "PHAC2_EP_SECONDS",
    "TEMPERINGS",
    "binned_confusion",
    "done_subset_index",
    "ep_column_blocks",
    "expected_information_gain",
    "fit_posterior_exponents",
    "outcome_log_likelihoods",
    "run_policy",
    "sequential_log_posterior",
    "stop_reasons",
    "suggest_next_ep",
]
