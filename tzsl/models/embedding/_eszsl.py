"""ESZSL: embarrassingly simple zero-shot learning, closed form (F16).

Romera-Paredes and Torr (ICML 2015) learn a bilinear compatibility ``x^T V s`` between a feature
vector ``x`` and a class attribute vector ``s``. The paper writes samples and classes as COLUMNS:
``X`` (d x n), ``Y`` in {-1, 1} (n x z), ``S`` (a x z), and gives

    V = (X X^T + gamma I)^-1  X Y S^T  (S S^T + lambda I)^-1          (paper, eq. 5)

tzsl stores samples and classes as ROWS (scikit-learn style): ``X`` (n, d), ``S`` (z, m) with one
row per training class, so the same estimator reads

    V = (X^T X + gamma I)^-1  X^T Y S  (S^T S + lambda I)^-1          V: (d, m)

``gamma`` regularises the feature side and ``lam`` (the paper's lambda) the attribute side, as in
the paper. A sample is classified among any set of (unseen) classes by ``argmax_c x^T V s_c``.

Attribute-model protocol (shared by every tzsl zero-shot attribute model): ``fit(X, Y)`` takes
each training trial's class attribute row ``Y`` (n, m); the training classes are the distinct rows
of ``Y`` in ``np.unique(Y, axis=0)`` order (trials of classes that share an attribute row are one
class). ``decision_function(X)`` gives attribute-space scores (n, m); a decision rule of
:mod:`tzsl.models` ranks any (unseen) class table against them (:class:`tzsl.models.ZeroShotClassifier`).
For binary attributes ``V`` does not depend on the order of the classes (all sums are of integers).

Computation: a thin SVD ``X = Q diag(s) R^T`` and an eigendecomposition ``S^T S = P diag(b) P^T``
give ``V = R diag(s / (s^2 + gamma)) Q^T (Y S) P diag(1 / (b + lam)) P^T``; the SVD form never
builds the d x d matrix, and for the cross-validated :class:`ESZSLCV` the decompositions are
computed once per fold and the whole (gamma, lam) grid is scored with one einsum.
"""

from __future__ import annotations

from collections.abc import Sequence
from numbers import Integral, Real

import numpy as np
from sklearn.base import BaseEstimator
from sklearn.preprocessing import StandardScaler
from sklearn.utils._param_validation import HasMethods, Interval, StrOptions
from sklearn.utils.validation import check_is_fitted

from tzsl._scoring import linear_embedding
from tzsl.models._attribute_model_base import attribute_table_tags
from tzsl.models._selection_criteria import DEFAULT_SCORING, SCORINGS, best_within_tolerance, heldout_scores
from tzsl.models._validation import ParameterError, ValidatedParamsMixin
from tzsl.models._zsl_input import (
    DEFAULT_GRID_EXTENSIONS,
    ZSLInputError,
    attribute_rows,
    class_grouped_folds,
    extend_at_edge,
    training_classes,
    validate_features,
    validate_features_and_rows,
)

__all__ = ["AttributeEmbeddingModel", "ESZSL", "ESZSLCV", "ZSLInputError", "attribute_rows", "training_classes"]

#: Default regulariser grid of :class:`ESZSLCV` (the paper's 10^-3 .. 10^3).
DEFAULT_GRID: tuple[float, ...] = (1e-3, 1e-2, 1e-1, 1.0, 10.0, 100.0, 1000.0)

# --------------------------------------------------------------------------------------------
# closed form
# --------------------------------------------------------------------------------------------


def _signed_indicator_times_S(y: np.ndarray, S: np.ndarray) -> np.ndarray:
    """``Y S`` for ``Y`` in {-1, 1}^(n x z) (+1 at each sample's class), without building Y."""
    return 2.0 * S[y] - S.sum(axis=0)


def _decompose(X: np.ndarray, y: np.ndarray, S: np.ndarray):
    """Decompositions shared by every (gamma, lam): see the module docstring.

    Returns ``R`` (d, r), ``s`` (r,), ``C = Q^T Y S P`` (r, m), ``P`` (m, m), ``b`` (m,).
    """
    Q, s, Rt = np.linalg.svd(X, full_matrices=False)
    b, P = np.linalg.eigh(S.T @ S)
    b = np.clip(b, 0.0, None)  # S^T S is PSD; clip round-off below zero
    C = Q.T @ _signed_indicator_times_S(y, S) @ P
    return Rt.T, s, C, P, b


