"""Predict-time arithmetic of the zero-shot models in numpy alone (importing it never imports scikit-learn).

The estimators of :mod:`tzsl.models` and the load-once predictor of :mod:`tzsl.inference` share
these functions, so a bundle stored as arrays (a linear map: ESZSL, SAE, ALE, SJE, DeViSE,
:mod:`tzsl.inference.linear_bundles`; a DAP model, :mod:`tzsl.inference.detector_bundles`) ranks
classes exactly as its estimator does, without importing scikit-learn (most of a cold process's start):

* :func:`linear_embedding`: standardise and map features to attribute space;
* :func:`compatibility_scores`, :func:`squared_distances`, :func:`cosine_similarities`: class
  scores of the decision rules (:class:`tzsl.models.CompatibilityRule`,
  :class:`tzsl.models.NearestAttributeRule`);
* :func:`class_posteriors` (:func:`tempered_proba`, with a calibrator's temperature): class posteriors,
  and :func:`valid_probabilities`: attribute posteriors; the one place probabilities are made valid
  (rounding a hair outside [0, 1] clipped, a real fault named in plain numbers: see below);
* :func:`sc_mdap`: multi-grasp decision fusion (DAP paper section 5.7.3);
* DAP (:mod:`tzsl.models.dap`, paper eqs. 3-6): :func:`check_class_attributes`,
  :func:`check_attribute_posteriors`, :func:`fuse_attribute_posteriors` (MAXDAP / AVGDAP),
  :func:`attribute_prior`, :func:`dap_log_scores` (and its per-attribute terms,
  :func:`dap_attribute_terms`), read by :class:`tzsl.models.DAPRule` and by DAP bundles stored as arrays;
* :func:`duplicate_attribute_groups`: classes whose attribute rows are identical (they tie in every ranking).
"""

from __future__ import annotations

from numbers import Integral

import numpy as np

from tzsl.exceptions import ConfigError, DataFileError
from tzsl.value_lists import FUSIONS, PRIORS

__all__ = ["DEFAULT_EPS", "ROUNDING_TOLERANCE", "attribute_prior", "check_attribute_posteriors",
           "check_class_attributes", "class_posteriors", "compatibility_scores", "cosine_similarities",
           "dap_attribute_terms", "dap_log_scores", "duplicate_attribute_groups", "fuse_attribute_posteriors",
           "linear_embedding", "sc_mdap", "squared_distances", "tempered_proba", "valid_probabilities"]


def linear_embedding(X: np.ndarray, weights: np.ndarray, mean: np.ndarray | None = None,
                     scale: np.ndarray | None = None) -> np.ndarray:
    """Attribute-space scores of a linear embedding, ``((X - mean) / scale) @ weights``.

    Parameters
    ----------
    X : ndarray of shape (n_trials, n_features)
        Features in the units the model was fitted with (float64).
    weights : ndarray of shape (n_features, n_attributes)
    mean, scale : ndarray of shape (n_features,), optional
        The standardisation fitted on the training trials (a
        :class:`~sklearn.preprocessing.StandardScaler`'s ``mean_`` and ``scale_``, applied the
        same way); None: the features are used as they are.

    Returns
    -------
    ndarray of shape (n_trials, n_attributes)
    """
    if mean is not None:
        X = (X - mean) / scale
    return X @ weights


def compatibility_scores(F: np.ndarray, K: np.ndarray) -> np.ndarray:
    """Bilinear compatibility ``F K^T`` of attribute-space scores with class rows.

    Parameters
    ----------
    F : ndarray of shape (n_trials, n_attributes)
    K : ndarray of shape (n_classes, n_attributes)

    Returns
    -------
    ndarray of shape (n_trials, n_classes)
    """
    return F @ K.T


def squared_distances(F: np.ndarray, L: np.ndarray) -> np.ndarray:
    """Squared Euclidean distances between rows, ``||f_i - l_c||^2``.

    Parameters
    ----------
    F : ndarray of shape (n, m)
    L : ndarray of shape (k, m)

    Returns
    -------
    ndarray of shape (n, k)
    """
    return (F**2).sum(axis=1)[:, None] - 2.0 * F @ L.T + (L**2).sum(axis=1)[None, :]


