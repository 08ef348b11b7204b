"""Attribute embedding trained with the fabric paper's loss ``C + lambda R`` (F15).

The fabric ZSL paper (section 4.2) maps a sample to an estimated attribute vector
``f_i = sigmoid(W t_i + b)`` (``t_i`` the CNN+LSTM feature; here any feature vector, optionally
through one tanh hidden layer) and trains it with

    o_i(c) = -||f_i - l_c||^2                                    (eq. 3; c over TRAINING classes)
    C = sum_i -log softmax_c(o_i)(y_i)                            (classification term)
    R = sum_i ||f_i - l_{y_i}||^2                                  (regression term)
    L = C + lambda R                                              (eq. 4)

An unseen sample goes to the nearest class attribute vector, ``argmin_g ||f - a_g||``.

The two ends of the paper's lambda grid {0, 0.1, 1, 10, inf}:

* ``lam=0`` is the classification term alone; the paper says so ("when lambda = 0, the
  objective function concerns only the classification tasks").
* ``lam="inf"`` is the REGRESSION term alone: the limit of ``L / lambda`` as lambda -> inf, and
  the only reading under which Table 1 holds two different single-term ends. The sentence under
  Table 1 literally says inf is "the case in which the objective function only contains the term
  C", but that would make the inf column the same objective as the lambda = 0 column, whereas
  Table 1 reports different numbers for them (row Fold of ``FABRIC_TABLE1`` in
  :mod:`tzsl.studies.papers.numbers`) and section 5.2 argues that
  "a single regression loss may result in overfitting" and that the best accuracy comes from
  combining the losses "rather than just one or the other". We therefore take that sentence as a
  typo for R. ``lam=0`` reproduces the literal "C only" reading.

Implementation choices: the loss is averaged over samples (``L / n``) so that the weight decay
``alpha / 2 * sum ||W||^2`` (weights, not biases) does not depend on the sample count; the
minimiser for ``alpha = 0`` is unchanged. Gradients are analytic (see :func:`_loss_and_grad`);
training is full-batch L-BFGS from a seeded Glorot-uniform start.
"""

from __future__ import annotations

import numbers
import warnings
from numbers import Integral, Real

import numpy as np
from scipy.optimize import minimize
from scipy.special import expit, log_softmax
from sklearn.base import TransformerMixin
from sklearn.exceptions import ConvergenceWarning
from sklearn.preprocessing import StandardScaler
from sklearn.utils import check_random_state
from sklearn.utils._param_validation import Interval, StrOptions

from tzsl._scoring import squared_distances
from tzsl.exceptions import ConfigError
from tzsl.models._zsl_input import ZSLInputError, training_classes, validate_features_and_rows
from tzsl.models.embedding._eszsl import AttributeEmbeddingModel

__all__ = ["EmbeddingZSL", "loss_weights"]


def loss_weights(lam, owner: str | None = None) -> tuple[float, float]:
    """Weights ``(w_C, w_R)`` of the classification and regression terms for a paper lambda.

    Parameters
    ----------
    lam : float >= 0, or "inf" / ``float("inf")``
        Finite lambda gives ``(1, lambda)``: ``L = C + lambda R``. ``"inf"`` gives ``(0, 1)``:
        the regression term alone (see the module docstring for why).
    owner : str or None
        Estimator name put in front of the error message.

    Returns
    -------
    (w_C, w_R) : tuple of float
    """
    prefix = f"{owner}: " if owner else ""
    if isinstance(lam, str):
        if lam.strip().lower() in ("inf", "infinity"):
            return 0.0, 1.0
        raise ConfigError(f'{prefix}lam must be a number >= 0 or "inf", got {lam!r}')
    if (not isinstance(lam, numbers.Real) or isinstance(lam, bool)
            or np.isnan(lam) or lam < 0):  # type: ignore[call-overload]  # numpy's stub omits numbers.Real
        raise ConfigError(f'{prefix}lam must be a number >= 0 or "inf", got {lam!r}')
    if np.isinf(lam):  # type: ignore[call-overload]  # numpy's stub omits numbers.Real
        return 0.0, 1.0
    return 1.0, float(lam)


