"""One attribute, one sensor: an under-sampled RBF-SVM with object-grouped tuning and Platt posteriors.

This is the attribute classifier ``g_m`` of the DAP paper (section 4.4): an RBF-kernel SVM trained
on a class-balanced (under-sampled) set, ``C`` in [1, 100] and ``gamma`` in [0.01, 1] tuned by
cross-validation, and a sigmoid map from SVM score to posterior ``p(a_m = 1 | x)``.

Departures from the paper, all to keep test objects out of every choice:

* Cross-validation is grouped by object (leave-one-object-out by default), so trials of one object
  never sit on both sides of a fold.
* Under-sampling removes whole objects of the majority class (not single trials), so that every
  object is either fully in or fully out of a draw; residual imbalance in trial counts is handled
  by ``class_weight="balanced"``.
* The kept draw ("select") is chosen by the grouped-CV score over *all training trials*, never on
  test objects (the paper kept the draws "giving the best results").
* The Platt sigmoid is fitted on out-of-fold decision values of training objects.

Speed: for each ``gamma`` the RBF Gram matrix of the training trials is computed once and every
fit uses ``SVC(kernel="precomputed")``. A held-out object that is not in a draw is scored by the
draw's full model (which never saw it), so only folds that hold out an object of the draw need a
refit: with ``m`` objects in a draw and a ``g x c`` grid that is ``g * c * (m + 1)`` fits per draw.
"""

from __future__ import annotations

import warnings
from numbers import Integral

import numpy as np
from joblib import Parallel, delayed
from scipy.optimize import minimize
from scipy.special import expit, log_expit
from sklearn import config_context
from sklearn.base import BaseEstimator, ClassifierMixin, clone
from sklearn.metrics.pairwise import euclidean_distances, rbf_kernel
from sklearn.model_selection import LeaveOneGroupOut, StratifiedGroupKFold
from sklearn.svm import SVC
from sklearn.svm import _libsvm  # noqa: PLC2701 - see _svc_fit_decision
from sklearn.utils import check_random_state
from sklearn.utils.multiclass import check_classification_targets
from sklearn.utils.validation import check_is_fitted, validate_data
from threadpoolctl import threadpool_limits
from tqdm.auto import tqdm

from tzsl.exceptions import ConfigError, SplitError
from tzsl.features import VariancePCA
from tzsl.models._cache import fit_clone, parallel_context, resolve_memory, spawn_seeds

__all__ = [
    "AttributeClassifierBank",
    "AttributeSVM",
    "AttributeTrainingError", "GridEdgeWarning", "balanced_object_draws", "default_preprocessor", "fit_platt"]

_UNDERSAMPLING = ("select", "bagging", "none")
SOLVERS = ("exact", "approximate", "auto")
AUTO_MAX_EXACT_TRIALS = 3000
_SCORING = ("log_loss", "balanced_accuracy")
_PLATT_WEIGHTING = ("balanced", "empirical")


class GridEdgeWarning(UserWarning):
    """A tuned hyper-parameter was chosen at the low or high end of its grid (the optimum may lie outside)."""


def _grid_edges(chosen: dict[str, tuple[np.ndarray, int]]) -> list[tuple[str, float, str]]:
    """``(name, value, "low" | "high")`` for each chosen grid index at an end of a grid of >= 2 points."""
    edges = []
    for name, (grid, i) in chosen.items():
        if grid.size >= 2 and i in (0, grid.size - 1):
            edges.append((name, float(grid[i]), "low" if i == 0 else "high"))
    return edges


class AttributeTrainingError(SplitError, ValueError):
    """An attribute cannot be learned from the training objects of a split.

    A :class:`tzsl.exceptions.SplitError` (and a ``ValueError``, as scikit-learn expects of
    estimators given unusable targets).
    """


def default_preprocessor() -> BaseEstimator:
    """Z-score then PCA keeping 95% of the variance, capped at 25 components (DAP paper §4.3).

    Returns
    -------
    tzsl.features.VariancePCA
        ``VariancePCA(variance=0.95, max_components=25)``, unfitted.
    """
    return VariancePCA(variance=0.95, max_components=25)


