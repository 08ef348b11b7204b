"""Bilinear compatibility models ALE, SJE and DeViSE, trained by minibatch SGD.

All three score a trial ``x`` (d,) against a class with attribute row ``phi(y)`` (m,) by the
bilinear compatibility

    F(x, y) = x^T W phi(y),        W: (d, m)

and learn ``W`` from the training classes (the distinct attribute rows of the fit ``A``) with a
ranking loss over the hinge terms ``h_y = [Delta(y_i, y) + F(x_i, y) - F(x_i, y_i)]_+`` with the
0/1 label loss ``Delta(y_i, y) = 1[y != y_i]`` (margin 1):

* **DeViSE**, Frome et al., "DeViSE: A Deep Visual-Semantic Embedding Model", NIPS 2013:
  the hinge rank loss summed over every violating class, ``l_i = sum_{y != y_i} h_y``.
* **SJE**, Akata, Reed, Walter, Lee and Schiele, "Evaluation of Output Embeddings for
  Fine-Grained Image Classification", CVPR 2015 (structured joint embedding): the
  multiclass structured SVM loss on the most violating class, ``l_i = max_y h_y``.
* **ALE**, Akata, Perronnin, Harchaoui and Schmid, "Label-Embedding for Attribute-Based
  Classification", CVPR 2013 / "Label-Embedding for Image Classification", TPAMI 2016:
  the weighted approximate ranking (WARP) loss ``l_i = (beta_r / r) sum_{y != y_i} h_y`` with
  ``r`` the number of violating classes (``h_y > 0``) and ``beta_r = sum_{k=1..r} 1/k``, which
  weights a true class ranked low more heavily (rank-weighted with alpha_k = 1/k).

Every loss is ``sum_y w_iy h_y`` with non-negative weights ``w_iy`` on the violating classes, so its
(sub)gradient is ``x_i (sum_y w_iy (phi(y) - phi(y_i)))^T``; one minibatch's gradient is
``X_B^T C Phi / |B|`` with the (|B|, z) matrix ``C`` of those weights, computed without a loop over
samples. The objective adds ``alpha / 2 ||W||_F^2``. The papers regularise by early stopping on a
validation split instead; a fixed number of epochs and a small ``alpha`` play that role here.

Step size: ``eta = learning_rate * |B| / (mean_i ||x_i||^2 * mean_{y != y'} ||phi(y) - phi(y')||^2)``,
so that a step moves the margin of a violated pair in the minibatch by about ``learning_rate``
(the loss is a mean over the minibatch), whatever the number and scale of features and attributes
and the batch size (features are standardised inside ``fit`` by default).
"""

from __future__ import annotations

from numbers import Integral, Real

import numpy as np
from sklearn.base import _fit_context
from sklearn.utils import check_random_state
from sklearn.utils._param_validation import Interval

from tzsl.models._attribute_model_base import EmbeddingAttributeModel
from tzsl.models._zsl_input import training_classes, validate_features_and_rows

__all__ = ["ALE", "DeViSE", "SJE", "ranking_loss_and_gradient", "ranking_loss_weights"]

_LOSSES = ("ale", "sje", "devise")


def ranking_loss_weights(hinge: np.ndarray, loss: str) -> np.ndarray:
    """Weights ``w_iy`` of each hinge term in the per-sample ranking loss.

    Parameters
    ----------
    hinge : ndarray of shape (n, z)
        ``[1 + F(x_i, y) - F(x_i, y_i)]_+`` with the true class's own entry set to 0.
    loss : {"ale", "sje", "devise"}

    Returns
    -------
    weights : ndarray of shape (n, z)
        Non-negative, zero where ``hinge == 0``; the loss of sample ``i`` is
        ``sum_y weights[i, y] * hinge[i, y]``.
    """
    violating = hinge > 0
    if loss == "devise":
        return violating.astype(float)
    if loss == "sje":
        weights = np.zeros_like(hinge)
        worst = np.argmax(hinge, axis=1)
        rows = np.arange(hinge.shape[0])
        weights[rows, worst] = violating[rows, worst]
        return weights
    if loss == "ale":
        rank = violating.sum(axis=1)  # r: number of violating classes
        harmonic = np.concatenate([[0.0], np.cumsum(1.0 / np.arange(1, hinge.shape[1] + 1))])
        per_violator = harmonic[rank] / np.maximum(rank, 1)  # beta_r / r
        return violating * per_violator[:, None]
    raise ValueError(f"unknown ranking loss {loss!r}; choose one of {_LOSSES}")


