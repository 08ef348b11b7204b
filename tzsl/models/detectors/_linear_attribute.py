"""One attribute, one sensor: a linear detector (L2 logistic regression or linear SVM) on z-scored features.

The linear counterpart of :class:`~tzsl.models.AttributeSVM`: ``C`` is chosen by object-grouped
cross-validation on the training objects (the class-balanced log-loss of Platt-mapped out-of-fold
scores, as the SVM's grid is scored), the grid is widened at whichever end the choice sits
(:func:`~tzsl.models.detectors._attribute_search.adaptive_grid_search`, as ``grid="adaptive"``) so that it
contains its optimum, and the posterior is Platt's sigmoid of the linear score fitted on the
out-of-fold scores of training objects. No kernel and no under-sampling: a fit's time is linear in
trials (``weighting="robust"`` adds ``(robust_rounds + 1) * (folds + 1)`` fits at the chosen ``C``).

A flexible RBF kernel can recognise which training object a test trial resembles and then
predicts that object's attributes together; a linear detector is pushed toward the attribute's
direction in feature space. Which is better depends on the data set (``docs/user_guide/methods.md``);
:class:`~tzsl.models.AttributeClassifierBank` chooses with ``detector="auto"``.

``weighting`` sets how trials count in the fit: ``"class"`` (the two classes weigh equally),
``"object"`` (every object weighs equally within its class: objects with many trials do not
dominate), or ``"robust"``: group-robust training over training objects (group DRO, Sagawa et
al. 2020, with exponentiated-gradient object weights): starting from ``"object"``, for
``robust_rounds`` rounds the weight of each object is multiplied by ``exp(robust_step * L_g)``, with
``L_g`` its mean training loss (nats), and renormalised within its class, so the fit is pulled
toward the objects it fits worst instead of the typical ones.
"""

from __future__ import annotations

from numbers import Integral, Real

import numpy as np
from scipy.special import log_expit
from sklearn.base import BaseEstimator, ClassifierMixin, clone
from sklearn.linear_model import LogisticRegression
from sklearn.preprocessing import StandardScaler
from sklearn.svm import LinearSVC
from sklearn.utils import check_random_state
from sklearn.utils._param_validation import HasMethods, Interval, StrOptions
from sklearn.utils.multiclass import check_classification_targets
from sklearn.utils.validation import check_is_fitted, validate_data

from tzsl._parallel import one_blas_thread
from tzsl.models._validation import ParameterError, ValidatedParamsMixin
from tzsl.models.detectors._attribute_search import MAX_GRID_EXTENSIONS, adaptive_grid_search
from tzsl.models.detectors._attribute_training import (
    AttributeTrainingError,
    balanced_sample_weights,
    binary_training_targets,
    cv_criteria,
    grid_edges,
    object_balanced_weights,
    object_grouped_folds,
)
from tzsl.models.detectors._platt_binary import PlattBinaryClassifierMixin

__all__ = ["LINEAR_LOSSES", "TRIAL_WEIGHTINGS", "LinearAttribute"]

#: ``loss`` options: L2 logistic regression, or a linear SVM (L2-regularised squared hinge).
LINEAR_LOSSES = ("log_loss", "squared_hinge")
#: ``weighting`` options (module docstring).
TRIAL_WEIGHTINGS = ("class", "object", "robust")


def _linear_fit(loss: str, C: float, Z: np.ndarray, yb: np.ndarray, w: np.ndarray,
                seed: int) -> LogisticRegression | LinearSVC:
    """The fitted sklearn linear model of ``loss`` on ``Z`` (n, d) with 0/1 targets and trial weights ``w``."""
    if loss == "log_loss":
        model = LogisticRegression(C=C, solver="newton-cholesky", max_iter=1000)
    else:
        model = LinearSVC(C=C, dual="auto", max_iter=5000, random_state=seed)
    return model.fit(Z, yb.astype(int), sample_weight=w)