def cosine_similarities(F: np.ndarray, K: np.ndarray) -> np.ndarray:
    """Cosine similarity of estimated attribute vectors with class rows.

    Parameters
    ----------
    F : ndarray of shape (n_trials, n_attributes)
    K : ndarray of shape (n_classes, n_attributes)

    Returns
    -------
    ndarray of shape (n_trials, n_classes), values in [-1, 1]
        An all-zero vector (either side) has similarity 0 to everything.
    """
    nf = np.linalg.norm(F, axis=1, keepdims=True)
    nk = np.linalg.norm(K, axis=1, keepdims=True)
    return (F / np.where(nf > 0, nf, 1.0)) @ (K / np.where(nk > 0, nk, 1.0)).T


#: How far outside [0, 1] a probability may stray by rounding and still be clipped into it (float32's
#: machine epsilon is 1.2e-7; a float64 sum of products strays by a few 1e-16).
ROUNDING_TOLERANCE = 1e-6

#: Names of the axes of a posterior array, by its number of dimensions.
_AXES = {1: ("trial",), 2: ("trial", "attribute"), 3: ("trial", "sensor", "attribute")}


def _position(index: tuple[int, ...], axes: tuple[str, ...]) -> str:
    """``"trial 115, attribute 1"``: an array index in words, plain integers."""
    return ", ".join(f"{name} {int(i)}" for name, i in zip(axes, index, strict=True))


def valid_probabilities(P, what: str = "attribute posteriors", *, axes: tuple[str, ...] | None = None) -> np.ndarray:
    """``P`` as float64 in [0, 1], rounding clipped; NaN or a real excursion raises.

    Parameters
    ----------
    P : array-like of shape (n_trials,), (n_trials, n_attributes) or (n_trials, n_sensors, n_attributes)
        Probabilities (unitless).
    what : str
        What ``P`` is, for the error message.
    axes : tuple of str, optional
        Names of ``P``'s axes for the error message; default ``trial[, sensor], attribute``.

    Returns
    -------
    ndarray of the shape of ``P``, float64
        ``P`` with values in ``[-ROUNDING_TOLERANCE, 0)`` set to 0 and in ``(1, 1 + ROUNDING_TOLERANCE]``
        set to 1. A new array only when something was clipped or converted.

    Raises
    ------
    ConfigError
        A NaN, or a value further than :data:`ROUNDING_TOLERANCE` outside [0, 1]; the message names
        the first such position and value in plain numbers.
    """
    P = np.asarray(P, dtype=np.float64)
    inside = (P >= 0.0) & (P <= 1.0)  # False for NaN
    if inside.all():
        return P
    near = (P >= -ROUNDING_TOLERANCE) & (P <= 1.0 + ROUNDING_TOLERANCE)
    if not near.all():
        index = tuple(int(i) for i in np.argwhere(~near)[0])
        names = axes if axes is not None else _AXES.get(P.ndim, tuple(f"axis {k}" for k in range(P.ndim)))
        value = float(P[index])
        raise ConfigError(f"{what} must lie in [0, 1]; found {value!r} at {_position(index, names)}")
    return np.clip(P, 0.0, 1.0)


def class_posteriors(scores, temperature: float = 1.0) -> np.ndarray:
    """``softmax(scores / temperature)`` over the classes: rows in [0, 1] that sum to 1.

    Parameters
    ----------
    scores : array-like of shape (n_trials, n_classes)
        Class scores, larger is better (DAP: log-posteriors up to a per-trial constant). ``-inf``
        is allowed (a class that cannot be) as long as each row has a finite score.
    temperature : float > 0
        Divides the scores (1: the method's own softmax).

    Returns
    -------
    ndarray of shape (n_trials, n_classes), float64
        Class posteriors; each row sums to 1 up to rounding.

    Raises
    ------
    ConfigError
        A NaN or ``+inf`` score, or a row without any finite score (the message names the trial and
        class in plain numbers).
    """
    S = np.asarray(scores, dtype=np.float64)
    if S.ndim != 2:
        raise ConfigError(f"class scores must have 2 dimensions (trials x classes), got shape {S.shape}")
    bad = np.isnan(S) | (S == np.inf)
    if bad.any():
        trial, cls = (int(i) for i in np.argwhere(bad)[0])
        raise ConfigError(f"class scores must be numbers or -inf; found {float(S[trial, cls])!r} at trial {trial}, "
                          f"class {cls}")
    if S.shape[1] and not np.isfinite(S).any(axis=1).all():
        trial = int(np.flatnonzero(~np.isfinite(S).any(axis=1))[0])
        raise ConfigError(f"class scores of trial {trial} are -inf for every class: no class can be ranked")
    S = S / float(temperature)
    with np.errstate(over="ignore", invalid="ignore"):  # scores a float range apart: exp underflows to 0
        shifted = np.exp(S - S.max(axis=1, keepdims=True))  # shifted by the row maximum, as scipy's softmax
        P = shifted / shifted.sum(axis=1, keepdims=True)
    return valid_probabilities(P, "class posteriors", axes=("trial", "class"))