def _closed_form(X: np.ndarray, y: np.ndarray, S: np.ndarray, gamma: float, lam: float):
    """ESZSL's ``V`` (d, m) for features ``X`` (n, d), class rows ``y`` (n,), attributes ``S``."""
    R, s, C, P, b = _decompose(X, y, S)
    return (R * (s / (s**2 + gamma))) @ C @ (P / (b + lam)).T


class AttributeEmbeddingModel(ValidatedParamsMixin, BaseEstimator):
    """Shared predict side of the linear/learned attribute embeddings (attribute-model protocol).

    ``decision_function(X)`` (== ``predict(X)``) maps trials to attribute space, (n, m); a
    decision rule (:class:`tzsl.models.CompatibilityRule` or
    :class:`tzsl.models.NearestAttributeRule`) turns that into class scores for any table.
    """

    #: What :meth:`decision_function` returns, read by :class:`tzsl.models.ZeroShotClassifier`.
    score_kind = "embedding"

    def __sklearn_tags__(self):
        return attribute_table_tags(super().__sklearn_tags__())

    def _embed(self, X: np.ndarray) -> np.ndarray:  # pragma: no cover
        raise NotImplementedError

    def decision_function(self, X) -> np.ndarray:
        """Attribute-space scores of the trials.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
            Features, in the units they were fitted with.

        Returns
        -------
        ndarray of shape (n_samples, n_attributes)
        """
        check_is_fitted(self)
        X = validate_features(self, X, reset=False)
        if self.scaler_ is not None:
            X = self.scaler_.transform(X)
        return self._embed(X)

    def predict(self, X) -> np.ndarray:
        """Same as :meth:`decision_function`: (n_samples, n_attributes) attribute-space scores."""
        return self.decision_function(X)


_COMMON_CONSTRAINTS: dict = {"standardize": ["boolean"]}


class _ESZSLBase(AttributeEmbeddingModel):
    def decision_function(self, X) -> np.ndarray:
        """Attribute-space scores ``standardise(X) @ coef_`` (:func:`tzsl.models.protocol.linear_embedding`).

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
            Features, in the units they were fitted with.

        Returns
        -------
        ndarray of shape (n_samples, n_attributes)
        """
        check_is_fitted(self)
        return linear_embedding(validate_features(self, X, reset=False), **self.linear_map())

    def linear_map(self) -> dict[str, np.ndarray]:
        """The fitted map as arrays, so that ``decision_function(X) == linear_embedding(X, **linear_map())``.

        Returns
        -------
        dict
            ``weights`` (n_features, n_attributes) and, when standardised, the scaler's ``mean``
            and ``scale`` (n_features,).
        """
        check_is_fitted(self)
        scaler = {} if self.scaler_ is None else {"mean": self.scaler_.mean_, "scale": self.scaler_.scale_}
        return {"weights": self.coef_, **scaler}

    def _start_fit(self, X, Y, groups):
        X, Y = validate_features_and_rows(self, X, Y)
        S_u, y_u = training_classes(Y, type(self).__name__, groups)
        return X, S_u, y_u

    def _finish_fit(self, X, S_u, y_u, gamma, lam):
        self.scaler_ = StandardScaler().fit(X) if self.standardize else None
        Xs = X if self.scaler_ is None else self.scaler_.transform(X)
        self.class_attributes_ = S_u
        self.n_attributes_ = S_u.shape[1]
        self.coef_ = _closed_form(Xs, y_u, S_u, gamma, lam)
        return self


