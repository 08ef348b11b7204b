"""SAE: semantic autoencoder for zero-shot learning, closed form.

Kodirov, Xiang and Gong, "Semantic Autoencoder for Zero-Shot Learning", CVPR 2017. A linear
encoder ``W`` projects features into attribute space and its transpose decodes them back:

    min_W  ||X - W^T S||_F^2 + lambda ||W X - S||_F^2          (paper, section 3, relaxed objective)

with samples as COLUMNS (``X`` d x N, ``S`` k x N). Setting the derivative to zero gives the
Sylvester equation

    S S^T W + W (lambda X X^T) = (1 + lambda) S X^T            (paper, section 3, A W + W B = C)

tzsl stores samples as ROWS (``X`` (n, d), ``A`` (n, m) = the class attribute row of every
trial), so the same equation reads

    A^T A W + W (lambda X^T X) = (1 + lambda) A^T X,        W: (m, d)

and the embedding of a trial is ``x W^T`` (m,), compared with class attribute rows by cosine
similarity (the paper's F -> S direction).

Computation: both coefficient matrices are symmetric positive semi-definite, so with
``A^T A = P diag(a) P^T`` and ``X^T X = Q diag(b) Q^T`` the solution is
``W = P [(P^T C Q)_{ij} / (a_i + lambda b_j)] Q^T`` with ``C = (1 + lambda) A^T X``; this is the
Bartels-Stewart solution of :func:`scipy.linalg.solve_sylvester` for symmetric matrices. Where
``a_i + lambda b_j`` is zero (rank-deficient ``A^T A`` and ``X^T X``, e.g. more attributes than
training classes and a constant feature) the equation leaves that component free and we take 0,
the minimum-norm solution, instead of failing.
"""

from __future__ import annotations

from numbers import Integral, Real

import numpy as np
from sklearn.base import _fit_context
from sklearn.preprocessing import StandardScaler
from sklearn.utils._param_validation import Interval, InvalidParameterError, StrOptions
from sklearn.utils.validation import check_is_fitted

from tzsl._scoring import cosine_similarities
from tzsl.models._attribute_model_base import EmbeddingAttributeModel
from tzsl.models._selection_criteria import DEFAULT_SCORING, SCORINGS, best_within_tolerance, heldout_scores
from tzsl.models._zsl_input import (
    DEFAULT_GRID_EXTENSIONS,
    class_grouped_folds,
    extend_at_edge,
    training_classes,
    validate_features_and_rows,
)

__all__ = ["DEFAULT_LAMS", "SAE", "SAECV", "sylvester_solution"]

#: Default lambda grid of :class:`SAECV`.
DEFAULT_LAMS: tuple[float, ...] = (1e-2, 1e-1, 1.0, 10.0, 100.0, 1e3, 1e4, 1e5)

#: Relative size below which ``a_i + lambda b_j`` counts as zero (rank deficiency).
_RCOND = 1e-12


def _sylvester_parts(A: np.ndarray, X: np.ndarray):
    """Eigendecompositions shared by every lambda: ``a, P`` of A^T A, ``b, Q`` of X^T X, P^T A^T X Q."""
    a, P = np.linalg.eigh(A.T @ A)
    b, Q = np.linalg.eigh(X.T @ X)
    a = np.clip(a, 0.0, None)  # PSD: clip round-off below zero
    b = np.clip(b, 0.0, None)
    return a, P, b, Q, P.T @ (A.T @ X) @ Q


def _solve_parts(parts, lam: float) -> np.ndarray:
    """``W`` (m, d) from :func:`_sylvester_parts` for one lambda (minimum-norm where singular)."""
    a, P, b, Q, M = parts
    denom = a[:, None] + lam * b[None, :]
    tiny = _RCOND * max(float(denom.max()), np.finfo(float).tiny)
    inv = np.divide(1.0, denom, out=np.zeros_like(denom), where=denom > tiny)
    return P @ ((1.0 + lam) * M * inv) @ Q.T


def sylvester_solution(A: np.ndarray, X: np.ndarray, lam: float) -> np.ndarray:
    """SAE's encoder ``W`` (m, d) solving ``A^T A W + lam W X^T X = (1 + lam) A^T X``.

    Parameters
    ----------
    A : ndarray of shape (n, m)
        Attribute row of each sample.
    X : ndarray of shape (n, d)
        Features of each sample.
    lam : float
        The paper's lambda (> 0), weight of the encoder term ``||X W^T - A||^2``.

    Returns
    -------
    W : ndarray of shape (m, d)
    """
    return _solve_parts(_sylvester_parts(A, X), lam)


