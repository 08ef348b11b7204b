"""Attribute detector families: the per-(attribute, sensor) classifier an attribute bank clones.

Written once here and read by every model with an attribute bank (:class:`~tzsl.models.AttributeClassifierBank`
and what builds on it: DAP's fusions and priors, GZSL, the classifier chain, the active-touch
bank given a template):

* ``"rbf-svm"``: :class:`~tzsl.models.AttributeSVM` (or the bank's ``estimator``), the DAP paper's detector;
* ``"logistic"``: :class:`~tzsl.models.LinearAttribute` with L2 logistic regression;
* ``"linear-svm"``: :class:`~tzsl.models.LinearAttribute` with a linear SVM (squared hinge);
* ``"robust-logistic"``: the logistic detector trained group-robustly over training objects
  (``weighting="robust"``), aimed at errors an unseen object shares across its attributes;
* ``"logistic-c1"``: :class:`~tzsl.models.LogisticAttribute` (z-score, class-balanced L2 logistic
  regression, ``C = 1``, its own posteriors): nothing tuned, the per-EP model's classifier;
* ``"auto"``: one of :data:`AUTO_CANDIDATES`, chosen by :func:`choose_detector` on the training
  objects only.
"""

from __future__ import annotations

import warnings

import numpy as np
from scipy.special import xlogy
from sklearn.base import clone
from sklearn.preprocessing import StandardScaler

from tzsl.exceptions import ConfigError
from tzsl.models._pseudo_unseen import pseudo_unseen_scores
from tzsl.models._zero_shot import ZeroShotClassifier
from tzsl.models._zsl_input import GridEdgeWarning, ZSLInputError
from tzsl.models.detectors._attribute_svm import AttributeSVM
from tzsl.models.detectors._attribute_training import default_preprocessor
from tzsl.models.detectors._linear_attribute import LinearAttribute
from tzsl.models.detectors._logistic_attribute import LogisticAttribute
from tzsl.models.rules import DAPRule

__all__ = ["AUTO_CANDIDATES", "AUTO_FOLDS", "DETECTORS", "FIXED_DETECTORS", "LINEAR_DETECTORS", "STUDY_DETECTOR",
           "choose_detector", "detector_preprocessor", "detector_template"]

#: The linear families and their :class:`LinearAttribute` parameters.
LINEAR_DETECTORS: dict[str, dict] = {
    "logistic": {"loss": "log_loss"},
    "linear-svm": {"loss": "squared_hinge"},
    "robust-logistic": {"loss": "log_loss", "weighting": "robust"},
}
#: The untuned families and their classifier (default parameters).
FIXED_DETECTORS: dict[str, type] = {"logistic-c1": LogisticAttribute}
#: ``detector`` options of an attribute bank.
DETECTORS = ("rbf-svm", *LINEAR_DETECTORS, *FIXED_DETECTORS, "auto")
#: The detector family of the generic zero-shot study (``[svm] detector`` of ``study = "zero-shot"``): chosen
#: on PHAC-2 selection splits and reported on confirmation splits (:data:`tzsl.models.INHERITED_CHOICES`,
#: ``study-detector``). The paper presets and :class:`~tzsl.models.AttributeClassifierBank` keep ``"rbf-svm"``.
STUDY_DETECTOR = "logistic-c1"
#: The families ``detector="auto"`` chooses between (the flexible kernel and the linear detector).
AUTO_CANDIDATES = ("rbf-svm", "logistic")
#: Class-grouped folds of pseudo-unseen training classes that ``detector="auto"`` scores on.
AUTO_FOLDS = 3
#: Posteriors are clipped to ``[AUTO_EPS, 1 - AUTO_EPS]`` in the attribute log-loss.
AUTO_EPS = 1e-6


def detector_template(detector: str, estimator=None):
    """The unfitted per-(attribute, sensor) classifier of a detector family.

    Parameters
    ----------
    detector : str
        One of :data:`DETECTORS` except ``"auto"``.
    estimator : classifier or None
        The template of ``"rbf-svm"`` (None: :class:`AttributeSVM` defaults); must be None for
        the other families.

    Returns
    -------
    classifier
        Taking ``fit(X, y, groups)`` and giving ``predict_proba``.

    Raises
    ------
    ConfigError
        An unknown family, ``"auto"``, or an ``estimator`` given with a linear family.
    """
    if detector == "rbf-svm":
        return AttributeSVM() if estimator is None else estimator
    if detector not in LINEAR_DETECTORS and detector not in FIXED_DETECTORS:
        raise ConfigError(f"detector {detector!r} has no template; choose one of {DETECTORS[:-1]}")
    if estimator is not None:
        raise ConfigError(f"detector={detector!r}: estimator is the template of detector='rbf-svm'; leave it None "
                          f"(got {type(estimator).__name__})")
    if detector in FIXED_DETECTORS:
        return FIXED_DETECTORS[detector]()
    return LinearAttribute(**LINEAR_DETECTORS[detector])