def _hinge(scores: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``[1 + s_iy - s_iyi]_+`` for (n, z) scores and true classes ``y`` (n,); true entry 0."""
    rows = np.arange(scores.shape[0])
    hinge = np.maximum(1.0 + scores - scores[rows, y][:, None], 0.0)
    hinge[rows, y] = 0.0
    return hinge


def ranking_loss_and_gradient(
    W: np.ndarray, X: np.ndarray, y: np.ndarray, Phi: np.ndarray, loss: str
) -> tuple[float, np.ndarray]:
    """Mean ranking loss of a minibatch and its (sub)gradient with respect to ``W``.

    Parameters
    ----------
    W : ndarray of shape (n_features, n_attributes)
    X : ndarray of shape (b, n_features)
        Minibatch features.
    y : ndarray of shape (b,), int
        Row of ``Phi`` of each trial's class.
    Phi : ndarray of shape (n_classes, n_attributes)
        Attribute rows of the classes ranked against each other.
    loss : {"ale", "sje", "devise"}

    Returns
    -------
    loss : float
        ``mean_i sum_y w_iy h_iy`` (no weight decay).
    grad : ndarray of shape (n_features, n_attributes)
        ``X^T C Phi / b`` with ``C[i, y] = w_iy`` and ``C[i, y_i] = -sum_y w_iy``.
    """
    hinge = _hinge(X @ W @ Phi.T, y)  # (b, n_classes)
    C = ranking_loss_weights(hinge, loss)
    value = float((C * hinge).sum()) / X.shape[0]
    C[np.arange(X.shape[0]), y] -= C.sum(axis=1)
    return value, X.T @ (C @ Phi) / X.shape[0]


def _step_scale(X: np.ndarray, Phi: np.ndarray) -> float:
    """``mean_i ||x_i||^2 * mean_{y != y'} ||phi(y) - phi(y')||^2`` for (n, d) X and (z, m) Phi.

    One SGD step on a single violated pair ``(y_i, y)`` with step ``1 / scale`` moves that
    sample's margin ``F(x_i, y_i) - F(x_i, y)`` by about 1.
    """
    z = Phi.shape[0]
    mean_sq = float(np.mean(np.sum(Phi**2, axis=1)))
    pair_sq = 2.0 * (mean_sq - float(np.sum(Phi.mean(axis=0) ** 2))) * z / (z - 1)
    return float(np.mean(np.sum(X**2, axis=1))) * pair_sq


_DOC_PARAMS = """
    Parameters
    ----------
    learning_rate : float, default=1.0
        SGD step in margin units (> 0): about how far one step moves the margin of a violated
        pair of classes for a trial of the minibatch; see the module docstring.
    n_epochs : int, default=50
        Passes over the training trials (the papers stop early on a validation split).
    batch_size : int, default=32
        Trials per SGD step (the gradient is vectorised over the minibatch).
    alpha : float, default=1e-3
        L2 weight decay ``alpha / 2 ||W||^2`` (>= 0).
    standardize : bool, default=True
        Z-score features with a StandardScaler fitted on the training trials inside ``fit``.
    random_state : int, RandomState or None, default=None
        Seeds the initial ``W`` (tiny Gaussian) and the minibatch shuffling.

    Attributes
    ----------
    coef_ : ndarray of shape (n_attributes, n_features)
        ``W^T``: ``predict(X) = X W`` (on standardised features), compared with class rows by
        dot product (:class:`~tzsl.models.CompatibilityRule`).
    class_attributes_ : ndarray of shape (n_train_classes, n_attributes)
        Distinct training attribute rows (the training classes).
    loss_curve_ : ndarray of shape (n_epochs,)
        Mean ranking loss per trial during each epoch (without the ``alpha`` term).
    scaler_ : StandardScaler or None
    n_attributes_, n_features_in_, n_iter_ : int
"""


class _BilinearCompatibility(EmbeddingAttributeModel):
    """Shared SGD training of ``F(x, y) = x^T W phi(y)``; subclasses set ``_loss``."""

    _loss = "devise"

    _parameter_constraints: dict = {
        "learning_rate": [Interval(Real, 0, None, closed="neither")],
        "n_epochs": [Interval(Integral, 1, None, closed="left")],
        "batch_size": [Interval(Integral, 1, None, closed="left")],
        "alpha": [Interval(Real, 0, None, closed="left")],
        "standardize": ["boolean"],
        "random_state": ["random_state"],
    }

    def __init__(
        self,
        *,
        learning_rate: float = 1.0,
        n_epochs: int = 50,
        batch_size: int = 32,
        alpha: float = 1e-3,
        standardize: bool = True,
        random_state=None,
    ):
        self.learning_rate = learning_rate
        self.n_epochs = n_epochs
        self.batch_size = batch_size
        self.alpha = alpha
        self.standardize = standardize
        self.random_state = random_state

    @_fit_context(prefer_skip_nested_validation=True)
    def fit(self, X, y, groups=None):
        """Learn ``W`` by minibatch SGD on the ranking loss over the training classes.

        Parameters
        ----------
        X : array-like of shape (n_trials, n_features)
        y : array-like of shape (n_trials, n_attributes)
            ``A``: the attribute row of each trial's class; the distinct rows are the training
            classes ``phi(y)`` (0/1 or real).
        groups : array-like of shape (n_trials,) or None
            Object id per trial; unused (no hyper-parameter is selected), accepted for the
            attribute-model protocol.

        Returns
        -------
        self
        """
        X, A = validate_features_and_rows(self, X, y)
        Phi, cls = training_classes(A, type(self).__name__)  # (z, m), (n,)
        Xs = self._fit_scaler(X)
        rng = check_random_state(self.random_state)
        n, d = Xs.shape
        m = Phi.shape[1]
        batch = min(int(self.batch_size), n)
        eta = self.learning_rate * batch / max(_step_scale(Xs, Phi), np.finfo(float).tiny)
        W = rng.normal(scale=1e-3 / np.sqrt(max(d * m, 1)), size=(d, m))
        curve = []
        for _ in range(int(self.n_epochs)):
            order = rng.permutation(n)
            total = 0.0
            for start in range(0, n, batch):
                idx = order[start : start + batch]
                loss, grad = ranking_loss_and_gradient(W, Xs[idx], cls[idx], Phi, self._loss)
                total += loss * idx.size
                W -= eta * (grad + self.alpha * W)
            curve.append(total / n)
        self.coef_ = W.T
        self.class_attributes_ = Phi
        self.n_attributes_ = m
        self.loss_curve_ = np.asarray(curve)
        self.n_iter_ = int(self.n_epochs)
        return self


class ALE(_BilinearCompatibility):
    __doc__ = (
        """Attribute label embedding (Akata et al., CVPR 2013 / TPAMI 2016), WARP ranking loss.

    An attribute model: ``fit(X, A)`` learns ``F(x, y) = x^T W phi(y)`` over the distinct rows of
    ``A`` with ``l_i = (beta_r / r) sum_y h_y``; ``predict(X)`` returns ``X W``.
"""
        + _DOC_PARAMS
    )
    _loss = "ale"


class SJE(_BilinearCompatibility):
    __doc__ = (
        """Structured joint embedding (Akata et al., CVPR 2015), multiclass structured hinge loss.

    An attribute model: ``fit(X, A)`` learns ``F(x, y) = x^T W phi(y)`` over the distinct rows of
    ``A`` with ``l_i = max_y h_y``; ``predict(X)`` returns ``X W``.
"""
        + _DOC_PARAMS
    )
    _loss = "sje"


class DeViSE(_BilinearCompatibility):
    __doc__ = (
        """DeViSE (Frome et al., NIPS 2013): hinge rank loss summed over all violating classes.

    An attribute model: ``fit(X, A)`` learns ``F(x, y) = x^T W phi(y)`` over the distinct rows of
    ``A`` with ``l_i = sum_{y != y_i} h_y``; ``predict(X)`` returns ``X W``.
"""
        + _DOC_PARAMS
    )
    _loss = "devise"
