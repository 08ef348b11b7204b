"""Contact detection, BioTac hold-window means (no PAC) and closing-joint angles of grasps."""

from __future__ import annotations

import numpy as np
import pytest

from tzsl.datasets._grasps import (
    BIOTAC_ARRAYS,
    FINGER_NAMES,
    JOINT_NAMES,
    grasp_from_arrays,
    load_hand_table4,
)
from tzsl.datasets._hand_simulator import simulate_grasps
from tzsl.exceptions import ConfigError, DataFileError
from tzsl.features._grasp_features import (
    CLOSING_JOINTS,
    MATERIAL_FEATURES,
    detect_contacts,
    grasp_features,
    pack_grasp_features,
    unpack_grasp_features,
)


def _step_grasp(grasp_id: str, rises: list[float], n_rows: int = 20, pac_level: float = 0.0):
    """Every signal is ``100 * (i+1)`` for the first half and ``+ rise * (k+1)`` in the second half."""
    arrays = {}
    half = n_rows // 2
    for i, rise in enumerate(rises):
        for name, tail in BIOTAC_ARRAYS.items():
            width = int(np.prod(tail)) if tail else 1
            base = 100.0 * (i + 1) + np.arange(width)
            block = np.tile(base, (n_rows, 1))
            block[half:] += rise * (1 + np.arange(width))
            arrays[f"f{i}_{name}"] = block.reshape((n_rows,) + tail)
        arrays[f"f{i}_pac"] = np.full((n_rows, 22), pac_level)
    joints = np.tile(np.linspace(0, 1, len(JOINT_NAMES)), (n_rows + 3, 1))
    joints[-5:] += 0.5
    arrays["joints"] = joints
    return grasp_from_arrays(arrays, grasp_id, "mug")


def test_closing_joints_are_ten_flexions_without_wrist():
    assert len(CLOSING_JOINTS) == 10 and set(CLOSING_JOINTS) <= set(JOINT_NAMES)
    assert not any(j.startswith("WR") or j.endswith("J4") for j in CLOSING_JOINTS)
    assert MATERIAL_FEATURES[:3] == ("pdc", "tac", "tdc") and len(MATERIAL_FEATURES) == 22
    assert "pac" not in MATERIAL_FEATURES


def test_detect_contacts_hand_made():
    # 2 grasps x 3 fingers x 10 rows; baseline = first 2 rows, hold = last half
    pdc = np.full((2, 3, 10), 2000.0)
    pdc[0, 0, 5:] += 30.0  # clear rise -> contact
    pdc[0, 1, 5:] += 10.0  # below the 20-count threshold
    pdc[0, 2] = 3500.0  # high but flat sensor: no rise, no contact
    pdc[1, 0, :2] -= 25.0  # baseline below the rest: a rise of 25 -> contact
    pdc[1, 1, 2:5] += 500.0  # transient bump before the hold window only
    got = detect_contacts(pdc, contact_threshold=20.0, baseline_rows=2)
    np.testing.assert_array_equal(got, [[True, False, False], [True, False, False]])
    # a higher threshold removes the 25- and 30-count rises
    assert not detect_contacts(pdc, contact_threshold=40.0, baseline_rows=2).any()


def test_detect_contacts_variable_lengths():
    pdc = np.full((1, 2, 12), np.nan)
    pdc[0, 0, :8] = [0, 0, 0, 0, 0, 0, 50, 50]  # 8 rows: hold = rows 4..7, mean 25
    pdc[0, 1, :12] = 0.0
    pdc[0, 1, 10:] = 100.0  # hold = rows 6..11, mean 33.3
    lengths = np.array([[8, 12]])
    np.testing.assert_array_equal(detect_contacts(pdc, lengths, baseline_rows=2), [[True, True]])
    np.testing.assert_array_equal(
        detect_contacts(pdc, lengths, baseline_rows=2, contact_threshold=30.0), [[False, True]]
    )
    with pytest.raises(ValueError, match="lengths"):
        detect_contacts(pdc, np.array([[2, 12]]), baseline_rows=2)