def _layer_shapes(n_features: int, n_attributes: int, hidden_units: int | None):
    """Shapes of ``[W1, b1, (W2, b2)]``; weights are (out, in)."""
    if hidden_units is None:
        return [(n_attributes, n_features), (n_attributes,)]
    return [
        (hidden_units, n_features),
        (hidden_units,),
        (n_attributes, hidden_units),
        (n_attributes,),
    ]


def _unpack(theta: np.ndarray, shapes) -> list[np.ndarray]:
    out, start = [], 0
    for shape in shapes:
        size = int(np.prod(shape))
        out.append(theta[start : start + size].reshape(shape))
        start += size
    return out


def _forward(params: list[np.ndarray], X: np.ndarray):
    """Embedding ``F`` (n, m) in (0, 1) and the hidden activations (n, h) or None."""
    if len(params) == 2:
        W, b = params
        return expit(X @ W.T + b), None
    W1, b1, W2, b2 = params
    H = np.tanh(X @ W1.T + b1)
    return expit(H @ W2.T + b2), H


_sq_dist = squared_distances  # one formula for training (here) and NearestAttributeRule


def _loss_and_grad(theta, shapes, X, y, L, w_c, w_r, alpha, with_grad=True):
    """Mean loss ``(w_C C + w_R R) / n + alpha/2 sum ||W||^2`` and its gradient.

    Parameters
    ----------
    theta : ndarray (n_params,)
        Flattened ``[W1, b1(, W2, b2)]``.
    X : ndarray (n, d)
    y : ndarray (n,) int
        Each sample's row in ``L``.
    L : ndarray (k, m)
        Class attribute vectors the softmax runs over.

    Notes
    -----
    With ``D_ic = ||f_i - l_c||^2``, ``P = softmax(-D)`` (rows) and ``E`` the one-hot labels:
    ``dC/dD = E - P`` and ``dD_ic/df_i = 2 (f_i - l_c)``, so, as the rows of ``P`` sum to one,
    ``dC/dF = 2 (P L - E L)``; ``dR/dF = 2 (F - E L)``. Then ``dZ = dF * F (1 - F)`` through
    the sigmoid, ``dW = dZ^T H``, ``db = sum_i dZ_i``, and through a tanh hidden layer
    ``dA = (dZ W2) * (1 - H^2)``, ``dW1 = dA^T X``. Weight decay adds ``alpha W``.
    """
    params = _unpack(theta, shapes)
    n = X.shape[0]
    F, H = _forward(params, X)
    L_y = L[y]
    diff = F - L_y
    reg = (diff**2).sum(axis=1)  # R_i
    loss = w_r * reg.sum()
    P = None
    if w_c:
        log_p = log_softmax(-_sq_dist(F, L), axis=1)
        loss += w_c * -log_p[np.arange(n), y].sum()
        P = np.exp(log_p)
    weights = params[0::2]
    loss = loss / n + 0.5 * alpha * sum(float((W**2).sum()) for W in weights)
    if not with_grad:
        return loss
    dF = 2.0 * w_r * diff
    if P is not None:
        dF += 2.0 * w_c * (P @ L - L_y)
    dZ = dF * (F * (1.0 - F)) / n
    if H is None:
        W, _ = params
        grads = [dZ.T @ X + alpha * W, dZ.sum(axis=0)]
    else:
        W1, _, W2, _ = params
        dA = (dZ @ W2) * (1.0 - H**2)
        grads = [dA.T @ X + alpha * W1, dA.sum(axis=0), dZ.T @ H + alpha * W2, dZ.sum(axis=0)]
    return loss, np.concatenate([g.ravel() for g in grads])


def _glorot_init(shapes, rng: np.random.RandomState) -> np.ndarray:
    parts = []
    for shape in shapes:
        if len(shape) == 2:
            limit = np.sqrt(6.0 / (shape[0] + shape[1]))
            parts.append(rng.uniform(-limit, limit, size=shape).ravel())
        else:
            parts.append(np.zeros(shape))
    return np.concatenate(parts)