def _trial_losses(loss: str, score: np.ndarray, yb: np.ndarray) -> np.ndarray:
    """Each trial's training loss (nats for log-loss) of the linear score ``score``; shape (n,)."""
    margin = np.where(yb, score, -score)
    if loss == "log_loss":
        return -log_expit(margin)
    return np.maximum(0.0, 1.0 - margin) ** 2


def robust_object_weights(loss: str, C: float, Z: np.ndarray, yb: np.ndarray, groups: np.ndarray,
                          rounds: int, step: float, seed: int) -> np.ndarray:
    """Trial weights of group-robust training over objects (exponentiated-gradient group DRO).

    Parameters
    ----------
    loss : {"log_loss", "squared_hinge"}
    C : float
    Z : ndarray of shape (n_trials, n_features)
        Preprocessed training trials.
    yb : ndarray of bool, shape (n_trials,)
    groups : ndarray of shape (n_trials,)
        Object of each trial.
    rounds : int
        Reweighting rounds (0: the object-balanced weights).
    step : float
        Multiplier of an object's mean loss in the exponent.
    seed : int

    Returns
    -------
    ndarray of shape (n_trials,)
        Weights summing to ``n / 2`` per class; within a class, an object's total weight grows
        with its training loss in the earlier rounds.
    """
    w0 = object_balanced_weights(yb, groups)
    _, g = np.unique(groups, return_inverse=True)
    g = g.ravel()
    log_m = np.zeros(g.max() + 1)  # log multiplier of each object
    w = w0
    for _ in range(rounds):
        model = _linear_fit(loss, C, Z, yb, w, seed)
        per_trial = _trial_losses(loss, model.decision_function(Z), yb)
        mean_loss = np.bincount(g, weights=per_trial) / np.bincount(g)
        log_m += step * mean_loss
        w = w0 * np.exp(log_m[g] - log_m.max())
        for cls in (True, False):  # each class keeps its total weight
            mask = yb == cls
            w[mask] *= w0[mask].sum() / w[mask].sum()
    return w