class ESZSL(_ESZSLBase):
    """Embarrassingly simple zero-shot learning (Romera-Paredes and Torr 2015), closed form.

    An attribute model: ``fit(X, Y)`` learns ``V`` from trials and their classes' attribute rows
    (the training classes are the distinct rows of ``Y``); ``decision_function(X) = X V`` in
    attribute space, scored against any class table by :class:`tzsl.models.CompatibilityRule`
    (``x^T V s_c``).

    Parameters
    ----------
    gamma : float > 0, default=1.0
        Feature-side ridge: the ``gamma`` of ``(X^T X + gamma I)^-1``.
    lam : float > 0, default=1.0
        Attribute-side ridge (the paper's lambda), in ``(S^T S + lam I)^-1``.
    standardize : bool, default=True
        Z-score features with a :class:`~sklearn.preprocessing.StandardScaler` fitted on the
        training samples inside ``fit`` (ESZSL has no intercept, so centring matters).

    Attributes
    ----------
    coef_ : ndarray of shape (n_features, n_attributes)
        ``V``, mapping (standardised) features to attribute space.
    class_attributes_ : ndarray of shape (n_train_classes, n_attributes)
        Distinct training attribute rows (``np.unique(Y, axis=0)``); trials sharing a row are
        one class (one +1 column of the paper's ``Y``).
    scaler_ : StandardScaler or None
    n_attributes_, n_features_in_ : int
    """

    _parameter_constraints: dict = {
        **_COMMON_CONSTRAINTS,
        "gamma": [Interval(Real, 0, None, closed="neither")],
        "lam": [Interval(Real, 0, None, closed="neither")],
    }

    def __init__(self, *, gamma=1.0, lam=1.0, standardize=True):
        self.gamma = gamma
        self.lam = lam
        self.standardize = standardize

    def fit(self, X, Y, groups=None):
        """Fit ``V`` in closed form.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
        Y : array-like of shape (n_samples, n_attributes)
            Attribute row of each sample's class; attributes may be real-valued.
        groups : array-like of shape (n_samples,), optional
            Object or class of each sample; only orders the classes (see :func:`training_classes`).

        Returns
        -------
        self : ESZSL
        """
        self._validate_params()
        X, S_u, y_u = self._start_fit(X, Y, groups)
        return self._finish_fit(X, S_u, y_u, float(self.gamma), float(self.lam))


