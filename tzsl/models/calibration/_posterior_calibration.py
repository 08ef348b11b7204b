"""Calibrated class posteriors for zero-shot methods: a temperature fitted on pseudo-unseen classes.

A zero-shot method's class posterior (DAP's product over attributes, a softmax over ESZSL/SAE
compatibilities, the ensemble's z-scores) is rarely calibrated: DAP multiplies attribute
posteriors as if independent and is over-confident. :class:`CalibratedZeroShotClassifier`
composes any zero-shot estimator (``fit(X, Y, groups)``, ``decision_function(X,
class_attributes)``) with one scalar **temperature** ``T``:

``p(z | x) = softmax_z(s(x, z) / T)``

where ``s`` are the method's class scores (DAP: log-posteriors, so ``1 / T`` is a common
exponent on every attribute factor: a tempered product). ``T`` is fitted honestly, on the
training trials only, by the zero-shot protocol itself:

0. above ``calibration_max_trials`` training trials (default :data:`MAX_CALIBRATION_TRIALS`), the
   folds are dealt on a seeded subsample of about that many trials, drawn from every (class,
   object) in proportion to its trials (:func:`calibration_subsample`), so the cost of calibration
   stops growing with the data set; below it every training trial is used;
1. the training classes (distinct attribute rows) are dealt into ``calibration_folds``
   class-grouped folds (:func:`tzsl.models.protocol.class_grouped_folds`; which class goes to which fold
   is seeded by ``random_state``);
2. for each fold, the method is refitted on the other classes and scores the held-out
   (*pseudo-unseen*) classes' trials among the held-out classes' rows, as a test trial is
   scored among the test classes (the folds are those of :mod:`tzsl.models._pseudo_unseen`, which
   the ``detector="auto"`` choice shares). A 0/1 attribute that fewer than ``MIN_FOLD_CLASSES`` of
   the fold's training classes have (or lack) cannot be learnt there (the per-attribute classifiers
   need both kinds of object), so that fold leaves it out, on both sides; ``calibration_info_`` counts such attributes;
3. ``T`` minimises the log-loss of those held-out trials (one scalar, bounded search on ``log
   T``).

The method is fitted on all training trials first, through the fit store
(:func:`tzsl.fit_store.fit_cached`; each fold's refit too): the same method with the same parameters,
seed and training rows, asked for bare (a score ensemble's member) or inside another calibrator, is
fitted once. An attribute model that tunes its own hyper-parameters and offers ``selected_params()``
(ESZSL's ridges, SAE's ``lam``, the DAP attribute bank's exact or approximate solver and, with
``calibration_refit="pinned"``, the default, each of its attribute classifiers' chosen ``C`` /
``gamma``) is refitted on the folds
with its choice pinned, so the fold scores have the scale of the final model (a re-tuned ridge,
or an exact model where the final one is approximate, changes the scale of the class scores, and
with it the temperature) and a fold refit costs one fit per attribute classifier instead of its
hyper-parameter search (with ``calibration_refit="search"`` the folds search the attribute
classifiers' grids again, as before). The ECE and accuracy of both on confirmation splits are
compared by ``experiments/benchmarks/calibration_refit.py``.

Dividing by ``T > 0`` keeps every trial's ranking, so :meth:`~CalibratedZeroShotClassifier.predict`
and every accuracy are those of the method alone. Test objects are never used.

When the training classes are too few for pseudo-unseen folds (fewer than 4: no fold can hold
out 2 classes and train on 2; or a fold whose training classes leave no attribute to learn, as
with 5 classes and 0/1 attributes), the estimator keeps ``T = 1``, warns
(:class:`CalibrationWarning`) and records why in ``calibration_info_`` (``"fitted": False``),
which the method comparison and ``tzsl predict --json`` show.
"""

from __future__ import annotations

import warnings
from numbers import Integral

import numpy as np
from scipy.optimize import minimize_scalar
from scipy.special import log_softmax
from sklearn.base import BaseEstimator, clone
from sklearn.utils._param_validation import HasMethods, Interval, StrOptions
from sklearn.utils.validation import check_is_fitted

from tzsl._fit_store import fit_cached
from tzsl._scoring import tempered_proba
from tzsl.exceptions import ConfigError
from tzsl.models._attribute_model_base import attribute_table_tags
from tzsl.models._pseudo_unseen import (
    MAX_CALIBRATION_TRIALS,
    PER_CLASSIFIER_PARAMS,
    calibration_subsample,
    pseudo_unseen_scores,
)
from tzsl.models._validation import ValidatedParamsMixin
from tzsl.models._zsl_input import ZSLInputError