class LinearAttribute(PlattBinaryClassifierMixin, ValidatedParamsMixin, ClassifierMixin, BaseEstimator):
    """Linear detector for one attribute and one sensor: ``C`` by object-grouped CV, Platt posteriors.

    Parameters
    ----------
    loss : {"log_loss", "squared_hinge"}, default="log_loss"
        L2 logistic regression (``LogisticRegression``), or a linear SVM (``LinearSVC``, squared
        hinge loss); either way the posterior is Platt's sigmoid of the linear score.
    C_range : (float, float), default=(0.001, 10.0)
        Ends of the starting log-spaced grid of ``C`` (inverse L2 strength on z-scored features,
        with trial weights summing to the number of trials).
    n_C : int, default=5
        Points of the starting grid (by default one per decade of ``C_range``).
    max_grid_extensions : int, default=MAX_GRID_EXTENSIONS
        While the chosen ``C`` is at an end of the grid, one log step is added beyond that end and
        the grid searched again (same folds; only the new points are fitted), at most this many
        times per end. 0 searches the starting grid only.
    cv : None or int >= 2 or splitter, default=5
        Object-grouped folds of the training trials (``None``: leave-one-object-out; int:
        stratified group k-fold over objects, at most the number of objects of the rarer class).
    weighting : {"class", "object", "robust"}, default="class"
        How trials count in the fit (module docstring): classes equally; objects equally within
        their class; or group-robust over objects.
    robust_rounds : int, default=5
        Reweighting rounds of ``weighting="robust"``.
    robust_step : float, default=1.0
        Step of ``weighting="robust"``: an object's weight is multiplied by ``exp(step * L)`` per
        round, ``L`` its mean training loss.
    preprocessor : transformer or None, default=None
        Fitted on the training trials (no labels); ``None``: ``StandardScaler`` (z-score).
    name : str or None, default=None
        Attribute name used in messages.
    random_state : int, RandomState or None, default=None
        Seeds the shuffled object-grouped folds and ``LinearSVC``.

    Attributes
    ----------
    classes_ : ndarray of shape (2,)
    n_features_in_ : int
    preprocessor_ : fitted transformer
    estimator_ : fitted LogisticRegression or LinearSVC
        On all training trials with the chosen ``C``.
    C_ : float
        Chosen ``C``.
    C_grid_ : ndarray of shape (n_C_searched,)
        The final, possibly widened, grid (increasing).
    cv_scores_ : ndarray of shape (n_C_searched,)
        Grouped-CV class-balanced log-loss (nats) of each ``C`` (lower is better); with
        ``weighting="robust"``, of the object-weighted fits (``C`` is chosen without the robust
        rounds, which then run at that ``C`` only: the search costs no more than ``"object"``).
    grid_edges_ : list of (str, float, str)
        ``("C", value, "low" | "high")`` if the choice is still at an end after every extension.
    platt_ : (float, float)
        Sigmoid ``p = expit(a * s + b)`` on the linear score ``s``.
    oof_scores_ : ndarray of shape (n_train,)
        Out-of-fold linear scores of the training trials for the chosen ``C`` (of the robust fits
        with ``weighting="robust"``); ``platt_`` is fitted on them.
    sample_weight_ : ndarray of shape (n_train,)
        Trial weights of the final fit.
    """

    _parameter_constraints: dict = {
        "loss": [StrOptions(set(LINEAR_LOSSES))],
        "C_range": ["array-like"],
        "n_C": [Interval(Integral, 1, None, closed="left")],
        "max_grid_extensions": [Interval(Integral, 0, None, closed="left")],
        "cv": [None, Interval(Integral, 2, None, closed="left"), HasMethods(["split"])],
        "weighting": [StrOptions(set(TRIAL_WEIGHTINGS))],
        "robust_rounds": [Interval(Integral, 0, None, closed="left")],
        "robust_step": [Interval(Real, 0, None, closed="left")],
        "preprocessor": [None, HasMethods(["fit", "transform"])],
        "name": [None, str],
        "random_state": ["random_state"],
    }

    def __init__(self, *, loss="log_loss", C_range=(0.001, 10.0), n_C=5, max_grid_extensions=MAX_GRID_EXTENSIONS,
                 cv=5, weighting="class", robust_rounds=5, robust_step=1.0, preprocessor=None, name=None,
                 random_state=None):
        self.loss = loss
        self.C_range = C_range
        self.n_C = n_C
        self.max_grid_extensions = max_grid_extensions
        self.cv = cv
        self.weighting = weighting
        self.robust_rounds = robust_rounds
        self.robust_step = robust_step
        self.preprocessor = preprocessor
        self.name = name
        self.random_state = random_state

    def _check_param_values(self) -> None:
        rng = np.asarray(self.C_range, dtype=object).ravel()
        if not (rng.size == 2 and all(isinstance(v, Real) for v in rng) and 0 < rng[0] <= rng[1]):
            raise ParameterError(f"The 'C_range' parameter of {type(self).__name__} must be (low, high) with "
                                 f"0 < low <= high. Got {self.C_range!r} instead.")

    def _weights(self, C: float, Z: np.ndarray, yb: np.ndarray, groups: np.ndarray, seed: int,
                 robust: bool) -> np.ndarray:
        """Trial weights of one fit (``weighting``; the robust rounds only if ``robust``); shape (n,)."""
        if self.weighting == "class":
            return balanced_sample_weights(yb)
        rounds = self.robust_rounds if robust and self.weighting == "robust" else 0
        return robust_object_weights(self.loss, C, Z, yb, groups, rounds, self.robust_step, seed)

    def _fit_weighted(self, C: float, Z, yb, groups, seed: int,
                      robust: bool = True) -> tuple[LogisticRegression | LinearSVC, np.ndarray]:
        w = self._weights(C, Z, yb, groups, seed, robust)
        return _linear_fit(self.loss, C, Z, yb, w, seed), w

    def _oof(self, C: float, Z, yb, groups, folds, seed: int, robust: bool) -> np.ndarray:
        """Out-of-fold linear scores (n,) of the training trials for one ``C``."""
        scores = np.empty(yb.size)
        for fold in folds:
            model, _ = self._fit_weighted(C, Z[~fold], yb[~fold], groups[~fold], seed, robust)
            scores[fold] = model.decision_function(Z[fold])
        return scores

    def fit(self, X, y, groups=None):
        """Fit on the training trials of one attribute and one sensor.

        Parameters
        ----------
        X : array-like of shape (n_trials, n_features)
            Features of one sensor (any units; z-scored by the preprocessor).
        y : array-like of shape (n_trials,)
            Two class labels (attribute absent / present); ``classes_[1]`` is "present".
        groups : array-like of shape (n_trials,), optional
            Object of each trial. ``None``: every trial is its own object.

        Returns
        -------
        self
        """
        self._validate_params()
        X, y = validate_data(self, X, y, dtype=np.float64)
        check_classification_targets(y)
        self.classes_, yb, groups = binary_training_targets(y, groups, self._label())
        rng = check_random_state(self.random_state)
        fold_seed, fit_seed = (int(s) for s in rng.randint(np.iinfo(np.int32).max, size=2))
        with one_blas_thread():  # small dense problems, many of them in parallel
            pre = StandardScaler() if self.preprocessor is None else clone(self.preprocessor)
            Z = np.asarray(pre.fit_transform(X), dtype=np.float64)
            folds = object_grouped_folds(self.cv, yb, groups, fold_seed)
            for fold in folds:
                if yb[~fold].all() or not yb[~fold].any():
                    raise AttributeTrainingError(f"{self._label()}: a cross-validation fold leaves one class "
                                                 "without training objects; use fewer folds (cv)")
            w_cal = (balanced_sample_weights(yb) if self.weighting == "class"
                     else object_balanced_weights(yb, groups))
            oof: dict[float, np.ndarray] = {}

            def search(Cs: np.ndarray, _gammas: np.ndarray):  # C is chosen without the robust rounds
                for C in Cs:
                    if float(C) not in oof:
                        oof[float(C)] = self._oof(float(C), Z, yb, groups, folds, fit_seed, robust=False)
                crit, platt = cv_criteria(np.stack([oof[float(C)] for C in Cs]), yb, w_cal, "log_loss")
                best = int(np.argmin(crit[:, 0]))  # ties: the smallest C (strongest regularisation)
                return (crit[:, 0], platt, best), (0, best)

            start = np.geomspace(float(self.C_range[0]), float(self.C_range[1]), int(self.n_C))
            Cs, _, (crit, platt, best) = adaptive_grid_search(search, start, np.ones(1), self.max_grid_extensions)
            self.C_grid_, self.cv_scores_ = Cs, crit
            self.C_ = float(Cs[best])
            self.oof_scores_ = oof[self.C_].copy()
            a, b = platt[best]
            if self.weighting == "robust":  # the robust model's own out-of-fold scores calibrate it
                self.oof_scores_ = self._oof(self.C_, Z, yb, groups, folds, fit_seed, robust=True)
                a, b = cv_criteria(self.oof_scores_[None], yb, w_cal, "log_loss")[1][0]
            self.platt_ = (float(a), float(b))
            self.estimator_, self.sample_weight_ = self._fit_weighted(self.C_, Z, yb, groups, fit_seed)
        self.grid_edges_ = grid_edges({"C": (Cs, best)})
        self.preprocessor_ = pre
        return self

    def svm_score(self, X) -> np.ndarray:
        """Linear score (logit of the logistic fit, or the SVM's signed distance).

        Parameters
        ----------
        X : array-like of shape (n_trials, n_features)

        Returns
        -------
        ndarray of shape (n_trials,)
            Positive towards ``classes_[1]``; unitless.
        """
        check_is_fitted(self)
        X = validate_data(self, X, dtype=np.float64, reset=False)
        return self.estimator_.decision_function(np.asarray(self.preprocessor_.transform(X), dtype=np.float64))
