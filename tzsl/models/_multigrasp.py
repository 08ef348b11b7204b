"""Multi-grasp recognition (DAP paper section 5.7.3) and the attribute distance matrix (eq. 13).

* **DF-MDAP** (data fusion, eqs. 11-12): the T grasps form one "super grasp" whose attribute
  posterior is the mean over grasps of the per-grasp LDAP posteriors,
  shape ``1/T sum_t max(0.5, p(a_m=1|x_sh^(t)))`` and material
  ``1/T sum_t 1/B_t sum_b max(0.5, p(a_m=1|x_b,mat^(t)))``; DAP then classifies the super grasp.
  :func:`df_mdap` takes the per-grasp LDAP posteriors (``HandDAPClassifier(fusion="ldap")
  .predict_attribute_proba``) and returns the super grasp's posteriors; :func:`df_mdap_log_scores`
  adds the DAP step.
* **SC-MDAP** (decision fusion): classify grasp by grasp, from the first, "until k similar
  classifications are made or until x(T) is reached. The classification that reaches k is taken
  as final decision" (:func:`sc_mdap`). When no class reaches ``k`` in the T grasps the paper
  gives no rule; we return the most frequent decision (ties: the class that reached that count
  first) and flag the sequence as undecided.
* **S** (eq. 13): ``S_lm = | a^{z_l}_m - mean_{x in D_test^{z_l}} p(a_m = 1 | x) |``
  (:func:`attribute_distance_matrix`).

Everything is vectorised over many grasp sequences at once.
"""

from __future__ import annotations

from numbers import Integral

import numpy as np
import pandas as pd
from sklearn.utils import check_random_state

from tzsl.exceptions import ConfigError
from tzsl.models._dap import dap_log_scores

__all__ = [
    "attribute_distance_matrix",
    "df_mdap",
    "df_mdap_log_scores",
    "sample_grasp_sequences",
    "sc_mdap",
]


def df_mdap(P_ldap: np.ndarray) -> np.ndarray:
    """Super-grasp attribute posteriors of DF-MDAP (eqs. 11-12).

    Parameters
    ----------
    P_ldap : ndarray of shape (..., T, m)
        Per-grasp LDAP posteriors (eqs. 9-10) of sequences of ``T`` grasps.

    Returns
    -------
    ndarray of shape (..., m)
        The mean over the ``T`` grasps.
    """
    P = np.asarray(P_ldap, dtype=float)
    if P.ndim < 2 or P.shape[-2] < 1:
        raise ConfigError(f"P_ldap must have shape (..., T, m) with T >= 1, got {P.shape}")
    return P.mean(axis=-2)


def df_mdap_log_scores(P_ldap: np.ndarray, K: np.ndarray | pd.DataFrame, prior: float = 0.5) -> np.ndarray:
    """DAP log scores of DF-MDAP super grasps.

    Parameters
    ----------
    P_ldap : ndarray of shape (n_sequences, T, m)
        Per-grasp LDAP posteriors.
    K : array-like of shape (k, m)
        Candidate class-attribute rows (0/1), columns in the order of ``P_ldap``'s last axis.
    prior : float, default=0.5
        Attribute prior ``p(a_m = 1)``.

    Returns
    -------
    ndarray of shape (n_sequences, k)
    """
    P = np.asarray(P_ldap, dtype=float)
    if P.ndim != 3:
        raise ConfigError(f"P_ldap must have shape (n_sequences, T, m), got {P.shape}")
    K = np.asarray(K, dtype=float)
    return dap_log_scores(df_mdap(P), K, np.full(P.shape[-1], float(prior)))


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


def sample_grasp_sequences(
    objects: np.ndarray,
    T: int,
    n_sequences: int,
    random_state: int | np.random.RandomState | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Random ordered sequences of ``T`` distinct grasps of one object, for every object.

    Parameters
    ----------
    objects : array-like of shape (n_grasps,)
        Object of every grasp.
    T : int
        Grasps per sequence; every object needs at least ``T`` grasps.
    n_sequences : int
        Sequences per object.
    random_state : int, RandomState or None

    Returns
    -------
    index : ndarray of int, shape (n_objects * n_sequences, T)
        Grasp indices into ``objects``; each row is a random permutation prefix of one object's grasps.
    sequence_object : ndarray, shape (n_objects * n_sequences,)
        Object of each sequence (objects in order of first appearance).
    """
    objects = np.asarray(objects)
    if not isinstance(T, Integral) or T < 1 or not isinstance(n_sequences, Integral) or n_sequences < 1:
        raise ConfigError(f"T and n_sequences must be positive integers, got {T!r}, {n_sequences!r}")
    rng = check_random_state(random_state)
    index, owner = [], []
    for name in pd.unique(objects):
        members = np.flatnonzero(objects == name)
        if members.size < T:
            raise ConfigError(f"object {str(name)!r} has {members.size} grasps; sequences of T={T} need more")
        order = np.argsort(rng.random_sample((n_sequences, members.size)), axis=1)[:, :T]
        index.append(members[order])
        owner.append(np.full(n_sequences, name, dtype=object))
    return np.concatenate(index), np.concatenate(owner)


def attribute_distance_matrix(P: np.ndarray, objects: np.ndarray, K: pd.DataFrame) -> pd.DataFrame:
    """Distance between attribute labels and mean posteriors per object, eq. (13).

    Parameters
    ----------
    P : ndarray of shape (n_grasps, m)
        ``p(a_m = 1 | x)`` of every test grasp (e.g. fused per-grasp posteriors), columns in the
        order of ``K``'s columns.
    objects : array-like of shape (n_grasps,)
        Object of every grasp; each must be a row of ``K``.
    K : DataFrame of shape (n_objects, m), 0/1

    Returns
    -------
    DataFrame of shape (n_objects_seen, m)
        ``S[l, m] = |K[l, m] - mean of P[:, m] over the grasps of object l|``, rows in ``K`` order
        restricted to objects present in ``objects``; values in [0, 1].
    """
    P = np.asarray(P, dtype=float)
    objects = np.asarray(objects)
    if P.ndim != 2 or P.shape != (objects.shape[0], K.shape[1]):
        raise ConfigError(f"P must have shape ({objects.shape[0]}, {K.shape[1]}), got {P.shape}")
    missing = sorted(set(objects.tolist()) - set(K.index))
    if missing:
        raise ConfigError(f"object(s) {missing} have no row in K")
    mean = pd.DataFrame(P, columns=K.columns).groupby(objects, sort=False).mean()
    rows = [o for o in K.index if o in mean.index]
    S = (K.loc[rows].astype(float) - mean.loc[rows]).abs()
    S.index.name = K.index.name
    return S