def tempered_proba(scores, temperature: float) -> np.ndarray:
    """``softmax(scores / temperature)`` over the classes: :func:`class_posteriors` (a calibrator's name for it).

    Parameters
    ----------
    scores : array-like of shape (n_trials, n_classes)
        Class scores (larger is better; DAP: log-posteriors up to a per-trial constant).
    temperature : float > 0

    Returns
    -------
    ndarray of shape (n_trials, n_classes)
        Rows sum to 1.
    """
    return class_posteriors(scores, temperature)


def duplicate_attribute_groups(A: np.ndarray) -> list[np.ndarray]:
    """Groups of rows sharing an attribute vector.

    Parameters
    ----------
    A : ndarray of shape (n, n_attributes)

    Returns
    -------
    list of int ndarray
        Row indices (ascending) of each vector that occurs more than once, ordered by first
        occurrence. Empty when all rows differ.
    """
    A = np.asarray(A)
    if A.shape[0] < 2:
        return []
    _, first, inverse, counts = np.unique(
        A.reshape(A.shape[0], -1), axis=0, return_index=True, return_inverse=True, return_counts=True
    )
    inverse = inverse.reshape(-1)
    groups = [np.flatnonzero(inverse == g) for g in np.flatnonzero(counts > 1)]
    return sorted(groups, key=lambda g: g[0])


