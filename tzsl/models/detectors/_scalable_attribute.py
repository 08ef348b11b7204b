"""One attribute, one sensor, many trials: Nystroem RBF features + logistic regression, linear in trials.

The exact attribute model (:class:`tzsl.models.AttributeSVM`) solves libsvm problems on an
``n x n`` kernel for every fold, grid point and draw, so time and memory grow as ``n^2``. This
model keeps its protocol (class-balanced under-sampling of whole objects, object-grouped
cross-validation on training trials only, Platt posteriors fitted on out-of-fold scores) and
replaces the kernel machine by

* a Nystroem approximation of the RBF kernel with ``n_components`` landmarks drawn from the
  draw's trials (features of shape ``(n, n_components)``, computed in blocks of ``block_size``
  trials, so no ``n x n`` array and no ``n x n_landmarks`` kernel beyond one block exists), and
* an L2 logistic regression with ``class_weight="balanced"``, fitted along an increasing ``C``
  path with warm starts (each fit starts from the previous ``C``'s solution), so the ``C`` grid
  costs little more than its largest fit.

Above ``max_tune_trials`` training trials the search (draw, ``gamma``, ``C`` and the Platt
sigmoid) runs on a random subset of that many trials, taken from every object in proportion to
its trials, and only the chosen model is refitted on all trials of the chosen draw (``C`` scaled
by subset / full draw size, so the L2 penalty per trial stays the same), so the search costs a
constant and the whole fit grows linearly in trials. Above ``max_fit_trials`` trials in the chosen
draw, that refit uses about ``max_fit_trials`` of them, again from every object in proportion (with
``n_components`` features the logistic fit is settled long before a million trials), so the only
parts of a fit that grow with trials are the preprocessor and the bookkeeping of the draws. A
preprocessor fitted on an array is reused by the next fit on an equal array in the same process
(the bank fits every attribute of a sensor on the same features), and scores are computed block by
block from the kernel (``kernel @ (normalization.T @ coef)``), so predicting holds no
``(n, n_components)`` array.

Memory: ``O(n * d)`` for the trials and their preprocessed features, plus ``O(m * n_components)``
for the features of the refit, ``m = min(draw, max_fit_trials)``, and ``O(block_size *
n_components)`` scratch. Time: the search is a constant; the refit is ``O(m * n_components * (d +
n_components))`` for its features plus the solver iterations (each ``O(m * n_components)``).
"""

from __future__ import annotations

import copy
import threading
import warnings
from collections import OrderedDict
from numbers import Integral, Real

import joblib
import numpy as np
from scipy.special import log_expit
from sklearn import config_context
from sklearn.base import BaseEstimator, ClassifierMixin, clone
from sklearn.exceptions import ConvergenceWarning
from sklearn.kernel_approximation import Nystroem
from sklearn.linear_model import LogisticRegression
from sklearn.metrics.pairwise import rbf_kernel
from sklearn.model_selection import StratifiedGroupKFold
from sklearn.utils import check_random_state
from sklearn.utils._param_validation import Interval, StrOptions
from sklearn.utils.multiclass import check_classification_targets
from sklearn.utils.validation import check_is_fitted, validate_data

from tzsl._fit_store import array_digest
from tzsl._parallel import one_blas_thread
from tzsl.exceptions import ConfigError
from tzsl.models._zsl_input import share_of_objects
from tzsl.models.detectors._attribute_training import (
    AttributeTrainingError,
    balanced_object_draws,
    balanced_sample_weights,
    default_preprocessor,
    fit_platt,
    fit_platt_many,
)
from tzsl.models.detectors._platt_binary import PlattBinaryClassifierMixin

__all__ = ["MAX_TUNE_TRIALS", "ScalableAttributeClassifier"]

#: Default ``max_tune_trials``: training trials the hyper-parameter search of one attribute model uses
#: (a larger training set is subsampled, every object keeping its share). Chosen for cost, not accuracy
#: (``make bench-scale``, SIMULATED data): the search is the fixed part of every fit (draws x gammas x
#: (folds + 1) warm-started ``C`` paths), linear in this number, and with 30 attributes x 2 sensors it
#: dominates a large run; the rule was the largest of 2,000 / 4,000 / 8,000 whose 100,000-trial
#: DAP + ESZSL benchmark run (``make bench-scale SCALE_SIZES=100000``) fits issue 33's wall-time goal
#: on 2 cores in CPU time (CPU seconds at most twice the goal's wall seconds); 8,000 was over it or
#: at its edge (the run's method comparison and tables do not run in parallel), so 4,000.
MAX_TUNE_TRIALS = 4_000

