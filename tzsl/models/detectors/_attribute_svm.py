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

import copy
import threading
from collections import OrderedDict
from numbers import Integral, Real

import joblib
import numpy as np
from sklearn import config_context
from sklearn.base import BaseEstimator, ClassifierMixin, clone
from sklearn.metrics.pairwise import euclidean_distances, rbf_kernel
from sklearn.svm import (
    SVC,
    _libsvm,
)
from sklearn.utils import check_random_state
from sklearn.utils._param_validation import HasMethods, Interval, StrOptions
from sklearn.utils.multiclass import check_classification_targets
from sklearn.utils.validation import check_is_fitted, validate_data

from tzsl._fit_store import array_digest
from tzsl._parallel import one_blas_thread
from tzsl.models._validation import ParameterError, ValidatedParamsMixin
from tzsl.models.detectors._attribute_search import (
    HALVING_KERNEL_BYTES,
    MAX_GRID_EXTENSIONS,
    SEARCHES,
    UNIT_WEIGHT,
    adaptive_grid_search,
    balanced_class_weight,
    fill_grid_lines,
    successive_halving,
    svc_fit_decision,
)
from tzsl.models.detectors._attribute_training import (
    GRIDS,
    PLATT_WEIGHTING,
    SCORING,
    UNDERSAMPLING,
    AttributeTrainingError,
    balanced_object_draws,
    balanced_sample_weights,
    binary_training_targets,
    cv_criteria,
    default_preprocessor,
    gamma_grid,
    grid_edges,
    object_grouped_folds,
)
from tzsl.models.detectors._platt_binary import PlattBinaryClassifierMixin

__all__ = ["AttributeSVM"]

#: Most bytes of preprocessed training sets (features and squared distances) a process keeps for reuse.
PREPROCESSED_BYTES = 64 * 2**20
#: This process's last preprocessed training sets: (preprocessor, features digest) -> (fitted, Z, D).
_PREPROCESSED: OrderedDict = OrderedDict()
_PREPROCESSED_LOCK = threading.Lock()


def _preprocessed(pre, X: np.ndarray) -> tuple[object, np.ndarray, np.ndarray]:
    """``(fitted preprocessor, Z, D)``: ``pre`` fitted on ``X`` (n_trials, n_features), the transformed trials Z
    (n_trials, n_components) and their squared Euclidean distances D (n_trials, n_trials).

    Every attribute of a sensor trains on the same trials (an :class:`AttributeClassifierBank` gives each
    (attribute, sensor) fit the sensor's features), so a process keeps its last results, up to
    :data:`PREPROCESSED_BYTES`, and hands the next fit on equal features with an equal preprocessor a copy
    of the same fitted preprocessor and the same (read-only) Z and D: the same numbers, computed once.
    """
    key = (joblib.hash(pre), array_digest(X))
    with _PREPROCESSED_LOCK:  # the bank's threading backend fits in threads of one process
        known = _PREPROCESSED.get(key)
        if known is not None:
            _PREPROCESSED.move_to_end(key)
    if known is not None:
        return copy.deepcopy(known[0]), known[1], known[2]
    Z = np.asarray(pre.fit_transform(X), dtype=np.float64)
    D = euclidean_distances(Z, squared=True)
    if Z.nbytes + D.nbytes <= PREPROCESSED_BYTES:
        Z.flags.writeable = D.flags.writeable = False
        with _PREPROCESSED_LOCK:
            _PREPROCESSED[key] = (copy.deepcopy(pre), Z, D)
            while sum(z.nbytes + d.nbytes for _, z, d in _PREPROCESSED.values()) > PREPROCESSED_BYTES:
                _PREPROCESSED.popitem(last=False)
    return pre, Z, D