def sc_mdap(decisions: np.ndarray, k_equal: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """SC-MDAP: stop at the first class decided ``k_equal`` times.

    Parameters
    ----------
    decisions : array-like of int, shape (..., T)
        Per-grasp class decisions (class indices >= 0, e.g. LDAP argmax), in grasp order.
    k_equal : int
        Number of equal classifications required (``k`` in the paper); ``k_equal = 1`` returns
        the first grasp's decision.

    Returns
    -------
    decision : ndarray of int, shape (...,)
        The class that first reached ``k_equal`` decisions; for undecided sequences the most
        frequent class (ties: the class reaching that count earliest).
    n_used : ndarray of int, shape (...,)
        Grasps used: position (1-based) of the grasp that completed ``k_equal`` decisions, or
        ``T`` when undecided.
    decided : ndarray of bool, shape (...,)
        Whether some class reached ``k_equal`` within the ``T`` grasps.
    """
    d = np.asarray(decisions)
    if d.ndim < 1 or d.shape[-1] < 1:
        raise ConfigError(f"decisions must have shape (..., T) with T >= 1, got {d.shape}")
    if not np.issubdtype(d.dtype, np.integer) or (d < 0).any():
        raise ConfigError("decisions must be non-negative integer class indices")
    if not isinstance(k_equal, Integral) or k_equal < 1:
        raise ConfigError(f"k_equal must be a positive integer, got {k_equal!r}")
    lead, T = d.shape[:-1], d.shape[-1]
    flat = d.reshape(-1, T)
    n = flat.shape[0]
    n_classes = int(flat.max()) + 1
    counts = np.zeros((n, T, n_classes), dtype=np.int64)
    counts[np.arange(n)[:, None], np.arange(T)[None, :], flat] = 1
    counts = counts.cumsum(axis=1)  # votes of every class after grasp t
    own = np.take_along_axis(counts, flat[..., None], axis=2)[..., 0]  # votes of the grasp's class
    hit = own == k_equal  # grasp t gives its class its k-th vote
    decided = hit.any(axis=1)
    first = np.argmax(hit, axis=1)
    decision = flat[np.arange(n), first]
    n_used = first + 1
    if not decided.all():
        und = ~decided
        final = counts[und, -1]  # (n_und, n_classes)
        top = final.max(axis=1)
        # grasp at which each class reached the top count (T if never)
        reached = counts[und] == top[:, None, None]
        when = np.where(reached.any(axis=1), np.argmax(reached, axis=1), T)
        when = np.where(final == top[:, None], when, T + 1)
        decision[und] = np.argmin(when, axis=1)
        n_used[und] = T
    return decision.reshape(lead), n_used.reshape(lead), decided.reshape(lead)


# ----------------------------------------------------------------------------- DAP (paper eqs. 3-6)
#: Probabilities are clipped to ``[DEFAULT_EPS, 1 - DEFAULT_EPS]`` in DAP's log-space product.
DEFAULT_EPS = 1e-6
_TERMS_PER_CHUNK = 4_000_000  # floats of one (rows, classes, attributes) block in dap_log_scores


def check_class_attributes(K, n_attributes: int | None = None, what: str = "class-attribute table") -> np.ndarray:
    """Validate a 0/1 class-attribute table.

    Parameters
    ----------
    K : array-like of shape (n_classes, n_attributes)
        Row ``z`` is the attribute vector ``a^z`` of class ``z``.
    n_attributes : int, optional
        Required column count (the attribute model's).
    what : str
        Name used in error messages.

    Returns
    -------
    ndarray of shape (n_classes, n_attributes), dtype float64 with values 0.0 / 1.0

    Raises
    ------
    DataFileError
        Not 2-D, missing (NaN) or non-binary entries (the message names row and column), or a
        column count different from ``n_attributes``.
    """
    arr = np.asarray(K)
    if arr.ndim != 2:
        raise DataFileError(None, f"{what} must be 2-D (classes x attributes), got shape {arr.shape}")
    try:
        Kf = arr.astype(float)
    except (TypeError, ValueError) as exc:
        raise DataFileError(None, f"{what} holds non-numeric entries") from exc
    nan = np.isnan(Kf)
    if nan.any():
        r, c = np.argwhere(nan)[0]
        raise DataFileError(None, f"{what}: missing value (NaN) at row {r}, column {c}")
    bad = ~np.isin(Kf, (0.0, 1.0))
    if bad.any():
        r, c = np.argwhere(bad)[0]
        raise DataFileError(None, f"{what}: value {arr[r, c].item()!r} at row {r}, column {c} is not 0 or 1")
    if n_attributes is not None and Kf.shape[1] != n_attributes:
        raise DataFileError(
            None, f"{what} has {Kf.shape[1]} attribute columns but the attribute model predicts {n_attributes}"
        )
    return Kf


def check_attribute_posteriors(P, ndim: tuple[int, ...] = (2, 3)) -> np.ndarray:
    """Attribute posteriors ``p(a_m = 1 | x)`` as float64 in [0, 1] (values a rounding error
    outside it are clipped into it).

    Parameters
    ----------
    P : array-like of shape (n_trials, n_attributes) or (n_trials, n_sensors, n_attributes)
    ndim : tuple of int
        Allowed dimensionalities.

    Raises
    ------
    ConfigError
        Wrong dimensionality, or NaN or a value further than rounding outside [0, 1] (naming its
        trial, sensor and attribute and the value in plain numbers).
    """
    P = np.asarray(P, dtype=np.float64)
    if P.ndim not in ndim:
        raise ConfigError(f"attribute posteriors must have {' or '.join(map(str, ndim))} dimensions, got {P.shape}")
    return valid_probabilities(P)


def fuse_attribute_posteriors(P, fusion: str = "avg") -> tuple[np.ndarray, np.ndarray]:
    """Fuse per-sensor attribute posteriors (paper eq. 5 MAXDAP, eq. 6 AVGDAP).

    Parameters
    ----------
    P : array-like of shape (n_trials, n_sensors, n_attributes) or (n_trials, n_attributes)
        ``p(a_m = 1 | x_s)``. A 2-D array is one sensor.
    fusion : {"avg", "max"}
        ``"avg"``: eq. (6). ``"max"``: eq. (5), the maximum of the posterior of each value.

    Returns
    -------
    present : ndarray of shape (n_trials, n_attributes)
        Fused ``p(a_m = 1 | x)``.
    absent : ndarray of shape (n_trials, n_attributes)
        Fused ``p(a_m = 0 | x)`` (``1 - present`` for ``"avg"``; ``1 - min_s p`` for ``"max"``).
    """
    P = check_attribute_posteriors(P)
    if P.ndim == 2:
        P = P[:, None, :]
    if fusion == "avg":
        present = P.mean(axis=1)
        return present, 1.0 - present
    if fusion == "max":
        return P.max(axis=1), 1.0 - P.min(axis=1)
    raise ConfigError(f"fusion must be one of {FUSIONS}, got {fusion!r}")


def attribute_prior(kind, *, train_attributes=None, class_attributes=None, groups=None) -> np.ndarray:
    """Attribute prior ``p(a_m = 1)`` (paper §4.5).

    Parameters
    ----------
    kind : {"uni", "train", "test"} or array-like of shape (n_attributes,)
        ``"uni"``: 0.5. ``"train"``: mean of the training objects' attribute rows (one row per
        object, taken from ``train_attributes`` grouped by ``groups``). ``"test"``: mean of the
        test classes' rows ``class_attributes``. An array is returned as is (after checks).
    train_attributes : array-like of shape (n_trials, n_attributes), optional
    class_attributes : array-like of shape (n_classes, n_attributes), optional
    groups : array-like of shape (n_trials,), optional
        Object of each training trial; ``None`` averages over trials.

    Returns
    -------
    ndarray of shape (n_attributes,)
    """
    if isinstance(kind, str):
        if kind == "test":
            if class_attributes is None:
                raise ConfigError("prior='test' needs the test classes' attribute table")
            return check_class_attributes(class_attributes).mean(axis=0)
        if kind in ("train", "uni"):
            ref = train_attributes if train_attributes is not None else class_attributes
            if ref is None:
                raise ConfigError(f"prior={kind!r} needs the attribute count (training attributes)")
            A = check_class_attributes(ref, what="training attribute rows")
            if kind == "uni":
                return np.full(A.shape[1], 0.5)
            if train_attributes is None:
                raise ConfigError("prior='train' needs the training attribute rows")
            if groups is None:
                return A.mean(axis=0)
            _, inv = np.unique(np.asarray(groups), return_inverse=True)
            per_object = np.zeros((inv.max() + 1, A.shape[1]))
            np.add.at(per_object, inv, A)
            per_object /= np.bincount(inv)[:, None]
            return per_object.mean(axis=0)
        raise ConfigError(f"prior must be one of {PRIORS} or an array, got {kind!r}")
    prior = np.asarray(kind, dtype=float)
    if prior.ndim != 1 or not np.all((prior >= 0) & (prior <= 1)):
        raise ConfigError("an explicit prior must be a 1-D array of probabilities p(a_m = 1)")
    return prior


def dap_attribute_terms(present, absent, K, prior, eps) -> np.ndarray:
    """``T[n, k, m] = log p(a_m = K_km | x_n) - log p(a_m = K_km)``, shape (n, k, m)."""
    lp1 = np.log(np.clip(present, eps, 1.0 - eps))
    lp0 = np.log(np.clip(absent, eps, 1.0 - eps))
    pr = np.clip(prior, eps, 1.0 - eps)
    Kb = K.astype(bool)
    like = np.where(Kb[None], lp1[:, None, :], lp0[:, None, :])
    return like - np.where(Kb, np.log(pr), np.log1p(-pr))[None]


def dap_log_scores(P, K, prior, *, P_absent=None, eps: float = DEFAULT_EPS) -> np.ndarray:
    """Unnormalised DAP log-posteriors, paper eq. (3) in log space.

    ``log p(z | x) = sum_m log p(a_m = K_zm | x) - log p(a_m = K_zm) + const``, with
    ``p(a_m = 0 | ·) = 1 - p(a_m = 1 | ·)`` unless ``P_absent`` is given.

    Parameters
    ----------
    P : array-like of shape (n_trials, n_attributes)
        ``p(a_m = 1 | x)``.
    K : array-like of shape (n_classes, n_attributes)
        0/1 class-attribute table.
    prior : array-like of shape (n_attributes,)
        ``p(a_m = 1)``.
    P_absent : array-like of shape (n_trials, n_attributes), optional
        ``p(a_m = 0 | x)`` when it is not ``1 - P`` (MAXDAP).
    eps : float, default=1e-6
        Probabilities (posteriors and priors) are clipped to ``[eps, 1 - eps]`` so that no single
        attribute gives ``-inf``.

    Returns
    -------
    ndarray of shape (n_trials, n_classes)
        Natural-log scores; argmax gives eq. (4).
    """
    P = check_attribute_posteriors(P, ndim=(2,))
    K = check_class_attributes(K, P.shape[1])
    absent = 1.0 - P if P_absent is None else check_attribute_posteriors(P_absent, ndim=(2,))
    prior = np.broadcast_to(np.asarray(prior, dtype=float), (P.shape[1],))
    # Per-attribute terms summed in the same order for every class, so classes whose scores are
    # mathematically equal (e.g. LDAP's p = 0.5 on the attribute they differ in) get exactly equal
    # floats: ties stay ties instead of being settled by matmul rounding (see break_ties).
    rows = max(1, _TERMS_PER_CHUNK // max(1, K.shape[0] * K.shape[1]))  # bound the (rows, k, m) tensor
    return np.concatenate([
        dap_attribute_terms(P[i : i + rows], absent[i : i + rows], K, prior, eps).sum(axis=2)
        for i in range(0, P.shape[0], rows)
    ]) if P.shape[0] else np.zeros((0, K.shape[0]))
