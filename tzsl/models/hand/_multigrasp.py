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

from tzsl._scoring import sc_mdap
from tzsl.exceptions import ConfigError
from tzsl.models.rules import DAPRule

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
    # DAP through its rule; with an explicit prior, fitting reads only the attribute count
    return DAPRule(prior=np.full(P.shape[-1], float(prior))).fit(K).decision_function(df_mdap(P), K)


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