def test_material_and_shape_features_values():
    rises = [30.0, 0.0, 5.0, 100.0, 21.0]
    g = _step_grasp("g1", rises)
    fe = grasp_features([g], baseline_rows=3)
    assert fe.material.shape == (1, 5, 22)
    # hold window = last half = exactly the raised rows; baseline = first rows
    for i, rise in enumerate(rises):
        expected = np.concatenate([[rise], [rise], [rise], rise * (1 + np.arange(19))])  # pdc, tac, tdc, e01..e19
        np.testing.assert_allclose(fe.material[0, i], expected)
    np.testing.assert_array_equal(fe.contact[0], [True, False, False, True, True])
    cols = [JOINT_NAMES.index(j) for j in CLOSING_JOINTS]
    np.testing.assert_allclose(fe.shape[0], np.linspace(0, 1, 19)[cols] + 0.5)
    assert fe.grasp_ids.tolist() == ["g1"] and fe.objects.tolist() == ["mug"]


def test_pac_is_ignored():
    a = grasp_features([_step_grasp("a", [30.0] * 5, pac_level=0.0)])
    b = grasp_features([_step_grasp("a", [30.0] * 5, pac_level=900.0)])
    np.testing.assert_array_equal(a.material, b.material)


def test_grasps_of_different_lengths():
    g_short = _step_grasp("s", [40.0] * 5, n_rows=20)
    g_long = _step_grasp("l", [40.0] * 5, n_rows=40)
    fe = grasp_features([g_short, g_long])
    np.testing.assert_allclose(fe.material[0], fe.material[1])
    alone = grasp_features([g_long])
    np.testing.assert_allclose(fe.material[1], alone.material[0])


def test_pack_unpack_round_trip_and_errors():
    rng = np.random.default_rng(0)
    mat, contact, shape = rng.normal(size=(4, 5, 22)), rng.random((4, 5)) < 0.5, rng.normal(size=(4, 10))
    X = pack_grasp_features(mat, contact, shape)
    assert X.shape == (4, 5 * 22 + 5 + 10)
    m2, c2, s2 = unpack_grasp_features(X)
    np.testing.assert_array_equal(m2, mat)
    np.testing.assert_array_equal(c2, contact)
    np.testing.assert_array_equal(s2, shape)
    X[0, 110] = 0.5
    with pytest.raises(ValueError, match="contact columns"):
        unpack_grasp_features(X)
    with pytest.raises(ValueError, match="packed grasp features"):
        unpack_grasp_features(X[:, :112])


def test_too_short_grasp_and_bad_settings():
    g = _step_grasp("tiny", [30.0] * 5, n_rows=6)
    with pytest.raises(DataFileError, match="6 rows") as info:
        grasp_features([g], baseline_rows=10)
    assert info.value.trial == "tiny"
    with pytest.raises(ConfigError, match="unknown joint"):
        grasp_features([_step_grasp("x", [1.0] * 5)], closing_joints=["WRJ9"])
    with pytest.raises(ConfigError, match="hold_fraction"):
        grasp_features([_step_grasp("x", [1.0] * 5)], hold_fraction=0.0)
    with pytest.raises(ConfigError, match="no grasps"):
        grasp_features([])


def test_simulated_contacts_are_detected():
    sim = simulate_grasps(load_hand_table4().K, 10, random_state=5)
    fe = grasp_features(sim.grasps)
    truth = sim.truth[[f"f{i}_contact" for i in range(len(FINGER_NAMES))]].to_numpy()
    np.testing.assert_array_equal(fe.contact, truth)
    sub = fe.subset(fe.objects == "salter")
    assert len(sub) == 10 and (sub.objects == "salter").all()
    np.testing.assert_array_equal(sub.n_contacts, truth[sim.truth["object"] == "salter"].sum(axis=1))