#: Fitted preprocessors kept per process, keyed by (preprocessor parameters, training array digest).
_PREPROCESSOR_MEMO: OrderedDict = OrderedDict()
_PREPROCESSOR_MEMO_SIZE = 4
_PREPROCESSOR_LOCK = threading.Lock()


def _fitted_preprocessor(template, X: np.ndarray):
    """A fitted clone of ``template`` on ``X`` (n_trials, n_features): ``clone(template).fit(X)``.

    The preprocessor sees no labels, so every attribute of a sensor fits the same one: the last
    few fits of this process are kept and a copy is returned for an equal (parameters, array)
    pair instead of fitting again. Deterministic either way (always ``fit`` then ``transform``).
    """
    key = (joblib.hash(clone(template)), array_digest(X))
    with _PREPROCESSOR_LOCK:
        fitted = _PREPROCESSOR_MEMO.get(key)
        if fitted is not None:
            _PREPROCESSOR_MEMO.move_to_end(key)
    if fitted is None:
        fitted = clone(template).fit(X)
        with _PREPROCESSOR_LOCK:
            _PREPROCESSOR_MEMO[key] = fitted
            while len(_PREPROCESSOR_MEMO) > _PREPROCESSOR_MEMO_SIZE:
                _PREPROCESSOR_MEMO.popitem(last=False)
    return copy.deepcopy(fitted)


def balanced_class_weights(y_codes: np.ndarray) -> np.ndarray:
    """Per-trial weights of ``class_weight="balanced"`` for 0/1 codes ``y_codes`` (n_trials,): ``n / (2 * count)``.

    The same floats scikit-learn's ``compute_class_weight("balanced")`` gives each trial (``n /
    (n_classes * bincount)``, not :func:`balanced_sample_weights`' ``0.5 / count * n``, which rounds
    differently), computed once per path instead of once per fit; passed as ``sample_weight`` with
    ``class_weight=None`` the fit is the same bit for bit (tests/models/test_scalable_attribute.py).
    """
    counts = np.maximum(np.bincount(y_codes, minlength=2), 1).astype(np.float64)  # an absent class indexes nothing
    return (y_codes.size / (2 * counts))[y_codes]


def _range_pair(value) -> bool:
    return (isinstance(value, tuple | list) and len(value) == 2
            and all(isinstance(v, Real) for v in value) and 0 < value[0] <= value[1])


