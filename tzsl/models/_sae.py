"""SAE: semantic autoencoder for zero-shot learning, closed form.

Kodirov, Xiang and Gong, "Semantic Autoencoder for Zero-Shot Learning", CVPR 2017. A linear
encoder ``W`` projects features into attribute space and its transpose decodes them back:

    min_W  ||X - W^T S||_F^2 + lambda ||W X - S||_F^2                        (paper, eq. 6)

with samples as COLUMNS (``X`` d x N, ``S`` k x N). Setting the derivative to zero gives the
Sylvester equation

    S S^T W + W (lambda X X^T) = (1 + lambda) S X^T                            (paper, eq. 8-9)

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

from numbers import Real

import numpy as np
from sklearn.base import _fit_context
from sklearn.utils._param_validation import Interval

from tzsl.models._attribute_model_base import (
    EmbeddingAttributeModel,
    training_classes,
    validate_fit_data,
)

__all__ = ["SAE", "sylvester_solution"]

#: Relative size below which ``a_i + lambda b_j`` counts as zero (rank deficiency).
_RCOND = 1e-12


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
    a, P = np.linalg.eigh(A.T @ A)
    b, Q = np.linalg.eigh(X.T @ X)
    a = np.clip(a, 0.0, None)  # PSD: clip round-off below zero
    b = np.clip(b, 0.0, None)
    denom = a[:, None] + lam * b[None, :]
    tiny = _RCOND * max(float(denom.max()), np.finfo(float).tiny)
    inv = np.divide(1.0, denom, out=np.zeros_like(denom), where=denom > tiny)
    C = (1.0 + lam) * (P.T @ (A.T @ X) @ Q)
    return P @ (C * inv) @ Q.T


class SAE(EmbeddingAttributeModel):
    """Semantic autoencoder (Kodirov, Xiang and Gong, CVPR 2017), closed form.

    An attribute model: ``fit(X, A)`` learns the encoder ``W`` of the paper's eq. 6 by solving its
    Sylvester equation (eq. 9); ``predict(X)`` returns the attribute-space projection ``X W^T``,
    which a decision rule compares with class attribute rows by cosine similarity.

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
    ``score_kind = "embedding"`` and ``default_rule = "cosine"``: :meth:`class_scores` gives the
    cosine similarity of each projection with each candidate class row.
    """

    default_rule = "cosine"

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
        X, A = validate_fit_data(self, X, y)
        self.class_attributes_, _ = training_classes(A, type(self).__name__)
        Xs = self._fit_scaler(X)
        self.coef_ = sylvester_solution(A, Xs, float(self.lam))
        self.n_attributes_ = A.shape[1]
        return self
