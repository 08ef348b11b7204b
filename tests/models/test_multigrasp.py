"""Multi-grasp fusion: DF-MDAP (eqs. 11-12), SC-MDAP, grasp sequences and the distance matrix S (eq. 13)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from tzsl.exceptions import ConfigError
from tzsl.models._dap import dap_log_scores
from tzsl.models.hand._hand_dap import fuse_grasp_posteriors
from tzsl.models.hand._multigrasp import (
    attribute_distance_matrix,
    df_mdap,
    df_mdap_log_scores,
    sample_grasp_sequences,
    sc_mdap,
)


def test_df_mdap_eqs11_12_by_hand():
    # T = 2 grasps, 3 BioTacs, 1 material + 1 shape attribute.
    # grasp 1: BioTacs 0, 1 touch with p = 0.2, 0.8 ; shape p = 0.9
    # grasp 2: BioTac 2 touches with p = 0.7       ; shape p = 0.1
    P_mat = np.array([[[0.2], [0.8], [0.0]], [[0.0], [0.0], [0.7]]])
    contact = np.array([[True, True, False], [False, False, True]])
    P_sh = np.array([[0.9], [0.1]])
    per_grasp = fuse_grasp_posteriors(P_mat, contact, P_sh, "ldap")
    # eq. 12: 1/2 * [ (max(.5,.2) + max(.5,.8)) / 2  +  max(.5,.7) / 1 ] = 1/2 * (0.65 + 0.7) = 0.675
    # eq. 11: 1/2 * [ max(.5,.9) + max(.5,.1) ] = 1/2 * (0.9 + 0.5) = 0.7
    np.testing.assert_allclose(df_mdap(per_grasp), [0.675, 0.7])
    # vectorised over sequences: (n_seq, T, m)
    np.testing.assert_allclose(df_mdap(np.stack([per_grasp, per_grasp[::-1]])), [[0.675, 0.7]] * 2)


def test_df_mdap_log_scores_by_hand():
    P = np.array([[[0.5, 0.9], [0.7, 0.5], [0.6, 0.5]]])  # 1 sequence of T = 3 grasps
    K = np.array([[1, 1], [0, 1], [1, 0]])
    scores = df_mdap_log_scores(P, K)
    fused = np.array([[0.6, 1.9 / 3]])
    np.testing.assert_allclose(scores, dap_log_scores(fused, K, np.full(2, 0.5)))
    # by hand: class 0: .6 * .6333, class 1: .4 * .6333, class 2: .6 * .3667 -> class 0
    assert scores.argmax() == 0
    np.testing.assert_allclose(scores[0, 0] - scores[0, 2], np.log((1.9 / 3) / (1.1 / 3)))
    with pytest.raises(ConfigError):
        df_mdap_log_scores(P[0], K)


def test_sc_mdap_by_hand():
    d = np.array([2, 0, 2, 1, 0, 0])
    assert [int(v) for v in sc_mdap(d, 1)] == [2, 1, True]  # first grasp
    assert [int(v) for v in sc_mdap(d, 2)] == [2, 3, True]  # class 2 twice at grasp 3
    assert [int(v) for v in sc_mdap(d, 3)] == [0, 6, True]  # class 0 a third time at grasp 6
    # k = 4 never reached: most frequent (0, three votes), all 6 grasps used, undecided
    assert [int(v) for v in sc_mdap(d, 4)] == [0, 6, False]
    # tie between 1 and 0 (two votes each): 0 reached two votes first (grasp 3 vs 4)
    assert [int(v) for v in sc_mdap(np.array([1, 0, 0, 1]), 3)] == [0, 4, False]


def _sc_reference(row: np.ndarray, k: int) -> tuple[int, int, bool]:
    counts: dict[int, int] = {}
    for t, c in enumerate(row):
        counts[c] = counts.get(c, 0) + 1
        if counts[c] == k:
            return int(c), t + 1, True
    top = max(counts.values())
    first = {}
    running: dict[int, int] = {}
    for t, c in enumerate(row):
        running[c] = running.get(c, 0) + 1
        if running[c] == top and c not in first:
            first[c] = t
    return min(first, key=first.get), len(row), False


@pytest.mark.parametrize("k", [1, 2, 3, 5])
def test_sc_mdap_vectorised_matches_loop(k):
    rng = np.random.default_rng(k)
    d = rng.integers(0, 4, size=(3, 50, 9))
    dec, used, ok = sc_mdap(d, k)
    assert dec.shape == used.shape == ok.shape == (3, 50)
    for idx in np.ndindex(3, 50):
        assert (int(dec[idx]), int(used[idx]), bool(ok[idx])) == _sc_reference(d[idx], k)


def test_sc_mdap_errors():
    with pytest.raises(ConfigError, match="k_equal"):
        sc_mdap(np.array([0, 1]), 0)
    with pytest.raises(ConfigError, match="non-negative integer"):
        sc_mdap(np.array([0.5, 1.0]), 1)


def test_sample_grasp_sequences():
    objects = np.array(["a"] * 5 + ["b"] * 4 + ["a"])
    idx, owner = sample_grasp_sequences(objects, 3, 20, random_state=0)
    assert idx.shape == (40, 3) and owner.tolist() == ["a"] * 20 + ["b"] * 20
    assert all(len(set(row)) == 3 for row in idx)
    assert (objects[idx] == owner[:, None]).all()
    again, _ = sample_grasp_sequences(objects, 3, 20, random_state=0)
    np.testing.assert_array_equal(idx, again)
    with pytest.raises(ConfigError, match="'b' has 4 grasps"):
        sample_grasp_sequences(objects, 5, 2)


def test_attribute_distance_matrix_eq13_by_hand():
    K = pd.DataFrame({"hard": [1, 0, 1], "round": [0, 1, 1]}, index=["x", "y", "unused"])
    P = np.array([[0.9, 0.2], [0.7, 0.4], [0.1, 0.6]])
    objects = np.array(["x", "x", "y"])
    S = attribute_distance_matrix(P, objects, K)
    # x: |1 - (0.9+0.7)/2| = 0.2, |0 - (0.2+0.4)/2| = 0.3 ; y: |0 - 0.1| = 0.1, |1 - 0.6| = 0.4
    assert S.index.tolist() == ["x", "y"]
    np.testing.assert_allclose(S.to_numpy(), [[0.2, 0.3], [0.1, 0.4]])
    with pytest.raises(ConfigError, match="no row in K"):
        attribute_distance_matrix(P, np.array(["x", "x", "z"]), K)
