"""What a robot should do next with a fitted per-EP model: ranking, decision, next EP
(``tzsl predict --suggest-next``)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from sklearn.utils.validation import check_is_fitted

from tzsl.exceptions import ConfigError
from tzsl.models._dap import check_class_attributes
from tzsl.models.active_touch._per_ep import PerEPAttributeModel
from tzsl.models.active_touch._policy import expected_information_gain, stop_reasons

__all__ = ["suggest_next_ep"]


def suggest_next_ep(model: PerEPAttributeModel, class_attributes, done_eps: Mapping[str, np.ndarray], *,
                    class_names: Sequence[str] | None = None, threshold: float = 0.9, max_eps: int | None = None,
                    max_seconds: float | None = None, n_samples: int = 256, random_state=0) -> dict:
    """What a robot should do next: current ranking, whether it has decided, and the next EP.

    Parameters
    ----------
    model : fitted PerEPAttributeModel
    class_attributes : array-like of shape (n_classes, n_attributes)
        0/1 attribute rows of the candidate (unseen) classes.
    done_eps : mapping of str -> array-like of shape (n_sensors, n_ep_features)
        The features of each EP done so far on the object (that EP's columns only).
    class_names : sequence of str, optional
        Default ``"0"``, ``"1"``, ...
    threshold, max_eps, max_seconds
        Stopping rule (:func:`stop_reasons`).
    n_samples : int
        Monte-Carlo outcomes per class for the expected gain.
    random_state : int or None

    Returns
    -------
    dict (JSON-serialisable)
        ``ranking``: list of ``{"class", "probability"}``, best first; ``decided`` (bool);
        ``decision`` (class or None); ``stop_reason`` (str or None); ``done_eps``; ``seconds_used``;
        ``next_ep`` (str or None); ``expected_gain_bits`` (float or None); ``candidates``: list of
        ``{"ep", "seconds", "expected_gain_bits"}`` for the EPs not done, best first;
        ``posterior``: how the ranking's probabilities were made, ``{"tempering", "exponent"
        (tau of the EPs done), "untempered_top_probability", "fitted_on"}``.
    """
    check_is_fitted(model)
    K = check_class_attributes(class_attributes, model.n_attributes_)
    names = [str(i) for i in range(K.shape[0])] if class_names is None else [str(c) for c in class_names]
    if len(names) != K.shape[0]:
        raise ConfigError(f"{len(names)} class names for {K.shape[0]} classes")
    unknown = [ep for ep in done_eps if ep not in model.eps_]
    if unknown:
        raise ConfigError(f"unknown EP(s) {unknown}; the model knows {list(model.eps_)}")
    done = np.array([ep in done_eps for ep in model.eps_])
    P = np.full((1, len(model.eps_), model.n_sensors_, model.n_attributes_), 0.5)  # EPs not done: unused
    for i, ep in enumerate(model.eps_):
        if done[i]:
            P[0, i] = model.predict_ep_proba(ep, np.asarray(done_eps[ep], dtype=np.float64)[None])[0]
    scores = model.ep_log_scores(P, K)
    lb = model.log_posterior(scores, done[None])
    used = float(model.ep_seconds_[done].sum())
    left = np.flatnonzero(~done)
    next_sec = float(model.ep_seconds_[left].min()) if left.size else np.inf
    reason = stop_reasons(lb, [done.sum()], [used], [next_sec], threshold=threshold, max_eps=max_eps,
                          max_seconds=max_seconds)[0]
    prob = np.exp(lb[0])
    rank = np.argsort(-prob, kind="stable")
    candidates = []
    if left.size:
        g = expected_information_gain(lb, model.outcome_log_likelihoods(K, n_samples, random_state))[0]
        affordable = [i for i in left if max_seconds is None or used + model.ep_seconds_[i] <= max_seconds]
        candidates = sorted(({"ep": model.eps_[i], "seconds": float(model.ep_seconds_[i]),
                              "expected_gain_bits": float(g[i])} for i in affordable),
                            key=lambda c: -c["expected_gain_bits"])
    decided = reason != ""
    best = candidates[0] if candidates and not decided else None
    return {
        "ranking": [{"class": names[i], "probability": float(prob[i])} for i in rank],
        "decided": bool(decided),
        "decision": names[rank[0]] if decided else None,
        "stop_reason": reason or None,
        "done_eps": [ep for ep in model.eps_ if ep in done_eps],
        "seconds_used": used,
        "next_ep": best["ep"] if best else None,
        "expected_gain_bits": best["expected_gain_bits"] if best else None,
        "candidates": candidates,
        "posterior": {
            "tempering": model.tempering,
            "exponent": model.exponent(done),
            "untempered_top_probability": float(np.exp(model.log_posterior(scores, done[None], tempered=False).max())),
            "fitted_on": f"{model.tempering_trials_} held-out trials of pseudo-unseen training objects "
                         f"({model.cv} object-grouped folds)",
        },
    }