__all__ = [
    "CALIBRATIONS",
    "CALIBRATION_REFITS",
    "CalibratedZeroShotClassifier",
    "CalibrationWarning",
    "MAX_CALIBRATION_TRIALS",
    "calibration_subsample",
    "fit_temperature",
    "pseudo_unseen_scores",
    "selected_params",
    "tempered_proba",
]

#: Values of the ``calibration`` parameter: a fitted temperature, or none (the method's own softmax).
CALIBRATIONS = ("temperature", "none")

#: Values of the ``calibration_refit`` parameter: the folds keep every chosen hyper-parameter of the
#: final fit, or search the attribute classifiers' hyper-parameters again (the solver stays pinned).
CALIBRATION_REFITS = ("pinned", "search")

#: Search range of ``log T`` (T from about 0.007 to 150).
LOG_T_BOUNDS = (-5.0, 5.0)


class CalibrationWarning(UserWarning):
    """The calibrator could not be fitted (too few training classes): ``T = 1`` was kept."""


def fit_temperature(scores: list[np.ndarray], y_true: list[np.ndarray], *,
                    log_bounds: tuple[float, float] = LOG_T_BOUNDS) -> float:
    """The temperature minimising the log-loss of held-out trials, ``argmin_T -sum log softmax(s / T)_y``.

    Parameters
    ----------
    scores : list of ndarray of shape (n_trials_f, n_classes_f)
        Class scores of each fold's held-out trials among that fold's candidate classes.
    y_true : list of int ndarray of shape (n_trials_f,)
        Column of each trial's true class.
    log_bounds : (float, float), default=LOG_T_BOUNDS
        Search interval of ``log T``.

    Returns
    -------
    float
        ``T`` in ``exp(log_bounds)``: > 1 softens an over-confident posterior, < 1 sharpens. A score of
        ``-inf`` leaves that class out of that trial's candidates (pools of different sizes).

    Raises
    ------
    ConfigError
        No trials, or non-finite scores.
    """
    S = [np.asarray(s, dtype=np.float64) for s in scores]
    Y = [np.asarray(y, dtype=int) for y in y_true]
    if not S or sum(len(y) for y in Y) == 0:
        raise ConfigError("fit_temperature: no held-out trials to fit the temperature on")
    if not all(not np.isnan(s).any() and not np.isposinf(s).any() and np.isfinite(s[np.arange(len(y)), y]).all()
               for s, y in zip(S, Y, strict=True)):
        raise ConfigError("fit_temperature: class scores hold NaN or +inf values, or a true class scored -inf")

    def nll(log_t: float) -> float:
        t = np.exp(log_t)
        return -float(sum(log_softmax(s / t, axis=1)[np.arange(len(y)), y].sum() for s, y in zip(S, Y, strict=True)))

    best = minimize_scalar(nll, bounds=log_bounds, method="bounded", options={"xatol": 1e-4})
    return float(np.exp(best.x))


def selected_params(model, refit: str = CALIBRATION_REFITS[0]) -> dict:
    """What a calibration fold pins of a fitted attribute model: ``model.selected_params()`` when it has
    that method, else {}; without :data:`PER_CLASSIFIER_PARAMS` when ``refit == "search"``.

    Parameters
    ----------
    model : fitted attribute model or None
    refit : {"pinned", "search"}, default="pinned"
        :data:`CALIBRATION_REFITS`.

    Returns
    -------
    dict
        ``set_params`` keywords for an unfitted clone of ``model``.
    """
    pick = getattr(model, "selected_params", None)
    chosen = pick() if callable(pick) else {}
    if refit == "search":
        chosen.pop(PER_CLASSIFIER_PARAMS, None)
    return chosen


def _pinned_text(chosen: dict) -> str:
    """``calibration_info_["pinned"]``: ``key=value`` pairs, a per-classifier list as its count."""
    return ", ".join(f"{k}=<chosen hyper-parameters of {sum(len(row) for row in v)} attribute classifiers>"
                     if k == PER_CLASSIFIER_PARAMS else f"{k}={v}" for k, v in chosen.items())


def _pinned_summary(fitted, refit: str = CALIBRATION_REFITS[0]) -> str:
    """``calibration_info_["pinned"]`` of a fitted method: its attribute model's pinned choices, or a score
    ensemble's (``pinned_methods``) member by member (none with ``refit="search"``)."""
    if hasattr(fitted, "pinned_methods"):
        if refit != "pinned":
            return ""
        pinned, own = fitted.pinned_methods(selected_params), fitted.pinned_methods(lambda model: {})
        return "; ".join(f"{p['name']}: {_pinned_text({k: v for k, v in p.items() if k not in q})}"
                         for p, q in zip(pinned, own, strict=True) if len(p) > len(q))
    return _pinned_text(selected_params(getattr(fitted, "attribute_model_", None), refit))