class SAE(EmbeddingAttributeModel):
    """Semantic autoencoder (Kodirov, Xiang and Gong, CVPR 2017), closed form.

    An attribute model: ``fit(X, A)`` learns the encoder ``W`` of the paper's relaxed objective by
    solving its Sylvester equation ``A W + W B = C``; ``predict(X)`` returns the attribute-space
    projection ``X W^T``, which a decision rule compares with class rows by cosine similarity.

    Parameters
    ----------
    lam : float, default=1.0
        The paper's lambda (> 0): weight of the encoder loss ``||X W^T - A||^2`` against the
        decoder loss ``||X - A W||^2``. Its useful size depends on the feature scale; with
        ``standardize=True`` each feature has unit variance.
    standardize : bool, default=True
        Z-score features with a StandardScaler fitted on the training trials inside ``fit``
        (the model has no intercept).

    Attributes
    ----------
    coef_ : ndarray of shape (n_attributes, n_features)
        The encoder ``W`` (on standardised features if ``standardize``).
    class_attributes_ : ndarray of shape (n_train_classes, n_attributes)
        The distinct training attribute rows (the training classes).
    scaler_ : StandardScaler or None
    n_attributes_, n_features_in_ : int

    Notes
    -----
    ``score_kind = "embedding"``; the registered method ``sae`` compares each projection with the
    candidate class rows by cosine similarity (:class:`~tzsl.models.NearestAttributeRule`).
    """

    _parameter_constraints: dict = {
        "lam": [Interval(Real, 0, None, closed="neither")],
        "standardize": ["boolean"],
    }

    def __init__(self, *, lam: float = 1.0, standardize: bool = True):
        self.lam = lam
        self.standardize = standardize

    @_fit_context(prefer_skip_nested_validation=True)
    def fit(self, X, y, groups=None):
        """Solve for the encoder ``W`` in closed form.

        Parameters
        ----------
        X : array-like of shape (n_trials, n_features)
        y : array-like of shape (n_trials, n_attributes)
            ``A``: the attribute row of each trial's class; the distinct rows are the training
            classes (0/1 or real).
        groups : array-like of shape (n_trials,) or None
            Object id per trial; unused (no hyper-parameter is selected), accepted for the
            attribute-model protocol.

        Returns
        -------
        self : SAE
        """
        X, A = validate_features_and_rows(self, X, y)
        self.class_attributes_, _ = training_classes(A, type(self).__name__)
        Xs = self._fit_scaler(X)
        self.coef_ = sylvester_solution(A, Xs, float(self.lam))
        self.n_attributes_ = A.shape[1]
        return self