class EmbeddingZSL(TransformerMixin, AttributeEmbeddingModel):
    """Features -> attribute embedding with the fabric paper's ``C + lambda R`` loss.

    An attribute model: ``fit(X, Y)`` with ``Y`` (n, m) the attribute row of each trial's class
    (the training classes are the distinct rows of ``Y``); ``decision_function(X)`` (and
    ``transform``) give the estimated attribute vector ``f(x)`` (n, m), ranked against any class
    table by :class:`tzsl.models.NearestAttributeRule` (``argmin_g ||f - a_g||``).

    Parameters
    ----------
    lam : float >= 0 or "inf", default=1.0
        The paper's lambda. ``0``: classification term C only; ``"inf"``: regression term R only
        (see the module docstring for this mapping).
    hidden_units : int or None, default=None
        ``None``: ``f = sigmoid(W x + b)``, as in the paper's last layer. An int adds one tanh
        hidden layer of that width.
    alpha : float >= 0, default=1e-3
        Weight decay, ``alpha / 2 * sum ||W||^2`` on the weights (biases are not decayed), added
        to the per-sample mean loss.
    max_iter : int, default=500
        Maximum L-BFGS iterations.
    early_stopping : bool, default=True
        Hold out whole training classes (``validation_fraction`` of them, at least one), train on
        the rest while tracking the loss of the held-out samples (softmax over ALL training
        classes, so a single held-out class is still informative), stop after
        ``n_iter_no_change`` iterations without improvement, then retrain on all training
        classes from the same start for the best iteration count.
    validation_fraction : float in (0, 1), default=0.2
        Share of training classes held out for early stopping (rounded, at least 1).
    n_iter_no_change : int, default=20
        Patience of early stopping, in L-BFGS iterations.
    standardize : bool, default=True
        Z-score features with a StandardScaler fitted on the training samples inside ``fit``
        (sigmoid units saturate on raw scales).
    random_state : int, RandomState or None, default=None
        Seeds the weight initialisation and the choice of validation classes.

    Attributes
    ----------
    coefs_ : list of ndarray
        ``[W1, b1]`` or ``[W1, b1, W2, b2]``; weights are (out, in).
    class_attributes_ : ndarray (n_train_classes, n_attributes)
        Distinct training attribute rows (``np.unique(Y, axis=0)``).
    scaler_ : StandardScaler or None
    loss_ : float
        Final training loss (mean, with weight decay).
    n_iter_ : int
        L-BFGS iterations of the final fit.
    validation_classes_ : ndarray or None
        Rows of ``class_attributes_`` held out for early stopping.
    validation_losses_ : ndarray or None
        Held-out loss after each iteration of the early-stopping run.
    best_iteration_ : int or None
    n_attributes_, n_features_in_ : int

    Notes
    -----
    Attributes need not be binary; the sigmoid output lies in (0, 1), so attribute values outside
    that range can be approached but not reached by R.
    """

    _parameter_constraints: dict = {
        "lam": [Interval(Real, 0, None, closed="left"), StrOptions({"inf"})],
        "hidden_units": [None, Interval(Integral, 1, None, closed="left")],
        "alpha": [Interval(Real, 0, None, closed="left")],
        "max_iter": [Interval(Integral, 1, None, closed="left")],
        "early_stopping": ["boolean"],
        "validation_fraction": [Interval(Real, 0, 1, closed="neither")],
        "n_iter_no_change": [Interval(Integral, 1, None, closed="left")],
        "standardize": ["boolean"],
        "random_state": ["random_state"],
    }

    def __init__(
        self,
        *,
        lam=1.0,
        hidden_units=None,
        alpha=1e-3,
        max_iter=500,
        early_stopping=True,
        validation_fraction=0.2,
        n_iter_no_change=20,
        standardize=True,
        random_state=None,
    ):
        self.lam = lam
        self.hidden_units = hidden_units
        self.alpha = alpha
        self.max_iter = max_iter
        self.early_stopping = early_stopping
        self.validation_fraction = validation_fraction
        self.n_iter_no_change = n_iter_no_change
        self.standardize = standardize
        self.random_state = random_state

    # ---------------------------------------------------------------- training
    def _minimize(self, theta0, shapes, X, y, L, weights, maxiter, callback=None):
        w_c, w_r = weights
        return minimize(
            _loss_and_grad,
            theta0,
            args=(shapes, X, y, L, w_c, w_r, float(self.alpha)),
            jac=True,
            method="L-BFGS-B",
            callback=callback,
            options={"maxiter": maxiter},
        )

    def fit(self, X, Y, groups=None):
        """Train the embedding.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
        Y : array-like of shape (n_samples, n_attributes)
            Attribute row of each sample's class.
        groups : array-like of shape (n_samples,), optional
            Object or class of each sample; orders the classes (see
            :func:`tzsl.models.protocol.training_classes`), which fixes the early-stopping hold-out.

        Returns
        -------
        self : EmbeddingZSL
        """
        self._validate_params()
        name = type(self).__name__
        weights = loss_weights(self.lam, owner=name)
        X, Y = validate_features_and_rows(self, X, Y)
        S_u, y_u = training_classes(Y, name, groups)
        rng = check_random_state(self.random_state)
        self.scaler_ = StandardScaler().fit(X) if self.standardize else None
        Xs = X if self.scaler_ is None else self.scaler_.transform(X)
        shapes = _layer_shapes(X.shape[1], S_u.shape[1], self.hidden_units)
        theta0 = _glorot_init(shapes, rng)

        self.validation_classes_ = None
        self.validation_losses_ = None
        self.best_iteration_ = None
        maxiter = int(self.max_iter)
        if self.early_stopping:
            maxiter = self._early_stopping_run(Xs, y_u, S_u, shapes, theta0, weights, rng)
        result = self._minimize(theta0, shapes, Xs, y_u, S_u, weights, maxiter)
        if not self.early_stopping and result.nit >= maxiter and not result.success:
            warnings.warn(
                f"{name}: L-BFGS stopped after max_iter={maxiter} iterations without "
                "converging; raise max_iter or use early_stopping",
                ConvergenceWarning,
                stacklevel=2,
            )
        self.coefs_ = _unpack(result.x.copy(), shapes)
        self.loss_ = float(result.fun)
        self.n_iter_ = int(result.nit)
        self.class_attributes_ = S_u
        self.n_attributes_ = S_u.shape[1]
        return self

    def _early_stopping_run(self, Xs, y_u, S_u, shapes, theta0, weights, rng) -> int:
        """Choose the iteration count on held-out classes; returns it."""
        name = type(self).__name__
        n_groups = S_u.shape[0]
        n_val = max(1, int(round(self.validation_fraction * n_groups)))
        if n_groups - n_val < 2:
            raise ZSLInputError(
                f"{name}: early stopping holds out {n_val} of {n_groups} training classes, "
                "leaving fewer than 2 to train on; use more classes or early_stopping=False"
            )
        val_groups = np.sort(rng.choice(n_groups, size=n_val, replace=False))
        is_val = np.isin(y_u, val_groups)
        X_tr, X_va, y_va = Xs[~is_val], Xs[is_val], y_u[is_val]
        tr_groups = np.setdiff1d(np.arange(n_groups), val_groups)
        y_tr = np.searchsorted(tr_groups, y_u[~is_val])
        w_c, w_r = weights
        losses: list[float] = []
        patience = int(self.n_iter_no_change)

        def callback(intermediate_result):
            val = _loss_and_grad(
                intermediate_result.x, shapes, X_va, y_va, S_u, w_c, w_r, 0.0, with_grad=False
            )
            losses.append(float(val))
            if len(losses) - 1 - int(np.argmin(losses)) >= patience:
                raise StopIteration

        self._minimize(
            theta0, shapes, X_tr, y_tr, S_u[tr_groups], weights, int(self.max_iter), callback
        )
        self.validation_classes_ = val_groups
        self.validation_losses_ = np.asarray(losses)
        if not losses:  # converged before the first callback
            self.best_iteration_ = 1
        else:
            self.best_iteration_ = int(np.argmin(losses)) + 1
        return self.best_iteration_

    # ---------------------------------------------------------------- inference
    def _embed(self, X):
        return _forward(self.coefs_, X)[0]

    def transform(self, X) -> np.ndarray:
        """Estimated attribute vectors ``f`` of shape (n_samples, n_attributes), in (0, 1)."""
        return self.decision_function(X)