def _pinned(template, fitted, refit: str = CALIBRATION_REFITS[0]):
    """``template`` (unfitted) with the fitted method's tuned choices pinned: its attribute model's
    (``selected_params``; with ``refit="search"`` without the per-classifier ones), or, for a score
    ensemble (``pinned_methods``), its members' as the ensemble says (``pin_members``) with
    ``refit="pinned"`` and none with ``"search"`` (every member searches again)."""
    if hasattr(fitted, "pinned_methods"):
        if refit == "pinned":
            template.set_params(methods=fitted.pinned_methods(selected_params))
        return template
    chosen = selected_params(getattr(fitted, "attribute_model_", None), refit)
    if chosen and "attribute_model" in template.get_params(deep=False):
        template.set_params(**{f"attribute_model__{k}": v for k, v in chosen.items()})
    return template


class CalibratedZeroShotClassifier(ValidatedParamsMixin, BaseEstimator):
    """A zero-shot method whose ``predict_proba`` is calibrated on pseudo-unseen training classes.

    See the module docstring for how the temperature is fitted.

    Parameters
    ----------
    estimator : zero-shot estimator
        ``fit(X, Y, groups=None)``, ``decision_function(X, class_attributes=None)`` and
        ``predict(X, class_attributes=None)`` (a :class:`~tzsl.models.ZeroShotClassifier`, the
        score ensemble). Cloned.
    calibration : {"temperature", "none"} or None, default="temperature"
        ``"none"`` / None: ``predict_proba`` is the method's own softmax (``T = 1``, no extra fits).
    calibration_folds : int >= 2, default=3
        Class-grouped folds of pseudo-unseen classes (each costs one more fit of the method).
    calibration_max_trials : int >= 2 or None, default=MAX_CALIBRATION_TRIALS
        Deal the folds on a seeded subsample of about this many training trials (every class and
        object keeps its share, :func:`calibration_subsample`) when there are more, so each fold's
        fit costs at most that of this many trials; None: on all of them. Below it the result
        does not depend on this parameter.
    calibration_refit : {"pinned", "search"}, default="pinned"
        ``"pinned"``: each fold refits the attribute classifiers with the hyper-parameters the
        final fit chose (``C``, ``gamma``; one under-sampling draw), so a fold costs one fit of
        each instead of its search; ``"search"``: the folds search them again (the former
        behaviour, about ``n_C x n_gamma x n_draws`` times the fits). Either way the solver and
        the method's own tuned choices (ESZSL's ridges, SAE's ``lam``) stay pinned.
    random_state : int, RandomState instance or None, default=None
        Seeds which training class goes to which fold.

    Attributes
    ----------
    estimator_ : fitted estimator
        The method fitted on all training trials.
    temperature_ : float
        ``T`` (1.0 when not calibrated).
    calibration_info_ : dict
        How ``T`` was fitted: ``method`` ("temperature" or "none"), ``fitted`` (bool),
        ``temperature``, ``n_folds``, ``n_classes`` (training classes), ``n_held_out_trials``
        (the trials the folds were dealt on: all, or the subsample), ``n_training_trials``,
        ``n_attributes_left_out`` (summed over folds), ``pinned`` (hyper-parameters held at the
        final fit's choice in the folds),
        ``log_loss_before`` / ``log_loss_after`` (per held-out trial), ``fitted_on``
        ("pseudo-unseen classes of the training objects"), ``reason`` when not fitted.
    class_attributes_ : ndarray of shape (n_train_classes, n_attributes)
        Distinct training rows (default candidates), from the method when it has them.
    n_features_in_ : int
        When the method has it.
    """

    _parameter_constraints: dict = {
        "estimator": [HasMethods(["fit", "decision_function", "predict"])],
        "calibration": [StrOptions(set(CALIBRATIONS)), None],
        "calibration_folds": [Interval(Integral, 2, None, closed="left")],
        "calibration_max_trials": [Interval(Integral, 2, None, closed="left"), None],
        "calibration_refit": [StrOptions(set(CALIBRATION_REFITS))],
        "random_state": ["random_state"],
    }

    def __init__(self, *, estimator=None, calibration="temperature", calibration_folds=3,
                 calibration_max_trials=MAX_CALIBRATION_TRIALS, calibration_refit="pinned", random_state=None):
        self.estimator = estimator
        self.calibration = calibration
        self.calibration_folds = calibration_folds
        self.calibration_max_trials = calibration_max_trials
        self.calibration_refit = calibration_refit
        self.random_state = random_state

    def __sklearn_tags__(self):
        return attribute_table_tags(super().__sklearn_tags__())

    def fit(self, X, Y, groups=None):
        """Fit the temperature on pseudo-unseen training classes, then the method on all trials.

        Parameters
        ----------
        X : array-like of shape (n_trials, n_features) or (n_trials, n_sensors, n_features)
        Y : array-like of shape (n_trials, n_attributes)
            Attribute row of each trial's class (1-D: one attribute).
        groups : array-like of shape (n_trials,), optional
            Object of each trial.

        Returns
        -------
        self
        """
        self._validate_params()
        if self.estimator is None:
            raise ConfigError("CalibratedZeroShotClassifier: estimator is required")
        if Y is None:
            raise ValueError(f"{type(self).__name__} requires y to be passed, but the target y is None")
        self.estimator_ = fit_cached(self.estimator, X, Y, groups)  # one fit per configuration (module docstring)
        A = np.asarray(Y, dtype=np.float64)
        A = A.reshape(-1, 1) if A.ndim == 1 else A
        n_classes = len(np.unique(A, axis=0))
        info = {"method": "none" if self.calibration in (None, "none") else "temperature", "fitted": False,
                "temperature": 1.0, "n_folds": 0, "n_classes": n_classes, "n_held_out_trials": 0,
                "n_training_trials": int(A.shape[0]),
                "fitted_on": "pseudo-unseen classes of the training objects (class-grouped folds)"}
        if info["method"] == "temperature":
            pinned = _pinned(clone(self.estimator), self.estimator_, self.calibration_refit)
            info.update(self._fit_temperature(pinned, X, A, groups, n_classes))
        self.temperature_ = float(info["temperature"])
        self.calibration_info_ = info
        for name in ("class_attributes_", "n_features_in_"):
            if hasattr(self.estimator_, name):
                setattr(self, name, getattr(self.estimator_, name))
        return self

    def _fit_temperature(self, template, X, A, groups, n_classes: int) -> dict:
        try:
            folds = pseudo_unseen_scores(template, X, A, groups, n_folds=self.calibration_folds,
                                         random_state=self.random_state, max_trials=self.calibration_max_trials)
        except ZSLInputError as exc:  # too few classes for pseudo-unseen folds: say so, keep T = 1
            reason = f"not calibrated: {n_classes} training classes are too few for pseudo-unseen folds ({exc})"
            warnings.warn(f"{type(self.estimator).__name__}: {reason}; predict_proba is the method's own softmax",
                          CalibrationWarning, stacklevel=3)
            return {"reason": reason}
        scores, ys = [s for s, _, _ in folds], [y for _, y, _ in folds]
        t = fit_temperature(scores, ys)
        n = sum(len(y) for y in ys)

        def loss(temp: float) -> float:
            return -sum(log_softmax(s / temp, axis=1)[np.arange(len(y)), y].sum()
                        for s, y in zip(scores, ys, strict=True)) / n

        return {"fitted": True, "temperature": t, "n_folds": len(folds), "n_held_out_trials": n,
                "pinned": _pinned_summary(self.estimator_, self.calibration_refit),
                "n_attributes_left_out": int(sum(d for _, _, d in folds)),
                "log_loss_before": float(loss(1.0)), "log_loss_after": float(loss(t))}

    def decision_function(self, X, class_attributes=None) -> np.ndarray:
        """The method's class scores (not tempered); shape (n_trials, n_classes)."""
        check_is_fitted(self)
        return self.estimator_.decision_function(X, class_attributes)

    def predict_proba(self, X, class_attributes=None) -> np.ndarray:
        """Calibrated class posteriors ``softmax(scores / T)`` over the candidate classes; (n_trials, n_classes)."""
        return tempered_proba(self.decision_function(X, class_attributes), self.temperature_)

    def predict_proba_uncalibrated(self, X, class_attributes=None) -> np.ndarray:
        """The method's own posteriors (``T = 1``), for reporting before / after; (n_trials, n_classes)."""
        check_is_fitted(self)
        return self.estimator_.predict_proba(X, class_attributes)

    def predict(self, X, class_attributes=None) -> np.ndarray:
        """The method's prediction (a temperature does not change the ranking); shape (n_trials,)."""
        check_is_fitted(self)
        return self.estimator_.predict(X, class_attributes)