class ESZSLCV(_ESZSLBase):
    """ESZSL with ``gamma`` and ``lam`` chosen by class-grouped cross-validation.

    Every fold holds out whole training classes (distinct attribute rows of ``Y``) and scores
    zero-shot recognition among the held-out classes only, so tuning mimics the test situation
    and never needs the test classes. The full grid is scored from one SVD and one
    eigendecomposition per fold.

    Parameters
    ----------
    gammas, lams : array-like of float > 0, default=10^-3 .. 10^3 (7 values each)
        Grids of the feature-side and attribute-side ridges. A single pair is fitted without
        cross-validation (``best_score_`` is then NaN and ``cv_scores_`` has no folds).
    cv : None, int >= 2 or splitter, default=None
        ``None``: :func:`~tzsl.models.protocol.class_grouped_folds` with ``min(5, n_classes // 2)``
        folds, each validating on >= 2 and training on >= 2 classes (classes sharing an attribute
        row are one class, never alone in a fold). An int: that many such folds (an error if
        more than ``n_classes // 2``). Otherwise any object with ``split(X, y, groups)``; it
        receives ``groups`` = class (row of ``class_attributes_``), and every fold must hold out
        whole classes, at least 2 of them, and train on at least 2.
    scoring : {"accuracy", "balanced_accuracy", "neg_log_loss"}, default="accuracy"
        Criterion on the held-out classes (:func:`tzsl.models.protocol.heldout_scores`): per-sample
        accuracy, mean per-class accuracy, or minus the log-loss of a softmax over the held-out
        classes' scores at its best temperature (smooth: a last-bit difference cannot flip the choice;
        not the default, see :mod:`tzsl.models.protocol`).
    standardize : bool, default=True
        As in :class:`ESZSL`; the scaler is refitted on each fold's training part.
    grid_extensions : int >= 0, default=3 (``DEFAULT_GRID_EXTENSIONS``)
        Adaptive grid: while the selected ``gamma`` or ``lam`` is the smallest or largest of its
        grid, that grid gains one log-scale step beyond the edge (the ratio of its two outer
        values) and the whole grid is rescored on the same folds, at most this many times.
        0 keeps the given grids.

    Attributes
    ----------
    best_gamma_, best_lam_ : float
        Chosen regularisers. Mean CV scores within ``TIE_TOLERANCE`` of the best are tied and the first
        of them in grid order is chosen: the smallest ``gamma``, then the smallest ``lam``.
    gammas_, lams_ : ndarray
        The final (sorted, possibly extended) grids that were scored.
    at_grid_edge_ : bool
        Whether a chosen value is still at an edge of its final grid (extension bound reached).
    cv_scores_ : ndarray of shape (n_gammas, n_lams, n_splits)
    mean_cv_scores_ : ndarray of shape (n_gammas, n_lams)
    best_score_ : float
    cv_val_classes_ : list of ndarray
        Rows of ``class_attributes_`` held out in each fold.
    coef_, class_attributes_, scaler_, n_attributes_, n_features_in_
        As in :class:`ESZSL`, refitted on all training samples with the chosen pair.
    """

    _parameter_constraints: dict = {
        **_COMMON_CONSTRAINTS,
        "gammas": ["array-like"],
        "lams": ["array-like"],
        "cv": [None, Interval(Integral, 2, None, closed="left"), HasMethods(["split"])],
        "scoring": [StrOptions(set(SCORINGS))],
        "grid_extensions": [Interval(Integral, 0, None, closed="left")],
    }

    def __init__(
        self,
        *,
        gammas: Sequence[float] = DEFAULT_GRID,
        lams: Sequence[float] = DEFAULT_GRID,
        cv=None,
        scoring=DEFAULT_SCORING,
        standardize=True,
        grid_extensions=DEFAULT_GRID_EXTENSIONS,
    ):
        self.gammas = gammas
        self.lams = lams
        self.cv = cv
        self.scoring = scoring
        self.standardize = standardize
        self.grid_extensions = grid_extensions

    def _check_param_values(self) -> None:
        for name in ("gammas", "lams"):
            try:
                arr = np.asarray(getattr(self, name), dtype=np.float64).ravel()
            except (TypeError, ValueError):
                arr = np.array([np.nan])
            if arr.size == 0 or not np.all(np.isfinite(arr) & (arr > 0)):
                raise ParameterError(
                    f"The {name!r} parameter of {type(self).__name__} must be a non-empty sequence of "
                    f"finite numbers > 0. Got {getattr(self, name)!r} instead."
                )

    def _folds(self, X: np.ndarray, y_u: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
        """CV folds over the training classes ``y_u`` (n,): the shared builder unless ``cv`` is a splitter."""
        name = type(self).__name__
        if self.cv is None or isinstance(self.cv, Integral):
            strict = self.cv is not None
            return class_grouped_folds(y_u, 5 if self.cv is None else int(self.cv), name, strict=strict)
        try:
            return list(self.cv.split(X, y_u, groups=y_u))
        except ValueError as exc:
            raise ZSLInputError(f"{name}: cannot split the training classes: {exc}") from exc

    def fit(self, X, Y, groups=None):
        """Choose ``(gamma, lam)`` by class-grouped CV, then refit on all training samples.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
        Y : array-like of shape (n_samples, n_attributes)
            Attribute row of each sample's class.
        groups : array-like of shape (n_samples,), optional
            Object or class of each sample; orders the classes (:func:`training_classes`), which
            fixes the folds. The CV groups are always the classes (distinct rows of ``Y``).

        Returns
        -------
        self : ESZSLCV
        """
        self._validate_params()
        name = type(self).__name__
        gammas = np.sort(np.asarray(self.gammas, dtype=np.float64).ravel())
        lams = np.sort(np.asarray(self.lams, dtype=np.float64).ravel())
        X, S_u, y_u = self._start_fit(X, Y, groups)
        self.gammas_, self.lams_, self.at_grid_edge_ = gammas, lams, False
        if gammas.size == lams.size == 1:  # nothing to choose: no cross-validation
            self.cv_scores_ = np.empty((1, 1, 0))
            self.mean_cv_scores_ = np.full((1, 1), np.nan)
            self.best_gamma_, self.best_lam_, self.best_score_ = float(gammas[0]), float(lams[0]), float("nan")
            self.cv_val_classes_ = []
            return self._finish_fit(X, S_u, y_u, self.best_gamma_, self.best_lam_)
        folds = self._folds(X, y_u)

        scores, val_classes = [], []
        for i, (tr, va) in enumerate(folds):
            g_tr, g_va = np.unique(y_u[tr]), np.unique(y_u[va])
            if np.intersect1d(g_tr, g_va).size:
                raise ZSLInputError(
                    f"{name}: cv fold {i} has classes on both sides; zero-shot tuning needs "
                    "folds that hold out whole classes (use a group splitter)"
                )
            if g_tr.size < 2 or g_va.size < 2:
                raise ZSLInputError(
                    f"{name}: cv fold {i} trains on {g_tr.size} and validates on {g_va.size} "
                    "classes; both need at least 2"
                )
            scores.append(self._score_fold(X[tr], y_u[tr], X[va], y_u[va], S_u, gammas, lams))
            val_classes.append(g_va)

        self.cv_scores_ = np.stack(scores, axis=-1)
        self.mean_cv_scores_ = self.cv_scores_.mean(axis=-1)
        gi, li = best_within_tolerance(self.mean_cv_scores_, (-gammas, -lams))
        for _ in range(int(self.grid_extensions)):  # adaptive: step beyond an edge that was selected
            new_g, new_l = extend_at_edge(gammas, gi), extend_at_edge(lams, li)
            if new_g is None and new_l is None:
                break
            gammas = gammas if new_g is None else new_g
            lams = lams if new_l is None else new_l
            self.cv_scores_ = np.stack(
                [self._score_fold(X[tr], y_u[tr], X[va], y_u[va], S_u, gammas, lams) for tr, va in folds], axis=-1
            )
            self.mean_cv_scores_ = self.cv_scores_.mean(axis=-1)
            gi, li = best_within_tolerance(self.mean_cv_scores_, (-gammas, -lams))
        self.gammas_, self.lams_ = gammas, lams
        self.at_grid_edge_ = extend_at_edge(gammas, gi) is not None or extend_at_edge(lams, li) is not None
        self.best_gamma_ = float(gammas[gi])
        self.best_lam_ = float(lams[li])
        self.best_score_ = float(self.mean_cv_scores_[gi, li])
        self.cv_val_classes_ = val_classes
        return self._finish_fit(X, S_u, y_u, self.best_gamma_, self.best_lam_)

    def selected_params(self) -> dict:
        """Parameters that refit this model with the chosen ridges and no search (``gammas``, ``lams``).

        A refit on part of the training classes (posterior calibration's pseudo-unseen folds,
        :class:`tzsl.models.CalibratedZeroShotClassifier`) then has the scale of this fit.
        """
        check_is_fitted(self)
        return {"gammas": (self.best_gamma_,), "lams": (self.best_lam_,)}

    def _score_fold(self, X_tr, y_tr, X_va, y_va, S_u, gammas, lams) -> np.ndarray:
        """The CV criterion on the held-out classes for every grid point (higher is better): (n_gammas, n_lams)."""
        tr_rows = np.unique(y_tr)
        va_rows, y_va_local = np.unique(y_va, return_inverse=True)
        S_tr, S_va = S_u[tr_rows], S_u[va_rows]
        y_tr_local = np.searchsorted(tr_rows, y_tr)
        if self.standardize:
            scaler = StandardScaler().fit(X_tr)
            X_tr, X_va = scaler.transform(X_tr), scaler.transform(X_va)
        R, s, C, P, b = _decompose(X_tr, y_tr_local, S_tr)
        u = s / (s**2 + gammas[:, None])  # (G, r)
        v = 1.0 / (b + lams[:, None])  # (L, m)
        A = X_va @ R  # (n_va, r)
        B = S_va @ P  # (k_va, m)
        # scores[g, l, i, c] = sum_{r, j} A[i, r] u[g, r] C[r, j] v[l, j] B[c, j]
        AUC = np.einsum("ir,gr,rj->gij", A, u, C, optimize=True)
        scores = np.einsum("gij,lj,cj->glic", AUC, v, B, optimize=True)
        return heldout_scores(scores, y_va_local, self.scoring)