def fit_platt(
    scores: np.ndarray, y: np.ndarray, sample_weight: np.ndarray | None = None
) -> tuple[float, float]:
    """Fit Platt's sigmoid ``p(y = 1 | s) = expit(a * s + b)``.

    Uses Platt's (1999) smoothed targets ``(N+ + 1) / (N+ + 2)`` and ``1 / (N- + 2)``, which keep
    the fit finite on separable scores. The slope is constrained to ``a >= 0``.

    Parameters
    ----------
    scores : ndarray of shape (n,)
        Classifier scores (SVM decision values, unitless).
    y : ndarray of shape (n,)
        0/1 labels.
    sample_weight : ndarray of shape (n,), optional
        Non-negative weights.

    Returns
    -------
    a, b : float
        Slope and intercept of the logit.
    """
    s = np.asarray(scores, dtype=float)
    y = np.asarray(y).astype(bool)
    w = np.ones_like(s) if sample_weight is None else np.asarray(sample_weight, dtype=float)
    n_pos, n_neg = int(y.sum()), int((~y).sum())
    t = np.where(y, (n_pos + 1.0) / (n_pos + 2.0), 1.0 / (n_neg + 2.0))
    scale = float(np.std(s)) or 1.0
    u = s / scale  # conditioning only; undone below
    w_pos, w_neg = w[y].sum(), w[~y].sum()
    x0 = np.array([0.0, np.log((w_pos + 1.0) / (w_neg + 1.0))])

    def loss(theta: np.ndarray) -> tuple[float, np.ndarray]:
        z = theta[0] * u + theta[1]
        nll = -(w * (t * log_expit(z) + (1.0 - t) * log_expit(-z))).sum()
        r = w * (expit(z) - t)
        return float(nll), np.array([(r * u).sum(), r.sum()])

    # a >= 0: the map must increase with the score. Without it, leave-one-object-out scores of
    # near-constant models (large gamma) are perfectly *anti*-correlated with the label (holding
    # out a positive object shifts the intercept down), and a negative slope would "win" the CV.
    res = minimize(loss, x0, jac=True, method="L-BFGS-B", bounds=[(0.0, None), (None, None)])
    return float(res.x[0] / scale), float(res.x[1])


_UNIT_WEIGHT = np.ones(2)
_EMPTY = np.empty(0)


def _balanced_class_weight(y: np.ndarray) -> np.ndarray:
    """``class_weight="balanced"`` of ``SVC`` for 0/1 labels: ``n / (2 * count)``; shape (2,)."""
    counts = np.bincount(y.astype(np.intp), minlength=2)
    return y.size / (2 * counts.astype(np.float64))


def _svc_fit_decision(K_train: np.ndarray, y: np.ndarray, C: float, class_weight: np.ndarray,
                      K_eval: np.ndarray) -> np.ndarray:
    """Fit a precomputed-kernel C-SVC and return its decision values on ``K_eval``.

    The same libsvm calls, with the same arguments, as ``SVC(kernel="precomputed", C=C,
    class_weight=...).fit(K_train, y).decision_function(K_eval)``, so the numbers are identical
    (``test_libsvm_path_equals_svc``), without ``SVC``'s per-call input validation, which took
    about 70% of the time on the small (a few hundred trials) problems of the grid search.

    Parameters
    ----------
    K_train : ndarray of shape (n_train, n_train), C-contiguous
        Kernel between training trials.
    y : ndarray of shape (n_train,)
        Labels as float64 0.0 / 1.0 (both present).
    C : float
    class_weight : ndarray of shape (2,)
        Multipliers of ``C`` for class 0 and class 1.
    K_eval : ndarray of shape (n_eval, n_train)
        Kernel between evaluated and training trials.

    Returns
    -------
    ndarray of shape (n_eval,)
        Decision values, positive towards class 1.
    """
    support, sv, n_sv, dual_coef, intercept, prob_a, prob_b, status, _ = _libsvm.fit(
        K_train, y, svm_type=0, kernel="precomputed", C=float(C), class_weight=class_weight,
        sample_weight=_EMPTY, cache_size=200.0, tol=1e-3, shrinking=True, max_iter=-1, random_seed=0,
    )
    if status != 0:
        raise AttributeTrainingError("libsvm did not converge on a cross-validation fit")
    dec = _libsvm.decision_function(
        K_eval, support, sv, n_sv, dual_coef, intercept, prob_a, prob_b, svm_type=0, kernel="precomputed",
        cache_size=200.0,
    )
    return -dec.ravel()


def _balanced_weights(y: np.ndarray) -> np.ndarray:
    y = y.astype(bool)
    w = np.empty(y.shape, dtype=float)
    w[y] = 0.5 / max(int(y.sum()), 1)
    w[~y] = 0.5 / max(int((~y).sum()), 1)
    return w * y.size


