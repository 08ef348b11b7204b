"""One split's test-set attribute posteriors (:class:`SplitPosteriors`): the result type every table of the
zero-shot study reads, in a module of its own so that the study, its tables and its method comparison
all import it without importing each other."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tzsl.evaluation import Split
from tzsl.exceptions import ConfigError
from tzsl.models import AttributeClassifierBank, DAPRule
from tzsl.models.dap import attribute_prior

__all__ = ["SplitPosteriors"]


@dataclass
class SplitPosteriors:
    """Test-set attribute posteriors of one split, enough to score every DAP variant.

    Attributes
    ----------
    split : Split
    attributes : tuple of str, length m
        Attributes the split's classifiers were trained on.
    P : ndarray of shape (n_test_trials, n_sensors, m)
        ``p(a_m = 1 | x_s)`` of every test trial from the independent classifiers.
    K : ndarray of shape (n_test_objects, m)
        Test objects' attribute rows (the unseen classes), in ``split.test_objects`` order.
    y : ndarray of shape (n_test_trials,)
        Row of ``K`` of each test trial's object.
    train_prior : ndarray of shape (m,)
        Attribute frequency over training objects.
    P_multilabel : ndarray of shape (n_test_trials, n_sensors, m) or None
        Posteriors of the joint (multi-label) model, when fitted.
    model : AttributeClassifierBank or None
        The fitted independent attribute classifiers.
    fit_seconds : float
        Wall-clock seconds of fitting them (small when the fit cache had them).
    """

    split: Split
    attributes: tuple[str, ...]
    P: np.ndarray
    K: np.ndarray
    y: np.ndarray
    train_prior: np.ndarray
    P_multilabel: np.ndarray | None = None
    model: AttributeClassifierBank | None = None
    fit_seconds: float = float("nan")

    def accuracy(self, fusion: str = "avg", prior: str = "uni", multilabel: bool = False) -> float:
        """DAP trial accuracy on this split's test objects."""
        return float((self.predict(fusion, prior, multilabel) == self.y).mean())

    def predict(self, fusion: str = "avg", prior: str = "uni", multilabel: bool = False) -> np.ndarray:
        """Predicted test-object row of every test trial, shape (n_test_trials,)."""
        return self.scores(fusion, prior, multilabel).argmax(axis=1)

    def scores(self, fusion: str = "avg", prior: str = "uni", multilabel: bool = False,
               K: np.ndarray | None = None) -> np.ndarray:
        """DAP log scores (n_test_trials, n_test_objects) against ``K`` (default the true rows), by
        :class:`~tzsl.models.DAPRule`.

        The prior is always the one of the true rows (a permuted ``K``, as in the negative
        control, has the same attribute frequencies).
        """
        P = self.P_multilabel if multilabel else self.P
        if P is None:
            raise ConfigError("no multi-label posteriors were computed for this split")
        rule = DAPRule(fusion=fusion, prior=self._prior(prior)).fit(self.K)  # the prior is given: nothing learnt
        return rule.decision_function(P, self.K if K is None else K)

    def _prior(self, prior: str) -> np.ndarray:
        if prior == "train":
            return self.train_prior
        return attribute_prior(prior, class_attributes=self.K)