class SAECV(EmbeddingAttributeModel):
    """SAE with ``lam`` chosen by class-held-out cross-validation on the training data.

    The training classes (distinct rows of ``A``) are split by
    :func:`~tzsl.models.protocol.class_grouped_folds` (each fold validates on >= 2 and trains on >= 2
    classes; classes sharing a row are one class, never alone in a fold); for every fold and every
    ``lam`` the encoder is fitted on the other classes (one pair of eigendecompositions per fold serves
    the whole grid) and scored among the fold's held-out classes (cosine to their rows), the situation
    of the test, by ``scoring`` (default: accuracy; :func:`~tzsl.models.protocol.heldout_scores`).
    Holding out classes holds out whole objects; test objects are never used. The best ``lam`` (mean
    criterion over folds; scores within
    :data:`~tzsl.models.protocol.TIE_TOLERANCE` of the best are tied and the smallest tied ``lam`` is
    kept: SAE's ``lam`` weighs the encoder against the decoder, neither end is simpler, and the
    smallest is the order the search always used) is refitted on all training trials.

    Parameters
    ----------
    lams : array-like of float, default=(1e-2, 1e-1, ..., 1e5)
        Candidate lambdas (each > 0), see :class:`SAE`.
    scoring : {"accuracy", "balanced_accuracy", "neg_log_loss"}, default="accuracy"
        Criterion on the held-out classes (:func:`~tzsl.models.protocol.heldout_scores`), on the
        cosine similarities.
    n_splits : int, default=5
        Folds of classes, capped at ``n_classes // 2`` so that each fold holds out >= 2 classes
        (see Notes for fewer than 4 classes).
    standardize : bool, default=True
        As in :class:`SAE`; the scaler is refitted on each fold's training part.
    grid_extensions : int >= 0, default=3 (``DEFAULT_GRID_EXTENSIONS``)
        Adaptive grid: while the chosen ``lam`` is the smallest or largest of the grid, the grid
        gains one log-scale step beyond that edge and is rescored on the same folds, at most this
        many times (:func:`~tzsl.models._zsl_input.extend_at_edge`). 0 keeps ``lams``.

    Attributes
    ----------
    best_lam_ : float
    lams_ : ndarray
        The final (sorted, possibly extended) grid that was scored.
    at_grid_edge_ : bool
        Whether ``best_lam_`` is still at an edge of ``lams_`` (extension bound reached).
    best_score_ : float
        Mean held-out criterion of ``best_lam_`` (higher is better).
    cv_scores_ : ndarray of shape (n_lams, n_splits)
        Held-out criterion of every lambda in every fold.
    coef_, class_attributes_, scaler_, n_attributes_, n_features_in_
        As in :class:`SAE`, refitted with ``best_lam_``.

    Notes
    -----
    With fewer than 4 training classes no fold can hold out 2 classes and train on 2: each fold
    then holds out one class, whose trials are classified among ALL training class rows.
    """

    _parameter_constraints: dict = {
        "lams": ["array-like"],
        "scoring": [StrOptions(set(SCORINGS))],
        "n_splits": [Interval(Integral, 2, None, closed="left")],
        "standardize": ["boolean"],
        "grid_extensions": [Interval(Integral, 0, None, closed="left")],
    }

    def __init__(
        self, *, lams=DEFAULT_LAMS, scoring: str = DEFAULT_SCORING, n_splits: int = 5, standardize: bool = True,
        grid_extensions: int = DEFAULT_GRID_EXTENSIONS,
    ):
        self.lams = lams
        self.scoring = scoring
        self.n_splits = n_splits
        self.standardize = standardize
        self.grid_extensions = grid_extensions

    def selected_params(self) -> dict:
        """Parameters that refit this model with the chosen ``lam`` and no search (``lams``).

        A refit on part of the training classes (posterior calibration's pseudo-unseen folds,
        :class:`tzsl.models.CalibratedZeroShotClassifier`) then has the scale of this fit.
        """
        check_is_fitted(self)
        return {"lams": (self.best_lam_,)}

    def _lam_grid(self) -> np.ndarray:
        try:
            lams = np.asarray(self.lams, dtype=np.float64).ravel()
        except (TypeError, ValueError):
            lams = np.array([np.nan])
        if lams.size == 0 or not np.all(np.isfinite(lams) & (lams > 0)):
            raise InvalidParameterError(
                f"The 'lams' parameter of SAECV must be a non-empty array of finite floats > 0. "
                f"Got {self.lams!r} instead."
            )
        return lams

    def _score_grid(self, prepared, lams: np.ndarray) -> int:
        """Fill ``cv_scores_`` (n_lams, n_folds) for ``lams`` on the prepared folds; index of the best lambda."""
        scores = []
        for parts, X_va, candidate_rows, truth in prepared:
            similarities = np.stack([cosine_similarities(X_va @ _solve_parts(parts, lam).T, candidate_rows)
                                     for lam in lams])  # (n_lams, n_held_out, n_candidates)
            scores.append(heldout_scores(similarities, truth, self.scoring))
        self.cv_scores_ = np.asarray(scores).T
        return best_within_tolerance(self.cv_scores_.mean(axis=1), (-lams,))[0]  # ties: the smallest lam

    @_fit_context(prefer_skip_nested_validation=True)
    def fit(self, X, y, groups=None):
        """Choose ``lam`` by class-held-out CV, then refit on all training trials.

        Parameters
        ----------
        X : array-like of shape (n_trials, n_features)
        y : array-like of shape (n_trials, n_attributes)
            ``A``: the attribute row of each trial's class; the distinct rows are the training
            classes (0/1 or real).
        groups : array-like of shape (n_trials,) or None
            Object id per trial; unused: folds hold out whole classes, hence whole objects.

        Returns
        -------
        self : SAECV
        """
        lams = np.sort(self._lam_grid())
        X, A = validate_features_and_rows(self, X, y)
        rows, cls = training_classes(A, "SAECV")
        n_classes = rows.shape[0]
        if n_classes >= 4:
            folds = class_grouped_folds(cls, self.n_splits, "SAECV")
        else:  # leave one class out, scored among all rows (Notes)
            folds = [(np.flatnonzero(cls != c), np.flatnonzero(cls == c)) for c in range(n_classes)]
        prepared = []  # per fold: the Sylvester parts (shared by every lambda), held-out features and truth
        for train, held_out in folds:
            held_rows = np.unique(cls[held_out])
            candidates = held_rows if held_rows.size >= 2 else np.arange(n_classes)
            X_tr, X_va = X[train], X[held_out]
            if self.standardize:
                scaler = StandardScaler().fit(X_tr)
                X_tr, X_va = scaler.transform(X_tr), scaler.transform(X_va)
            truth = np.searchsorted(candidates, cls[held_out])
            prepared.append((_sylvester_parts(A[train], X_tr), X_va, rows[candidates], truth))
        best = self._score_grid(prepared, lams)
        for _ in range(int(self.grid_extensions)):  # adaptive: step beyond an edge that was selected
            wider = extend_at_edge(lams, best)
            if wider is None:
                break
            lams = wider
            best = self._score_grid(prepared, lams)
        self.lams_ = lams
        self.at_grid_edge_ = lams.size > 1 and extend_at_edge(lams, best) is not None
        mean = self.cv_scores_.mean(axis=1)
        self.best_lam_ = float(lams[best])
        self.best_score_ = float(mean[best])
        self.class_attributes_ = rows
        self.coef_ = sylvester_solution(A, self._fit_scaler(X), self.best_lam_)
        self.n_attributes_ = A.shape[1]
        return self
