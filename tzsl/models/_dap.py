"""Direct Attribute Prediction (DAP) with sensor fusion, in log space and vectorised.

The functions here are the DAP arithmetic; :class:`tzsl.models.DAPRule` is the decision rule
that applies them inside :class:`tzsl.models.ZeroShotClassifier`.

Equations refer to the DAP paper (``haptic_zsl_dap``):

* (3) ``p(z | x) ∝ prod_m p(a_m = a^z_m | x) / p(a_m = a^z_m)`` (uniform class prior); here as
  ``log p(z | x) = sum_m [log p(a_m = a^z_m | x) - log p(a_m = a^z_m)] + const``.
* (4) ``z(x) = argmax_z p(z | x)``.
* (5) MAXDAP: ``p(a_m = a^z_m | x) = max_b p(a_m = a^z_m | x_b)``. The maximum is taken over the
  posterior *of the value the class asks for*: for a class with ``a^z_m = 1`` it is
  ``max_b p(a_m = 1 | x_b)``, for ``a^z_m = 0`` it is ``max_b p(a_m = 0 | x_b) = 1 - min_b p(a_m = 1 | x_b)``.
  So the fused pair is not normalised, exactly as the paper writes it.
* (6) AVGDAP: ``p(a_m = a^z_m | x) = mean_b p(a_m = a^z_m | x_b)`` (normalised, value-independent).

Fusion is over attribute posteriors across sensors *before* DAP (the paper: "attributes posteriors
p(a|x_b1) and p(a|x_b2) must be combined to infer p(a|x)"), not over class posteriors.

Attribute priors ``p(a_m = 1)`` (§4.5): ``"train"`` = mean over training objects of their attribute
rows, ``"test"`` = mean over the test classes' rows of the class-attribute table, ``"uni"`` = 0.5.
"""

from __future__ import annotations

import numpy as np
from threadpoolctl import threadpool_limits

from tzsl.exceptions import ConfigError, DataFileError
from tzsl._scoring import valid_probabilities

__all__ = [
    "attribute_prior",
    "break_ties",
    "check_attribute_posteriors",
    "check_class_attributes",
    "dap_accuracy_over_subsets",
    "dap_log_scores",
    "fuse_attribute_posteriors",
]

FUSIONS = ("avg", "max")
PRIORS = ("uni", "train", "test")
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


def _per_attribute_terms(present, absent, K, prior, eps) -> np.ndarray:
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
        _per_attribute_terms(P[i : i + rows], absent[i : i + rows], K, prior, eps).sum(axis=2)
        for i in range(0, P.shape[0], rows)
    ]) if P.shape[0] else np.zeros((0, K.shape[0]))


def break_ties(scores, random_state=None) -> np.ndarray:
    """Row-wise argmax with exact ties broken uniformly at random (seeded).

    ``np.argmax`` always returns the first of tied classes, so a class listed early in the
    class table would win every tie. Here each of the tied classes is equally likely, so tied
    evidence is scored at its expected accuracy over many trials.

    Parameters
    ----------
    scores : array-like of shape (n, k)
    random_state : int, Generator or None

    Returns
    -------
    ndarray of shape (n,), int
    """
    scores = np.asarray(scores, dtype=float)
    top = scores == scores.max(axis=1, keepdims=True)
    if (top.sum(axis=1) == 1).all():
        return scores.argmax(axis=1)
    rng = np.random.default_rng(random_state)
    return np.where(top, rng.random(scores.shape) + 1.0, 0.0).argmax(axis=1)


def dap_accuracy_over_subsets(
    P, K, y, subsets, *, fusion: str = "avg", prior="uni", eps: float = DEFAULT_EPS, chunk: int = 256,
    per_trial: bool = False,
) -> np.ndarray:
    """DAP trial accuracy for many attribute subsets at once (paper §4.7, Fig. 4).

    Parameters
    ----------
    P : array-like of shape (n_trials, n_sensors, n_attributes) or (n_trials, n_attributes)
        Attribute posteriors ``p(a_m = 1 | x_s)`` of the test trials.
    K : array-like of shape (n_classes, n_attributes)
        Test classes' attribute table.
    y : array-like of shape (n_trials,)
        True class of each trial as a row index into ``K``.
    subsets : array-like of shape (n_subsets, n_attributes) bool, or (n_subsets, j) int
        Attribute subsets as masks or as column indices.
    fusion : {"avg", "max"}
    prior : {"uni", "test"} or array-like of shape (n_attributes,)
        ``"train"`` needs training rows: pass the array from :func:`attribute_prior`.
    eps : float
    chunk : int
        Subsets scored per numpy pass (bounds memory at ``chunk * n_trials * n_classes`` floats).
    per_trial : bool, default False
        Return every trial's outcome instead of the accuracy (for bootstrap intervals).

    Returns
    -------
    ndarray of shape (n_subsets,), or (n_subsets, n_trials) with ``per_trial``
        Fraction of trials whose argmax class equals ``y`` (with ``per_trial``: 1.0 where the
        trial's argmax class equals ``y``, else 0.0).
    """
    present, absent = fuse_attribute_posteriors(P, fusion)
    m = present.shape[1]
    K = check_class_attributes(K, m)
    y = np.asarray(y)
    if y.shape != (present.shape[0],) or y.min() < 0 or y.max() >= K.shape[0]:
        raise ConfigError(f"y must hold {present.shape[0]} row indices into the {K.shape[0]}-row class table")
    pr = attribute_prior(prior, class_attributes=K) if isinstance(prior, str) else attribute_prior(prior)
    if pr.shape != (m,):
        raise ConfigError(f"prior has {pr.size} entries for {m} attributes")
    subsets = np.asarray(subsets)
    if subsets.dtype == bool:
        if subsets.ndim != 2 or subsets.shape[1] != m:
            raise ConfigError(f"subset masks must have shape (n_subsets, {m}), got {subsets.shape}")
        mask = subsets.astype(float)
    else:
        if subsets.ndim != 2 or subsets.min() < 0 or subsets.max() >= m:
            raise ConfigError(f"subset indices must be (n_subsets, j) with values in [0, {m})")
        mask = np.zeros((subsets.shape[0], m))
        np.put_along_axis(mask, subsets.astype(np.intp), 1.0, axis=1)
    T = _per_attribute_terms(present, absent, K, pr, eps)  # (n, k, m)
    out = np.empty((mask.shape[0], len(y)) if per_trial else mask.shape[0])
    # one BLAS thread: the products are small, and on 2 cores threaded BLAS spent 5 times the CPU (and
    # wall) time of one thread on the PHAC-2 sweep; the outcomes no longer depend on the machine's cores
    with threadpool_limits(limits=1):
        for start in range(0, mask.shape[0], chunk):
            S = np.einsum("nkm,rm->rnk", T, mask[start : start + chunk], optimize=True)
            hits = S.argmax(axis=2) == y[None, :]
            out[start : start + chunk] = hits if per_trial else hits.mean(axis=1)
    return out