def balanced_object_draws(yb: np.ndarray, groups: np.ndarray, n_draws: int,
                          rng: np.random.RandomState) -> tuple[list[np.ndarray], np.ndarray]:
    """Class-balanced under-sampling draws that drop whole objects of the majority class.

    Parameters
    ----------
    yb : ndarray of bool, shape (n_trials,)
    groups : ndarray of shape (n_trials,)
        Object of each trial.
    n_draws : int
        Random draws; 0 means no under-sampling (one draw keeping every trial).
    rng : numpy.random.RandomState

    Returns
    -------
    draws : list of ndarray of bool, shape (n_trials,)
        Kept trials of each distinct draw (duplicates merged).
    weights : ndarray of shape (n_distinct_draws,)
        Fraction of the ``n_draws`` draws equal to each distinct draw.
    """
    n = yb.size
    if n_draws == 0:
        return [np.ones(n, dtype=bool)], np.ones(1)
    minority = yb.sum() * 2 <= n  # True: positives are the minority
    major = yb != minority
    # groups holding only majority trials can be dropped whole
    g_all, g_inv = np.unique(groups, return_inverse=True)
    has_minor = np.bincount(g_inv, weights=(~major).astype(float), minlength=g_all.size) > 0
    droppable = np.flatnonzero(~has_minor)
    size = np.bincount(g_inv, minlength=g_all.size)
    n_minor = int((~major).sum())
    # majority trials inside mixed groups are always kept
    kept_major_fixed = int(np.bincount(g_inv, weights=major.astype(float), minlength=g_all.size)[has_minor].sum())
    need = n_minor - kept_major_fixed
    draws = []
    for _ in range(n_draws):
        order = droppable[rng.permutation(droppable.size)]
        csum = np.cumsum(size[order])
        k = int(np.searchsorted(csum, need)) + 1 if need > 0 else 0
        k = min(k, order.size)
        keep_group = has_minor.copy()
        keep_group[order[:k]] = True
        draws.append(keep_group[g_inv])
    uniq, inverse = np.unique(np.array(draws), axis=0, return_inverse=True)
    weights = np.bincount(inverse.ravel(), minlength=len(uniq)).astype(float)
    return list(uniq), weights / weights.sum()