class ScalableAttributeClassifier(PlattBinaryClassifierMixin, ClassifierMixin, BaseEstimator):
    """Binary attribute classifier for large trial counts: Nystroem-RBF + warm-started logistic path.

    Parameters
    ----------
    preprocessor : transformer or None, default=None
        Fitted on the training trials (no labels). ``None``:
        :func:`tzsl.models.detectors.default_preprocessor`.
    n_components : int, default=256
        Nystroem landmarks (columns of the approximate RBF feature map); capped at the draw size.
    gamma_range : (float, float), default=(0.001, 1.0)
        Ends of the log-spaced RBF ``gamma`` grid (squared preprocessed features^-1).
    n_gamma : int, default=4
    C_range : (float, float), default=(0.1, 1000.0)
        Ends of the log-spaced grid of the logistic regression's inverse L2 strength.
    n_C : int, default=5
    cv : int, default=3
        Object-grouped stratified folds (``StratifiedGroupKFold``), at most the number of objects
        of the rarer class in the draw.
    undersampling : {"select", "none"}, default="select"
        ``"select"``: ``n_draws`` balanced draws of whole majority-class objects, keep the best by
        grouped CV; ``"none"``: all trials, classes weighted ``"balanced"``.
    n_draws : int, default=1
    platt_weighting : {"balanced", "empirical"}, default="balanced"
        As in :class:`tzsl.models.AttributeSVM`.
    block_size : int, default=8192
        Trials per block when computing the feature map (bounds the scratch memory).
    max_iter : int, default=200
        L-BFGS iterations per fit of the ``C`` path.
    max_tune_trials : int or None, default=MAX_TUNE_TRIALS
        Largest number of training trials the hyper-parameter search uses (see above); ``None``:
        all of them.
    max_fit_trials : int or None, default=100000
        Largest number of trials of the chosen draw the final refit uses (see above); ``None``:
        all of them. Below it the model does not depend on this parameter.
    name : str or None, default=None
        Attribute name used in error messages.
    random_state : int, RandomState or None, default=None
        Seeds the draws, the folds and the Nystroem landmarks.

    Attributes
    ----------
    classes_ : ndarray of shape (2,)
    n_features_in_ : int
    preprocessor_ : fitted transformer
    feature_map_ : fitted Nystroem
    coef_ : ndarray of shape (n_components,)
    intercept_ : float
    n_iter_ : int
        L-BFGS iterations of the kept fit (warm-started from the previous ``C`` of the path).
    n_fit_trials_ : int
        Training trials the kept logistic fit used (the search's, or the refit's on the draw).
    C_, gamma_ : float
    draw_ : int
    platt_ : (float, float)
        Sigmoid ``p = expit(a * s + b)`` on the linear score ``s``.
    oof_scores_ : ndarray of shape (n_tune,)
        Out-of-fold scores of the chosen setting on the search trials (``tune_index_``).
    tune_index_ : ndarray of shape (n_tune,)
        Training trials the search used (all of them up to ``max_tune_trials``).
    cv_scores_ : ndarray of shape (n_draws, n_gamma, n_C)
        Class-balanced log-loss of the Platt posteriors of the out-of-fold scores (lower is better).
    grid_edges_ : list of (str, float, str)
        Chosen hyper-parameters at an end of their grid, as in :class:`tzsl.models.AttributeSVM`.
    """

    _parameter_constraints: dict = {
        "preprocessor": "no_validation",
        "n_components": [Interval(Integral, 1, None, closed="left")],
        "gamma_range": ["array-like"],
        "n_gamma": [Interval(Integral, 1, None, closed="left")],
        "C_range": ["array-like"],
        "n_C": [Interval(Integral, 1, None, closed="left")],
        "cv": [Interval(Integral, 2, None, closed="left")],
        "undersampling": [StrOptions({"select", "none"})],
        "n_draws": [Interval(Integral, 1, None, closed="left")],
        "platt_weighting": [StrOptions({"balanced", "empirical"})],
        "block_size": [Interval(Integral, 1, None, closed="left")],
        "max_iter": [Interval(Integral, 1, None, closed="left")],
        "max_tune_trials": [None, Interval(Integral, 2, None, closed="left")],
        "max_fit_trials": [None, Interval(Integral, 2, None, closed="left")],
        "name": [None, str],
        "random_state": ["random_state"],
    }

    def __init__(self, *, preprocessor=None, n_components=256, gamma_range=(0.001, 1.0), n_gamma=4,
                 C_range=(0.1, 1000.0), n_C=5, cv=3, undersampling="select", n_draws=1,
                 platt_weighting="balanced", block_size=8192, max_iter=200, max_tune_trials=MAX_TUNE_TRIALS,
                 max_fit_trials=100_000, name=None, random_state=None):
        self.preprocessor = preprocessor
        self.n_components = n_components
        self.gamma_range = gamma_range
        self.n_gamma = n_gamma
        self.C_range = C_range
        self.n_C = n_C
        self.cv = cv
        self.undersampling = undersampling
        self.n_draws = n_draws
        self.platt_weighting = platt_weighting
        self.block_size = block_size
        self.max_iter = max_iter
        self.max_tune_trials = max_tune_trials
        self.max_fit_trials = max_fit_trials
        self.name = name
        self.random_state = random_state

    def _transform(self, feature_map: Nystroem, Z: np.ndarray) -> np.ndarray:
        """Nystroem features of ``Z`` (n, d) in blocks of ``block_size`` rows; shape (n, n_components)."""
        out = np.empty((Z.shape[0], feature_map.components_.shape[0]))
        for start in range(0, Z.shape[0], self.block_size):
            out[start : start + self.block_size] = feature_map.transform(Z[start : start + self.block_size])
        return out

    def _path(self, F_train, y_train, F_eval, Cs, out_scores, start=None) -> list[tuple[np.ndarray, float, int]]:
        """Warm-started logistic fits along ``Cs``; ``out_scores[ci]`` = scores of ``F_eval``.

        ``start``: ``(coef, intercept)`` the first fit starts from (default: zeros).
        """
        model = LogisticRegression(warm_start=True, class_weight=None, max_iter=self.max_iter, tol=1e-4)
        if start is not None:
            model.coef_, model.intercept_ = start[0][None, :].copy(), np.array([start[1]])
        # 0/1 codes, not booleans: scikit-learn encodes non-numeric labels in a Python loop over the
        # trials on every fit (same classes order, same fit); features made here are finite
        y_codes = np.asarray(y_train, dtype=np.int8)
        weights = balanced_class_weights(y_codes)
        solutions = []
        for ci, C in enumerate(Cs):
            # parameters are this method's own (validated once, in fit): not validated again per fit of the path
            with warnings.catch_warnings(), config_context(assume_finite=True, skip_parameter_validation=True):
                warnings.simplefilter("ignore", ConvergenceWarning)  # a capped step is reported through n_iter_
                model.set_params(C=float(C)).fit(F_train, y_codes, sample_weight=weights)
            coef, intercept = model.coef_[0].copy(), float(model.intercept_[0])
            solutions.append((coef, intercept, int(model.n_iter_[0])))
            if F_eval.shape[0]:
                out_scores[ci] = F_eval @ coef + intercept
        return solutions

    def fit(self, X, y, groups=None):
        """Fit on the training trials of one attribute and one sensor.

        Parameters
        ----------
        X : array-like of shape (n_trials, n_features)
        y : array-like of shape (n_trials,)
            Two classes; ``classes_[1]`` is "present".
        groups : array-like of shape (n_trials,), optional
            Object of each trial. ``None``: every trial is its own object.

        Returns
        -------
        self
        """
        self._validate_params()
        for nm in ("gamma_range", "C_range"):
            if not _range_pair(getattr(self, nm)):
                raise ConfigError(f"{nm} must be (low, high) with 0 < low <= high, got {getattr(self, nm)!r}")
        X, y = validate_data(self, X, y, dtype=np.float64)
        check_classification_targets(y)
        self.classes_ = np.unique(y)
        if self.classes_.size != 2:
            raise AttributeTrainingError(
                f"{self._label()}: training labels hold {self.classes_.size} class(es); need exactly 2 "
                "(absent and present). Only binary classification is supported."
            )
        yb = y == self.classes_[1]
        n = yb.size
        groups = np.arange(n) if groups is None else np.asarray(groups)
        if groups.shape != (n,):
            raise ConfigError(f"groups must have shape ({n},), got {groups.shape}")
        for cls, mask in ((self.classes_[1], yb), (self.classes_[0], ~yb)):
            if np.unique(groups[mask]).size < 2:
                raise AttributeTrainingError(
                    f"{self._label()}: fewer than 2 training objects with label {cls!r}; need at least 2"
                )
        rng = check_random_state(self.random_state)
        with one_blas_thread():
            self._fit(X, yb, groups, rng)
        return self

    def _search(self, Z, yb, groups, draws, Cs, gammas, fold_seed: int, map_seed: int):
        """Grouped-CV search over draws x gammas x Cs on ``Z`` (n, d); the chosen setting and its parts."""
        n = yb.size
        w_cal = balanced_sample_weights(yb) if self.platt_weighting == "balanced" else np.ones(n)
        oof = np.empty((len(draws), gammas.size, Cs.size, n))
        full: dict[tuple[int, int], tuple[Nystroem, list]] = {}
        for di, keep in enumerate(draws):
            idx, out = np.flatnonzero(keep), np.flatnonzero(~keep)
            y_draw = yb[idx]
            n_min = min(np.unique(groups[idx][y_draw]).size, np.unique(groups[idx][~y_draw]).size)
            splitter = StratifiedGroupKFold(n_splits=min(self.cv, n_min), shuffle=True, random_state=fold_seed)
            folds = list(splitter.split(np.zeros((idx.size, 1)), y_draw, groups[idx]))
            for gi, gamma in enumerate(gammas):
                # n_jobs=1: inside a Dask task joblib's context would split the kernel into chunks
                # (n_jobs=None follows it), and other matrix shapes round differently from a local run
                feature_map = Nystroem(gamma=float(gamma), n_components=min(self.n_components, idx.size),
                                       random_state=map_seed, n_jobs=1).fit(Z[idx])
                F = self._transform(feature_map, Z)
                F_draw = F[idx]
                for tr, te in folds:
                    scores = np.empty((Cs.size, te.size))
                    self._path(F_draw[tr], y_draw[tr], F_draw[te], Cs, scores)
                    oof[di, gi, :, idx[te]] = scores.T
                scores = np.empty((Cs.size, out.size))
                solutions = self._path(F_draw, y_draw, F[out], Cs, scores)
                if out.size:
                    oof[di, gi, :, out] = scores.T
                full[di, gi] = (feature_map, solutions)
        flat = oof.reshape(-1, n)
        a, b = fit_platt_many(flat, yb, w_cal)  # every configuration's sigmoid in one Newton solve
        z = a[:, None] * flat + b[:, None]
        crit = (-(w_cal * np.where(yb, log_expit(z), log_expit(-z))).sum(axis=1) / w_cal.sum()).reshape(oof.shape[:3])
        di, gi, ci = (int(i) for i in np.unravel_index(int(np.argmin(crit)), crit.shape))
        return di, gi, ci, crit, oof[di, gi, ci].copy(), w_cal, full[di, gi]

    def _fit(self, X, yb, groups, rng) -> None:
        n = yb.size
        pre = _fitted_preprocessor(self.preprocessor if self.preprocessor is not None else default_preprocessor(), X)
        Z = np.asarray(pre.transform(X), dtype=np.float64)
        (C_low, C_high), (gamma_low, gamma_high) = self.C_range, self.gamma_range  # pairs (checked in fit)
        Cs = np.geomspace(C_low, C_high, self.n_C)
        gammas = np.geomspace(gamma_low, gamma_high, self.n_gamma)
        draws, _ = balanced_object_draws(yb, groups, self.n_draws if self.undersampling == "select" else 0, rng)
        fold_seed = int(rng.randint(np.iinfo(np.int32).max))
        map_seed = int(rng.randint(np.iinfo(np.int32).max))
        tune = share_of_objects(groups, self.max_tune_trials, rng)
        sub = tune.size < n
        di, gi, ci, crit, oof, w_cal, (feature_map, solutions) = self._search(
            Z[tune] if sub else Z, yb[tune], groups[tune], [d[tune] for d in draws], Cs, gammas, fold_seed, map_seed)
        coef, intercept, n_iter = solutions[ci]
        self.n_fit_trials_ = int(draws[di][tune].sum())
        if sub:  # refit the chosen setting on the draw (up to max_fit_trials of it), from the search's solution
            idx = np.flatnonzero(draws[di])
            idx = idx[share_of_objects(groups[idx], self.max_fit_trials, rng)]
            F = self._transform(feature_map, Z[idx])
            self.n_fit_trials_ = int(idx.size)
            scale = draws[di][tune].sum() / idx.size  # same L2 penalty per trial as in the search
            ((coef, intercept, n_iter),) = self._path(F, yb[idx], F[:0], Cs[ci : ci + 1] * scale,
                                                      np.empty((1, 0)), start=(coef, intercept))
        self.preprocessor_, self.feature_map_ = pre, feature_map
        self.coef_, self.intercept_, self.n_iter_ = coef, intercept, n_iter
        self.C_, self.gamma_ = float(Cs[ci]), float(gammas[gi])
        self.draw_ = int(di) if self.undersampling == "select" else -1
        self.cv_scores_ = crit
        self.tune_index_ = tune
        self.oof_scores_ = oof
        self.platt_ = fit_platt(oof, yb[tune], w_cal)
        self.grid_edges_ = [
            (nm, float(grid[i]), "low" if i == 0 else "high")
            for nm, grid, i in (("C", Cs, ci), ("gamma", gammas, gi))
            if grid.size >= 2 and i in (0, grid.size - 1)
        ]

    def svm_score(self, X) -> np.ndarray:
        """Linear score on the approximate RBF features, shape (n_trials,); positive towards ``classes_[1]``."""
        check_is_fitted(self)
        X = validate_data(self, X, dtype=np.float64, reset=False)
        Z = np.asarray(self.preprocessor_.transform(X), dtype=np.float64)
        fm = self.feature_map_
        out = np.empty(Z.shape[0])
        with one_blas_thread():  # the same bits in every process, whatever its BLAS threads
            weights = fm.normalization_.T @ self.coef_  # the features' linear map folded into the kernel's
            for start in range(0, Z.shape[0], self.block_size):
                block = rbf_kernel(Z[start : start + self.block_size], fm.components_, gamma=fm.gamma)
                out[start : start + self.block_size] = block @ weights
        return out + self.intercept_