class AttributeSVM(PlattBinaryClassifierMixin, ValidatedParamsMixin, ClassifierMixin, BaseEstimator):
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
    grid : {"paper", "extended", "adaptive"}, default="extended"
        ``"paper"``: ``gamma`` from ``gamma_range`` and ``n_gamma`` as the DAP paper tuned it.
        ``"extended"``: that grid plus two decades below its low end (0.001, 0.0001 for the
        paper's range; :func:`tzsl.models.detectors.gamma_grid`), because on PHAC-2 most (attribute, sensor)
        fits chose the paper grid's low edge. ``"adaptive"``: start from ``"extended"``; while
        the chosen ``C`` or ``gamma`` is at an end of its grid, add one log step beyond that end
        (the ratio of its two outer values) and search again on the same draws and folds, at
        most ``MAX_GRID_EXTENSIONS`` steps per end (:mod:`tzsl.models.attribute_training`); only
        the new configurations are fitted. The paper-reproduction studies pin ``"paper"``. The
        grids' accuracy, grouped-CV log-loss, share of fits at a grid edge and fit time are
        measured by ``experiments/benchmarks/phac2_accuracy.py`` (its generated tables in
        ``experiments/benchmarks/README.md``).
    cv : None, int or splitter, default=None
        Object-grouped cross-validation on the training trials. ``None``: leave-one-object-out
        (``LeaveOneGroupOut``); int: ``StratifiedGroupKFold(min(cv, n), shuffle=True)`` with ``n``
        the number of objects of the rarer class in the draw (so every fold keeps both classes); or
        any splitter with ``split(X, y, groups)`` whose test folds partition the trials.
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
        would be divided out twice, so that pairing needs ``"empirical"`` (Table 2 of
        ``tzsl reproduce-tables`` shows the priors side by side).
    search : {"halving", "grid"}, default="halving"
        ``"grid"`` scores every (draw, C, gamma) on all out-of-fold scores; ``"halving"``:
        successive halving with the folds as the resource (:mod:`tzsl.models.detectors._attribute_search`:
        a third of the configurations kept per round, never fewer than three, the last ones
        scored exactly as the grid scores them). With ``undersampling="bagging"`` (draws tuned
        jointly) the grid is searched. ``"halving"`` is the default because, on PHAC-2 with 5
        object-grouped folds and both gamma grids, it was chosen on 10 random splits of seed 0
        and confirmed on 10 random splits of seed 1: on the confirmation splits the 95% interval
        of the paired AVGDAP difference (halving minus grid, same trials) contains 0, and the
        attribute fits take clearly less CPU. Measured by ``experiments/benchmarks/phac2_search.py
        --seed 0|1 --n-splits 10 --grid paper|extended``; the numbers are in the generated table
        of ``docs/user_guide/performance.md``. ``"grid"`` gives the former results.
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
    C_grid_, gamma_grid_ : ndarray of shape (n_C_searched,), (n_gammas_searched,)
        The grids searched, increasing (with ``grid="adaptive"`` the final, possibly widened, ones).
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
    cv_scores_ : ndarray of shape (n_draws_or_1, n_gammas_searched, n_C_searched)
        Grouped-CV criterion of every configuration (lower is better; balanced accuracy is
        stored negated); NaN where ``search="halving"`` pruned the configuration.
    grid_edges_ : list of (str, float, str)
        ``(parameter, value, "low" | "high")`` for each chosen ``C`` / ``gamma`` at an end of its
        grid (the grouped-CV optimum may lie outside the grid); empty when none is. With
        ``grid="adaptive"`` only ends whose extensions were exhausted.
    """

    _parameter_constraints: dict = {
        "preprocessor": [None, HasMethods(["fit", "transform"])],
        "C_range": ["array-like"],
        "gamma_range": ["array-like"],
        "n_C": [Interval(Integral, 1, None, closed="left")],
        "n_gamma": [Interval(Integral, 1, None, closed="left")],
        "grid": [StrOptions(set(GRIDS))],
        "cv": [None, Interval(Integral, 2, None, closed="left"), HasMethods(["split"])],
        "undersampling": [StrOptions(set(UNDERSAMPLING))],
        "n_draws": [Interval(Integral, 1, None, closed="left")],
        "scoring": [StrOptions(set(SCORING))],
        "platt_weighting": [StrOptions(set(PLATT_WEIGHTING))],
        "search": [StrOptions(set(SEARCHES))],
        "name": [None, str],
        "random_state": ["random_state"],
    }

    def __init__(
        self,
        *,
        preprocessor=None,
        C_range=(1.0, 100.0),
        gamma_range=(0.01, 1.0),
        n_C=3,
        n_gamma=3,
        grid="extended",
        cv=None,
        undersampling="select",
        n_draws=3,
        scoring="log_loss",
        platt_weighting="balanced",
        search="halving",
        name=None,
        random_state=None,
    ):
        self.preprocessor = preprocessor
        self.C_range = C_range
        self.gamma_range = gamma_range
        self.n_C = n_C
        self.n_gamma = n_gamma
        self.grid = grid
        self.cv = cv
        self.undersampling = undersampling
        self.n_draws = n_draws
        self.scoring = scoring
        self.platt_weighting = platt_weighting
        self.search = search
        self.name = name
        self.random_state = random_state

    # ------------------------------------------------------------------ helpers
    def _check_param_values(self) -> None:
        for nm in ("C_range", "gamma_range"):
            rng = np.asarray(getattr(self, nm), dtype=object).ravel()
            ok = rng.size == 2 and all(isinstance(v, Real) for v in rng) and 0 < rng[0] <= rng[1]
            if not ok:
                raise ParameterError(
                    f"The {nm!r} parameter of {type(self).__name__} must be (low, high) with "
                    f"0 < low <= high. Got {getattr(self, nm)!r} instead."
                )

    def _folds(self, yb, groups, seed: int) -> list[np.ndarray]:
        return object_grouped_folds(self.cv, yb, groups, seed)

    def _draws(self, yb, groups, rng) -> tuple[list[np.ndarray], np.ndarray]:
        return balanced_object_draws(yb, groups, self.n_draws if self.undersampling != "none" else 0, rng)

    def _grid_oof(self, D, yb, groups, draws, fold_seed, Cs, gammas, cw, oof) -> None:
        """Fill ``oof[draw, gamma, C]`` with out-of-fold SVM scores of every training trial.

        The grouped folds are made over the objects of each draw; a trial outside the draw is
        scored by the draw's full model, which never saw it. Per draw and ``gamma`` the kernel of
        the draw is computed once (``np.exp`` in place on one buffer) and each fold's training
        and held-out blocks are gathered once for all ``C``; the fits call libsvm directly
        (:func:`~tzsl.models.detectors._attribute_search.svc_fit_decision`), which gives the same numbers as
        ``SVC`` bitwise.
        """
        _libsvm.set_verbosity_wrap(0)  # libsvm's global switch; SVC sets it before every fit
        for di, keep in enumerate(draws):
            idx, out, y_draw, D_draw, fold_index, fold_w, w_full = self._draw_parts(D, yb, groups, keep, fold_seed, cw)
            K = np.empty_like(D_draw)
            Kd, K_out = K[: idx.size], K[idx.size :]
            for gi, gamma in enumerate(gammas):
                np.multiply(D_draw, -gamma, out=K)
                np.exp(K, out=K)
                Kd_c = np.ascontiguousarray(Kd)
                K_out_c = np.ascontiguousarray(K_out)
                for ci, C in enumerate(Cs):
                    if out.size:
                        oof[di, gi, ci, out] = svc_fit_decision(Kd_c, y_draw, C, w_full, K_out_c)
                for (tr, te), w in zip(fold_index, fold_w, strict=True):
                    Ktr = Kd[np.ix_(tr, tr)]
                    Kte = Kd[np.ix_(te, tr)]
                    y_tr = y_draw[tr]
                    for ci, C in enumerate(Cs):
                        oof[di, gi, ci, idx[te]] = svc_fit_decision(Ktr, y_tr, C, w, Kte)

    def _draw_parts(self, D, yb, groups, keep, fold_seed, cw) -> tuple:
        """One draw's trials, folds and class weights: ``(idx, out, y_draw, D_draw, fold_index, fold_w, w_full)``.

        ``idx`` / ``out``: the trials in / outside the draw; ``D_draw`` (n_draw + n_out, n_draw)
        the squared distances of the draw's trials, then the outside trials, to the draw's
        trials; ``fold_index`` the (train, test) positions within the draw of each fold.
        """
        idx, out = np.flatnonzero(keep), np.flatnonzero(~keep)
        folds = self._folds(yb[idx], groups[idx], fold_seed)
        y_draw = yb[idx].astype(np.float64)
        for fold in folds:
            if y_draw[~fold].all() or not y_draw[~fold].any():
                raise AttributeTrainingError(
                    f"{self._label()}: a cross-validation fold leaves one class without training "
                    "objects; use fewer folds (cv)"
                )
        D_draw = D[np.ix_(np.concatenate([idx, out]), idx)]
        fold_index = [(np.flatnonzero(~f), np.flatnonzero(f)) for f in folds]
        fold_w = [balanced_class_weight(y_draw[tr]) if cw else UNIT_WEIGHT for tr, _ in fold_index]
        w_full = balanced_class_weight(y_draw) if cw else UNIT_WEIGHT
        return idx, out, y_draw, D_draw, fold_index, fold_w, w_full

    def _halving_oof(self, D, yb, groups, draws, fold_seed, Cs, gammas, cw, oof, fits: dict) -> np.ndarray:
        """:func:`successive_halving` over the grid; fills ``oof`` of the survivors, returns them (bool).

        ``fits`` holds every fit's decision values by ``(draw, gamma, C, fold)`` (fold -1: the
        trials outside the draw); a fit already in it (an earlier search on a smaller grid) is reused.
        """
        _libsvm.set_verbosity_wrap(0)
        parts = [self._draw_parts(D, yb, groups, keep, fold_seed, cw) for keep in draws]
        kernels: dict[tuple[int, int, bool], np.ndarray] = {}
        # every (draw, gamma) kernel is kept for the later rounds while they fit in HALVING_KERNEL_BYTES
        keep_kernels = sum(p[3].nbytes for p in parts) * len(gammas) <= HALVING_KERNEL_BYTES

        def kernel(di: int, gi: int, outside: bool) -> np.ndarray:
            """The RBF kernel of the draw's trials (outside False: (n_draw, n_draw)) or of the trials outside
            the draw to them (True: (n_out, n_draw)); the outside block only for the configurations that
            reach the last round (elementwise, so the same numbers as one kernel of both blocks)."""
            if (di, gi, outside) in kernels:
                return kernels[di, gi, outside]
            n_draw = parts[di][0].size
            rows = parts[di][3][n_draw:] if outside else parts[di][3][:n_draw]
            K = np.exp(rows * -gammas[gi])
            if keep_kernels:
                kernels[di, gi, outside] = K
            return K

        def fit(di: int, gi: int, cis: np.ndarray, folds: range, outside: bool) -> None:
            idx, out, y_draw, _, fold_index, fold_w, w_full = parts[di]
            for f in ([-1] if outside and out.size else []) + list(folds):
                keys = [(di, float(gammas[gi]), float(Cs[ci]), f) for ci in cis]
                todo = [(ci, key) for ci, key in zip(cis, keys, strict=True) if key not in fits]
                if todo:
                    Kd = kernel(di, gi, False)
                    if f < 0:  # the trials outside the draw, by a fit on the whole draw
                        K_fit, K_eval, y_fit, w = Kd, kernel(di, gi, True), y_draw, w_full
                    else:
                        tr, te = fold_index[f]
                        K_fit, K_eval = Kd[np.ix_(tr, tr)], Kd[np.ix_(te, tr)]
                        y_fit, w = y_draw[tr], fold_w[f]
                    for ci, key in todo:
                        fits[key] = svc_fit_decision(K_fit, y_fit, Cs[ci], w, K_eval)
                rows = out if f < 0 else idx[fold_index[f][1]]
                for ci, key in zip(cis, keys, strict=True):
                    oof[di, gi, ci, rows] = fits[key]

        def score(di: int, cells: np.ndarray, n_seen: int) -> np.ndarray:
            idx, fold_index = parts[di][0], parts[di][4]
            rows = idx[np.concatenate([te for _, te in fold_index[:n_seen]])]
            y_seen = yb[rows]
            w = balanced_sample_weights(y_seen) if self.platt_weighting == "balanced" else np.ones(rows.size)
            by_cell = oof[di].reshape(-1, oof.shape[-1])  # (n_gammas * n_C, n_train), a view
            return cv_criteria(by_cell[np.ix_(np.flatnonzero(cells), rows)], y_seen, w, self.scoring)[0]

        return successive_halving(oof.shape[:3], [len(p[4]) for p in parts], fit, score)

    def _search_oof(self, D, yb, groups, draws, fold_seed, Cs, gammas, cw,
                    known: dict) -> tuple[np.ndarray, np.ndarray]:
        """Out-of-fold scores (n_draws, n_gammas, n_C, n_train) and the configurations searched to the end (bool).

        ``known`` carries an earlier search of this fit on a smaller grid (``grid="adaptive"``): the
        grid search then fits only the new grid lines, successive halving only the new fits.
        """
        oof = np.empty((len(draws), gammas.size, Cs.size, yb.size))
        if self.search == "halving" and self.undersampling != "bagging":
            fits = known.setdefault("fits", {})
            return oof, self._halving_oof(D, yb, groups, draws, fold_seed, Cs, gammas, cw, oof, fits)
        fill_grid_lines(oof, Cs, gammas, known.get("grid"),
                        lambda g, c, out: self._grid_oof(D, yb, groups, draws, fold_seed, c, g, cw, out))
        known["grid"] = (Cs, gammas, oof)
        return oof, np.ones(oof.shape[:3], dtype=bool)

    def _choose(self, oof, alive, yb, w_cal, draw_w) -> tuple:
        """Criteria of the searched configurations and the best: ``(crit, platt, oof, (draw, gamma, C))``.

        ``crit`` and ``platt`` (n_draws_or_1, n_gammas, n_C, 2) are NaN where pruned; ``oof`` is
        averaged over the draws (weights ``draw_w``) when bagging.
        """
        if self.undersampling == "bagging":
            oof, alive = np.tensordot(draw_w, oof, axes=(0, 0))[None], alive[:1]
        crit, platt = np.full(oof.shape[:3] + (2,), np.nan), np.full(oof.shape[:3] + (2,), np.nan)
        crit[alive], platt[alive] = cv_criteria(oof[alive], yb, w_cal, self.scoring)
        flat = np.lexsort((crit[..., 1].ravel(), crit[..., 0].ravel()))[0]  # NaN (pruned) sorts last
        return crit, platt, oof, tuple(int(i) for i in np.unravel_index(flat, oof.shape[:3]))

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
        self._validate_params()
        X, y = validate_data(self, X, y, dtype=np.float64)
        check_classification_targets(y)
        self.classes_, yb, groups = binary_training_targets(y, groups, self._label())
        n = yb.size
        rng = check_random_state(self.random_state)

        # many small dense problems: more BLAS threads than one only spin (and do not change results)
        with one_blas_thread():
            pre, Z, D = _preprocessed(clone(self.preprocessor) if self.preprocessor is not None
                                      else default_preprocessor(), X)
            draws, draw_w = self._draws(yb, groups, rng)
            fold_seed = int(rng.randint(np.iinfo(np.int32).max))
            cw = None if self.undersampling == "none" else "balanced"
            w_cal = balanced_sample_weights(yb) if self.platt_weighting == "balanced" else np.ones(n)
            known: dict = {}  # what earlier searches of this fit computed (grid="adaptive" searches again)

            def search(Cs: np.ndarray, gammas: np.ndarray) -> tuple[tuple, tuple[int, int]]:
                oof, alive = self._search_oof(D, yb, groups, draws, fold_seed, Cs, gammas, cw, known)
                chosen = self._choose(oof, alive, yb, w_cal, draw_w)
                return chosen, chosen[-1][1:]

            Cs, gammas, (crit, platt, oof, (di, gi, ci)) = adaptive_grid_search(
                search, np.geomspace(*self.C_range, self.n_C), gamma_grid(self.gamma_range, self.n_gamma, self.grid),
                MAX_GRID_EXTENSIONS if self.grid == "adaptive" else 0)
            self.C_grid_, self.gamma_grid_ = Cs, gammas
            self.cv_scores_ = crit[..., 0]
            self.C_, self.gamma_ = float(Cs[ci]), float(gammas[gi])
            self.oof_scores_ = oof[di, gi, ci].copy()
            self.platt_ = (float(platt[di, gi, ci, 0]), float(platt[di, gi, ci, 1]))
        self.grid_edges_ = grid_edges({"C": (Cs, ci), "gamma": (gammas, gi)})
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
        for w, svc, Ztr in zip(self.estimator_weights_, self.estimators_, self.train_features_, strict=True):
            out += w * svc.decision_function(rbf_kernel(Z, Ztr, gamma=self.gamma_))
        return out