class AttributeSVM(ClassifierMixin, BaseEstimator):
    """Binary RBF-SVM for one attribute and one sensor, under-sampled, group-tuned, Platt-calibrated.

    Parameters
    ----------
    preprocessor : transformer or None, default=None
        Fitted on the training trials given to :meth:`fit` (no labels used), before the SVM.
        ``None`` uses :func:`default_preprocessor`: ``tzsl.features.VariancePCA(0.95, max_components=25)``.
    C_range : (float, float), default=(1.0, 100.0)
        Ends of the log-spaced grid of SVM ``C``.
    gamma_range : (float, float), default=(0.01, 1.0)
        Ends of the log-spaced grid of RBF ``gamma`` (in units of squared preprocessed features^-1).
    n_C, n_gamma : int, default=3
        Grid sizes (3 gives the decades 1, 10, 100 and 0.01, 0.1, 1).
    cv : None, int or splitter, default=None
        Object-grouped cross-validation on the training trials. ``None``: leave-one-object-out
        (``LeaveOneGroupOut``); int: ``StratifiedGroupKFold(min(cv, n), shuffle=True)`` with ``n``
        the number of objects of the rarer class in the draw (so every fold keeps both classes); or any splitter with ``split(X, y, groups)`` whose
        test folds partition the trials.
    undersampling : {"select", "bagging", "none"}, default="select"
        ``"select"``: ``n_draws`` random balanced draws, keep the (draw, C, gamma) with the best
        grouped-CV score. ``"bagging"``: average the SVM scores of all draws (tuned jointly on the
        averaged out-of-fold scores). ``"none"``: train on all trials, no balancing.
    n_draws : int, default=3
        Number of random balanced draws.
    scoring : {"log_loss", "balanced_accuracy"}, default="log_loss"
        Criterion on out-of-fold scores of all training trials: class-balanced log-loss of the
        Platt posteriors (lower is better), or balanced accuracy of the sign of the SVM score
        (ties broken by log-loss). Ties keep the earliest draw, then the smallest ``gamma``, then the smallest ``C``.
    platt_weighting : {"balanced", "empirical"}, default="balanced"
        Weight the two classes equally when fitting the sigmoid (posterior for a 50% prior, as
        for a classifier trained on balanced data) or by their training frequency (posterior
        for the training prior). DAP divides each posterior by the attribute prior ``p(a_m)``:
        ``"balanced"`` posteriors already carry a 50% prior, so they pair with DAP's ``"uni"``
        prior (dividing by 0.5 changes nothing); with DAP's ``"train"`` prior the training prior
        would be divided out twice, so that pairing needs ``"empirical"``. PHAC-2, 5 random
        splits (seed 0), AVGDAP: balanced+uni 0.310, balanced+train 0.226 (double correction),
        empirical+train 0.286, empirical+uni 0.290.
    name : str or None, default=None
        Attribute name used in error messages.
    random_state : int, RandomState or None, default=None
        Seeds the under-sampling draws and a shuffled ``StratifiedGroupKFold``.

    Attributes
    ----------
    classes_ : ndarray of shape (2,)
    n_features_in_ : int
    preprocessor_ : fitted transformer
    C_, gamma_ : float
        Chosen hyper-parameters.
    draw_ : int
        Index of the kept draw (``"select"``), -1 otherwise.
    estimators_ : list of SVC
        Fitted precomputed-kernel SVMs (one, or one per draw when bagging).
    estimator_weights_ : ndarray of shape (n_estimators,)
    train_features_ : list of ndarray of shape (n_kept, n_components)
        Preprocessed trials each SVM was trained on (needed for the kernel at predict time).
    platt_ : (float, float)
        Sigmoid ``p = expit(a * s + b)`` on the SVM score ``s``.
    oof_scores_ : ndarray of shape (n_train,)
        Out-of-fold SVM scores of the training trials for the chosen configuration.
    cv_scores_ : ndarray of shape (n_draws_or_1, n_gamma, n_C)
        Grouped-CV criterion of every configuration (lower is better; balanced accuracy is
        stored negated).
    grid_edges_ : list of (str, float, str)
        ``(parameter, value, "low" | "high")`` for each chosen ``C`` / ``gamma`` at an end of its
        grid (the grouped-CV optimum may lie outside the grid); empty when none is.
    """

    def __init__(
        self,
        preprocessor=None,
        C_range=(1.0, 100.0),
        gamma_range=(0.01, 1.0),
        n_C=3,
        n_gamma=3,
        cv=None,
        undersampling="select",
        n_draws=3,
        scoring="log_loss",
        platt_weighting="balanced",
        name=None,
        random_state=None,
    ):
        self.preprocessor = preprocessor
        self.C_range = C_range
        self.gamma_range = gamma_range
        self.n_C = n_C
        self.n_gamma = n_gamma
        self.cv = cv
        self.undersampling = undersampling
        self.n_draws = n_draws
        self.scoring = scoring
        self.platt_weighting = platt_weighting
        self.name = name
        self.random_state = random_state

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.classifier_tags.multi_class = False
        return tags

    # ------------------------------------------------------------------ helpers
    def _label(self) -> str:
        return f"attribute {self.name!r}" if self.name is not None else "attribute"

    def _check_params(self) -> None:
        if self.undersampling not in _UNDERSAMPLING:
            raise ConfigError(f"undersampling must be one of {_UNDERSAMPLING}, got {self.undersampling!r}")
        if self.scoring not in _SCORING:
            raise ConfigError(f"scoring must be one of {_SCORING}, got {self.scoring!r}")
        if self.platt_weighting not in _PLATT_WEIGHTING:
            raise ConfigError(f"platt_weighting must be one of {_PLATT_WEIGHTING}, got {self.platt_weighting!r}")
        for nm in ("n_C", "n_gamma", "n_draws"):
            v = getattr(self, nm)
            if not isinstance(v, Integral) or v < 1:
                raise ConfigError(f"{nm} must be a positive integer, got {v!r}")
        for nm in ("C_range", "gamma_range"):
            lo, hi = getattr(self, nm)
            if not (0 < lo <= hi):
                raise ConfigError(f"{nm} must be (low, high) with 0 < low <= high, got {getattr(self, nm)!r}")

    def _folds(self, yb, groups, seed: int) -> list[np.ndarray]:
        if self.cv is None:
            splitter = LeaveOneGroupOut()
        elif isinstance(self.cv, Integral):
            # never more folds than objects of the rarer class, so each fold keeps both classes
            n_min = min(np.unique(groups[yb]).size, np.unique(groups[~yb]).size)
            splitter = StratifiedGroupKFold(n_splits=min(int(self.cv), n_min), shuffle=True, random_state=seed)
        else:
            splitter = self.cv
        masks = []
        for _, test in splitter.split(np.zeros((yb.size, 1)), yb, groups):
            m = np.zeros(yb.size, dtype=bool)
            m[test] = True
            masks.append(m)
        counts = np.sum(masks, axis=0) if masks else np.zeros(yb.size)
        if not np.all(counts == 1):
            raise ConfigError("cv: the test folds must partition the training trials (each trial exactly once)")
        return masks

    def _draws(self, yb, groups, rng) -> tuple[list[np.ndarray], np.ndarray]:
        return balanced_object_draws(yb, groups, self.n_draws if self.undersampling != "none" else 0, rng)

    def _criterion(self, oof: np.ndarray, yb: np.ndarray, w_cal: np.ndarray) -> tuple[float, float]:
        a, b = fit_platt(oof, yb, w_cal)
        z = a * oof + b
        ll = float(-(w_cal * np.where(yb, log_expit(z), log_expit(-z))).sum() / w_cal.sum())
        if self.scoring == "log_loss":
            return ll, 0.0
        pred = oof > 0
        bacc = 0.5 * (pred[yb].mean() + (~pred[~yb]).mean())
        return -float(bacc), ll

    def _grid_oof(self, D, yb, groups, draws, fold_seed, Cs, gammas, cw, oof) -> None:
        """Fill ``oof[draw, gamma, C]`` with out-of-fold SVM scores of every training trial.

        The grouped folds are made over the objects of each draw; a trial outside the draw is
        scored by the draw's full model, which never saw it. Per draw and ``gamma`` the kernel of
        the draw is computed once (``np.exp`` in place on one buffer) and each fold's training
        and held-out blocks are gathered once for all ``C``; the fits call libsvm directly
        (:func:`_svc_fit_decision`), which gives the same numbers as ``SVC`` bitwise.
        """
        _libsvm.set_verbosity_wrap(0)  # libsvm's global switch; SVC sets it before every fit
        for di, keep in enumerate(draws):
            idx = np.flatnonzero(keep)
            out = np.flatnonzero(~keep)
            folds = self._folds(yb[idx], groups[idx], fold_seed)
            y_draw = yb[idx].astype(np.float64)
            for fold in folds:
                if y_draw[~fold].all() or not y_draw[~fold].any():
                    raise AttributeTrainingError(
                        f"{self._label()}: a cross-validation fold leaves one class without training "
                        "objects; use fewer folds (cv)"
                    )
            # gathered once per draw: squared distances of the draw (rows: draw, then outside trials)
            D_draw = D[np.ix_(np.concatenate([idx, out]), idx)]
            K = np.empty_like(D_draw)
            Kd, K_out = K[: idx.size], K[idx.size :]
            fold_index = [(np.flatnonzero(~f), np.flatnonzero(f)) for f in folds]
            fold_w = [_balanced_class_weight(y_draw[tr]) if cw else _UNIT_WEIGHT for tr, _ in fold_index]
            w_full = _balanced_class_weight(y_draw) if cw else _UNIT_WEIGHT
            for gi, gamma in enumerate(gammas):
                np.multiply(D_draw, -gamma, out=K)
                np.exp(K, out=K)
                Kd_c = np.ascontiguousarray(Kd)
                K_out_c = np.ascontiguousarray(K_out)
                for ci, C in enumerate(Cs):
                    if out.size:
                        oof[di, gi, ci, out] = _svc_fit_decision(Kd_c, y_draw, C, w_full, K_out_c)
                for (tr, te), w in zip(fold_index, fold_w):
                    Ktr = Kd[np.ix_(tr, tr)]
                    Kte = Kd[np.ix_(te, tr)]
                    y_tr = y_draw[tr]
                    for ci, C in enumerate(Cs):
                        oof[di, gi, ci, idx[te]] = _svc_fit_decision(Ktr, y_tr, C, w, Kte)

    def _final_svc(self, D, keep, yb, C, gamma, cw) -> SVC:
        """The ``SVC`` of one draw on all its trials for the chosen ``(C, gamma)`` (used at predict time)."""
        idx = np.flatnonzero(keep)
        K = np.exp(-gamma * D[np.ix_(idx, idx)])
        return SVC(kernel="precomputed", C=C, class_weight=cw).fit(K, yb[idx])

    # ------------------------------------------------------------------ API
    def fit(self, X, y, groups=None):
        """Fit on the training trials of one attribute and one sensor.

        Parameters
        ----------
        X : array-like of shape (n_trials, n_features)
            Features of one sensor (any units; standardised by the preprocessor).
        y : array-like of shape (n_trials,)
            Two class labels (attribute absent / present); ``classes_[1]`` is "present".
        groups : array-like of shape (n_trials,), optional
            Object of each trial. ``None``: every trial is its own object.

        Returns
        -------
        self
        """
        self._check_params()
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
            n_obj = np.unique(groups[mask]).size
            if n_obj < 2:
                raise AttributeTrainingError(
                    f"{self._label()}: only {n_obj} training object(s) with label {cls!r}; "
                    "need at least 2 (one class present in a single object cannot be cross-validated)"
                )
        rng = check_random_state(self.random_state)

        # many small dense problems: more BLAS threads than one only spin (and do not change results)
        with threadpool_limits(limits=1):
            pre = clone(self.preprocessor) if self.preprocessor is not None else default_preprocessor()
            Z = np.asarray(pre.fit_transform(X), dtype=np.float64)
            D = euclidean_distances(Z, squared=True)
            Cs = np.geomspace(*self.C_range, self.n_C)
            gammas = np.geomspace(*self.gamma_range, self.n_gamma)
            draws, draw_w = self._draws(yb, groups, rng)
            fold_seed = int(rng.randint(np.iinfo(np.int32).max))
            cw = None if self.undersampling == "none" else "balanced"

            oof = np.empty((len(draws), gammas.size, Cs.size, n))
            self._grid_oof(D, yb, groups, draws, fold_seed, Cs, gammas, cw, oof)
            w_cal = _balanced_weights(yb) if self.platt_weighting == "balanced" else np.ones(n)
            if self.undersampling == "bagging":
                oof = np.tensordot(draw_w, oof, axes=(0, 0))[None]
            crit = np.empty(oof.shape[:3] + (2,))
            for key in np.ndindex(*oof.shape[:3]):
                crit[key] = self._criterion(oof[key], yb, w_cal)
            flat = np.lexsort((crit[..., 1].ravel(), crit[..., 0].ravel()))[0]
            di, gi, ci = np.unravel_index(flat, oof.shape[:3])
            self.cv_scores_ = crit[..., 0]
            self.C_, self.gamma_ = float(Cs[ci]), float(gammas[gi])
            self.oof_scores_ = oof[di, gi, ci].copy()
            self.platt_ = fit_platt(self.oof_scores_, yb, w_cal)
        self.grid_edges_ = _grid_edges({"C": (Cs, int(ci)), "gamma": (gammas, int(gi))})
        if self.undersampling == "bagging":
            chosen = range(len(draws))
            self.draw_ = -1
            self.estimator_weights_ = draw_w
        else:
            chosen = [di]
            self.draw_ = int(di) if self.undersampling == "select" else -1
            self.estimator_weights_ = np.ones(1)
        with config_context(assume_finite=True, skip_parameter_validation=True):
            self.estimators_ = [self._final_svc(D, draws[d], yb, self.C_, self.gamma_, cw) for d in chosen]
        self.train_features_ = [Z[draws[d]] for d in chosen]
        self.preprocessor_ = pre
        return self

    def svm_score(self, X) -> np.ndarray:
        """Raw SVM decision value (averaged over draws when bagging).

        Parameters
        ----------
        X : array-like of shape (n_trials, n_features)

        Returns
        -------
        ndarray of shape (n_trials,)
            Signed distance-like score, positive towards ``classes_[1]``.
        """
        check_is_fitted(self)
        X = validate_data(self, X, dtype=np.float64, reset=False)
        Z = np.asarray(self.preprocessor_.transform(X), dtype=np.float64)
        out = np.zeros(Z.shape[0])
        for w, svc, Ztr in zip(self.estimator_weights_, self.estimators_, self.train_features_):
            out += w * svc.decision_function(rbf_kernel(Z, Ztr, gamma=self.gamma_))
        return out

    def decision_function(self, X) -> np.ndarray:
        """Logit of ``p(classes_[1] | x)`` (Platt-mapped SVM score); shape (n_trials,)."""
        check_is_fitted(self)
        a, b = self.platt_
        return a * self.svm_score(X) + b

    def predict_proba(self, X) -> np.ndarray:
        """Posteriors, shape (n_trials, 2), columns ordered as ``classes_``."""
        p1 = expit(self.decision_function(X))
        return np.column_stack([1.0 - p1, p1])

    def predict(self, X) -> np.ndarray:
        """Class with posterior >= 0.5, shape (n_trials,)."""
        check_is_fitted(self)
        return self.classes_[(self.decision_function(X) >= 0).astype(int)]