def detector_preprocessor(template):
    """The preprocessor a detector template applies: its own, or its family's default (unfitted).

    :class:`LinearAttribute` and :class:`LogisticAttribute`: ``StandardScaler`` (z-score); otherwise
    :func:`~tzsl.models.detectors.default_preprocessor` (z-score + PCA), as
    :class:`AttributeSVM` uses.
    """
    own = template.get_params().get("preprocessor")
    if own is not None:
        return own
    linear = isinstance(template, (LinearAttribute, LogisticAttribute))
    return StandardScaler() if linear else default_preprocessor()


def _held_out_terms(fitted, X_held, K_held) -> tuple[np.ndarray, np.ndarray]:
    """Class scores (n, k) and sensor-averaged attribute posteriors (n, m) of a fold's held-out trials."""
    P = np.asarray(fitted.attribute_model_.predict_proba(X_held))
    return fitted.decision_function(X_held, K_held), (P.mean(axis=1) if P.ndim == 3 else P)


def choose_detector(bank, X: np.ndarray, A: np.ndarray, groups, candidates=AUTO_CANDIDATES, *,
                    n_folds: int = AUTO_FOLDS, random_state=None) -> dict:
    """Choose a detector family by zero-shot accuracy on pseudo-unseen training classes.

    The training classes (distinct attribute rows) are dealt into ``n_folds`` class-grouped folds
    (:func:`tzsl.models.calibration.pseudo_unseen_scores`, the same folds for every candidate);
    for each fold and candidate the bank is refitted on the other classes and AVGDAP (uniform
    prior) recognises the held-out trials among the held-out classes. The candidate with the
    highest trial accuracy wins; ties go to the lower attribute log-loss, then to the earlier
    candidate. Only training objects are used.

    Parameters
    ----------
    bank : AttributeClassifierBank
        Unfitted template; cloned with each candidate ``detector``.
    X : ndarray of shape (n_trials, n_sensors, n_features)
    A : ndarray of shape (n_trials, n_attributes)
        0/1 attribute row of each training trial's object.
    groups : ndarray of shape (n_trials,) or None
        Object of each trial (for the candidates' own grouped tuning).
    candidates : sequence of str, default AUTO_CANDIDATES
        Families of :data:`DETECTORS` (not ``"auto"``).
    n_folds : int, default AUTO_FOLDS
    random_state : int or None
        Seeds the fold dealing (and the candidates' fits).

    Raises
    ------
    ZSLInputError
        Fewer than 4 training classes (no pseudo-unseen fold can be formed).

    Returns
    -------
    dict
        ``{"detector": chosen, "criterion": "zero-shot accuracy on pseudo-unseen training
        classes", "n_folds", "n_held_out_trials", "scores": {candidate: {"accuracy",
        "attribute_log_loss"}}}``; accuracy in [0, 1], log-loss in nats per (trial, attribute).
    """
    if not candidates or "auto" in candidates or not set(candidates) <= set(DETECTORS):
        raise ConfigError(f"detector candidates must be families of {DETECTORS[:-1]}, got {tuple(candidates)!r}")
    scores: dict[str, dict[str, float]] = {}
    n_held = 0
    for name in candidates:
        member = clone(bank).set_params(detector=name, progress=False,  # estimator: the rbf-svm's template
                                        **({} if name == "rbf-svm" else {"estimator": None}))
        zsl = ZeroShotClassifier(attribute_model=member, decision_rule=DAPRule(fusion="avg", prior="uni"),
                                 random_state=random_state)
        with warnings.catch_warnings():  # the folds' grid edges are not the final fit's
            warnings.simplefilter("ignore", GridEdgeWarning)
            try:
                folds = pseudo_unseen_scores(zsl, X, A, groups, n_folds=n_folds, random_state=random_state,
                                             score=lambda fitted, Xh, Kh: (*_held_out_terms(fitted, Xh, Kh), Kh))
            except ZSLInputError as exc:
                raise ZSLInputError(f"detector='auto' cannot choose on pseudo-unseen training classes ({exc}); "
                                    "give the detector family") from None
        hits, losses, n_held = 0, [], 0
        for (class_scores, P, K), y, _ in folds:
            hits += int(np.sum(np.argmax(class_scores, axis=1) == y))
            n_held += y.size
            truth = K[y]
            p = np.clip(P, AUTO_EPS, 1 - AUTO_EPS)
            losses.append(-(xlogy(truth, p) + xlogy(1 - truth, 1 - p)))
        scores[name] = {"accuracy": hits / n_held,
                        "attribute_log_loss": float(np.mean(np.concatenate([x.ravel() for x in losses])))}
    order = sorted(candidates, key=lambda c: (-scores[c]["accuracy"], scores[c]["attribute_log_loss"],
                                               list(candidates).index(c)))
    return {"detector": order[0], "criterion": "zero-shot accuracy on pseudo-unseen training classes",
            "n_folds": len(folds), "n_held_out_trials": n_held, "scores": scores}