def _check_attribute_matrix(A, n: int, names) -> np.ndarray:
    A = np.asarray(A)
    if A.ndim != 2 or A.shape[0] != n:
        raise ConfigError(f"attribute targets must have shape ({n}, n_attributes), got {A.shape}")
    Af = A.astype(float)
    bad = ~np.isin(Af, (0.0, 1.0))  # NaN is not in the set either
    if bad.any():
        r, c = np.argwhere(bad)[0]
        raise AttributeTrainingError(
            f"attribute {names[c]!r}: trial row {r} has value {A[r, c].item()!r}; attribute targets must be 0/1"
        )
    return Af.astype(np.int64)


class AttributeClassifierBank(BaseEstimator):
    """Independent attribute classifiers: one per (attribute, sensor), fitted in parallel and cached.

    This is the attribute layer of DAP (paper §3.3, §4.4): attributes are assumed independent,
    and each sensor (BioTac) gets its own classifier.

    Parameters
    ----------
    estimator : classifier or None, default=None
        Template cloned for every (attribute, sensor); must accept ``fit(X, y, groups)`` and give
        ``predict_proba``. ``None``: :class:`AttributeSVM` with default parameters.
    attribute_names : sequence of str or None, default=None
        Names used in error messages (default ``"0"``, ``"1"``, ...).
    n_jobs : int or None, default=None
        Parallel fits (joblib convention; ``-1`` = all cores).
    backend : {"loky", "dask", "threading", "sequential"}, default="loky"
        joblib backend. ``"dask"`` runs the fits on the current ``dask.distributed`` Client.
        Results do not depend on the backend or ``n_jobs``.
    memory : None, str, Path or joblib.Memory, default=None
        Cache of fitted per-(attribute, sensor) models, keyed on the data and all parameters.
        ``None``: ``$TZSL_CACHE_DIR`` if set, else no caching.
    progress : bool, default=False
        Show a tqdm progress bar over the fits.
    random_state : int, RandomState or None, default=None
        Each (attribute, sensor) fit gets its own seed from ``np.random.SeedSequence``.
    solver : {"exact", "approximate", "auto"}, default="auto"
        ``"exact"``: ``estimator`` as given. ``"approximate"``: a
        :class:`tzsl.models.ScalableAttributeClassifier` (Nystroem RBF features + logistic
        regression, linear in trials) with ``estimator``'s preprocessor, under-sampling and Platt
        weighting. ``"auto"``: exact up to ``max_exact_trials`` training trials, approximate above
        (the exact model's time grows as trials^2). The choice and its reason are in
        ``solver_choice_`` and printed when ``progress`` is on.
    max_exact_trials : int, default=3000
        Largest training set fitted exactly by ``solver="auto"`` (about 15 minutes per split of
        30 attributes x 2 sensors on 2 cores at 4,000 trials, issue 15).

    Attributes
    ----------
    estimators_ : list of list of fitted classifiers
        ``estimators_[m][s]`` is attribute ``m`` on sensor ``s``.
    grid_edge_hits_ : list of dict
        One ``{"attribute", "sensor", "parameter", "value", "edge"}`` per tuned hyper-parameter
        chosen at an end of its grid (from each estimator's ``grid_edges_``); a
        :class:`GridEdgeWarning` summarises them once per :meth:`fit`.
    n_sensors_, n_attributes_, n_features_in_ : int
    solver_choice_ : dict
        ``{"solver": "exact" | "approximate", "reason": str, "n_trials": int}``.
    """

    def __init__(
        self,
        estimator=None,
        attribute_names=None,
        n_jobs=None,
        backend="loky",
        memory=None,
        progress=False,
        random_state=None,
        solver="auto",
        max_exact_trials=AUTO_MAX_EXACT_TRIALS,
    ):
        self.estimator = estimator
        self.attribute_names = attribute_names
        self.n_jobs = n_jobs
        self.backend = backend
        self.memory = memory
        self.progress = progress
        self.random_state = random_state
        self.solver = solver
        self.max_exact_trials = max_exact_trials

    def _names(self, m: int) -> list[str]:
        if self.attribute_names is None:
            return [str(i) for i in range(m)]
        names = [str(a) for a in self.attribute_names]
        if len(names) != m:
            raise ConfigError(f"attribute_names has {len(names)} names but the targets have {m} columns")
        return names

    def _template(self):
        return AttributeSVM() if self.estimator is None else self.estimator

    def _choose_template(self, n_trials: int):
        """The estimator template for ``n_trials`` training trials; sets ``solver_choice_``."""
        if self.solver not in SOLVERS:
            raise ConfigError(f"solver must be one of {SOLVERS}, got {self.solver!r}")
        exact = self._template()
        if self.solver == "auto":
            approximate = n_trials > self.max_exact_trials
            relation = ">" if approximate else "<="
            reason = f"solver='auto': {n_trials} training trials {relation} max_exact_trials={self.max_exact_trials}"
        else:
            approximate = self.solver == "approximate"
            reason = f"solver={self.solver!r}"
        self.solver_choice_ = {"solver": "approximate" if approximate else "exact", "reason": reason,
                               "n_trials": int(n_trials)}
        if self.progress:
            tqdm.write(f"attribute models: {self.solver_choice_['solver']} ({reason})")
        if not approximate:
            return exact
        from tzsl.models._scalable_attribute import ScalableAttributeClassifier  # noqa: PLC0415 (imports this module)

        shared = {k: v for k, v in exact.get_params(deep=False).items()
                  if k in ("preprocessor", "platt_weighting", "name", "random_state")}
        undersampling = exact.get_params(deep=False).get("undersampling", "select")
        shared["undersampling"] = "none" if undersampling == "none" else "select"
        return ScalableAttributeClassifier(**shared)

    def _check_fit_input(self, X, A) -> tuple[np.ndarray, np.ndarray, list[str]]:
        """``(X, A, names)``: X (n_trials, n_sensors, n_features) float64, A (n_trials, n_attributes) 0/1."""
        X = _check_3d(X)
        n = X.shape[0]
        if np.ndim(A) != 2:
            raise ConfigError(f"attribute targets must have shape ({n}, n_attributes), got {np.shape(A)}")
        names = self._names(np.shape(A)[1])
        return X, _check_attribute_matrix(A, n, names), names

    def _run_fits(self, tasks: list, desc: str) -> list:
        """Run joblib ``tasks`` on ``self.backend`` / ``self.n_jobs``; results in task order."""
        with parallel_context(self.backend):
            backend = None if self.backend == "dask" else self.backend
            results = Parallel(n_jobs=self.n_jobs, backend=backend, return_as="generator")(tasks)
            return list(tqdm(results, total=len(tasks), desc=desc, disable=not self.progress))

    def _check_predict_input(self, X) -> np.ndarray:
        """``X`` as float64 (n_trials, n_sensors_, n_features_in_), after the fitted check."""
        check_is_fitted(self)
        X = _check_3d(X)
        if X.shape[1:] != (self.n_sensors_, self.n_features_in_):
            raise ConfigError(
                f"X has {X.shape[1]} sensors x {X.shape[2]} features; the model was fitted on "
                f"{self.n_sensors_} x {self.n_features_in_}"
            )
        return X

    def fit(self, X, A, groups=None):
        """Fit one classifier per (attribute, sensor).

        Parameters
        ----------
        X : array-like of shape (n_trials, n_sensors, n_features)
            Per-sensor trial features.
        A : array-like of shape (n_trials, n_attributes)
            0/1 attribute targets of each trial (the attribute row of its object).
        groups : array-like of shape (n_trials,), optional
            Object of each trial, for object-grouped cross-validation.

        Returns
        -------
        self
        """
        X, A, names = self._check_fit_input(X, A)
        n, s, d = X.shape
        groups = None if groups is None else np.asarray(groups)
        if groups is not None and groups.shape != (n,):
            raise ConfigError(f"groups must have shape ({n},), got {groups.shape}")
        g = np.arange(n) if groups is None else groups
        for j, nm in enumerate(names):  # fail fast, before any parallel work
            for label, mask in (("present", A[:, j] == 1), ("absent", A[:, j] == 0)):
                k = np.unique(g[mask]).size
                if k < 2:
                    raise AttributeTrainingError(
                        f"attribute {nm!r}: {label} in only {k} training object(s); need at least 2 "
                        "(leave the attribute out of this split)"
                    )
        template = self._choose_template(n)
        seeds = spawn_seeds(self.random_state, A.shape[1] * s)
        memory = resolve_memory(self.memory)
        fit_one = memory.cache(fit_clone)
        tasks = []
        for j, nm in enumerate(names):
            for k in range(s):
                est = clone(template)
                params = est.get_params(deep=False)
                if "random_state" in params:
                    est.set_params(random_state=seeds[j * s + k])
                if "name" in params:
                    est.set_params(name=f"{nm} (sensor {k})")
                tasks.append(delayed(fit_one)(est, X[:, k, :], A[:, j], groups))
        fitted = self._run_fits(tasks, "attribute fits")
        self.estimators_ = [fitted[j * s : (j + 1) * s] for j in range(A.shape[1])]
        self.n_sensors_, self.n_attributes_, self.n_features_in_ = s, A.shape[1], d
        self._record_grid_edges(names)
        return self

    def _record_grid_edges(self, names: list[str]) -> None:
        """Fill ``grid_edge_hits_`` from the fitted estimators; one :class:`GridEdgeWarning` for the batch."""
        self.grid_edge_hits_ = [
            {"attribute": names[j], "sensor": k, "parameter": p, "value": v, "edge": e}
            for j, per_sensor in enumerate(self.estimators_)
            for k, est in enumerate(per_sensor)
            for p, v, e in getattr(est, "grid_edges_", ())
        ]
        if self.grid_edge_hits_:
            counts: dict[str, int] = {}
            for hit in self.grid_edge_hits_:
                key = f"{hit['parameter']} = {hit['value']:g} ({hit['edge']} edge)"
                counts[key] = counts.get(key, 0) + 1
            n_fits = sum(len(per) for per in self.estimators_)
            detail = ", ".join(f"{key}: {c}" for key, c in sorted(counts.items()))
            warnings.warn(
                f"{len(self.grid_edge_hits_)} hyper-parameter choices of {n_fits} (attribute, sensor) fits sit on a "
                f"grid edge ({detail}); the optimum may lie outside the grid (see grid_edge_hits_)",
                GridEdgeWarning, stacklevel=3,
            )

    def predict_proba(self, X) -> np.ndarray:
        """Attribute posteriors per sensor.

        Parameters
        ----------
        X : array-like of shape (n_trials, n_sensors, n_features)

        Returns
        -------
        ndarray of shape (n_trials, n_sensors, n_attributes)
            ``p(a_m = 1 | x_s)``.
        """
        X = self._check_predict_input(X)
        P = np.empty((X.shape[0], self.n_sensors_, self.n_attributes_))
        for j, per_sensor in enumerate(self.estimators_):
            for k, est in enumerate(per_sensor):
                P[:, k, j] = est.predict_proba(X[:, k, :])[:, 1]
        return P


def _check_3d(X) -> np.ndarray:
    X = np.asarray(X, dtype=np.float64)
    if X.ndim != 3:
        raise ConfigError(f"features must have shape (n_trials, n_sensors, n_features), got {X.shape}")
    if not np.isfinite(X).all():
        t, s, f = np.argwhere(~np.isfinite(X))[0]
        raise ConfigError(f"features hold a non-finite value at trial row {t}, sensor {s}, feature {f}")
    return X
