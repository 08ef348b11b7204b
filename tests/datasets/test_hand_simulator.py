"""The Shadow-hand grasp simulator: determinism and its documented properties."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from tzsl.datasets._grasps import FINGER_NAMES, grasp_arrays, load_hand_table4, read_grasps
from tzsl.datasets._hand_simulator import LOCAL_SHAPE_ATTRIBUTES, simulate_grasps
from tzsl.exceptions import ConfigError

TABLE = load_hand_table4()


@pytest.fixture(scope="module")
def sim():
    return simulate_grasps(TABLE.K, n_grasps_per_object=40, shape_miss_rate=0.3, random_state=7)


def _all_arrays(grasps):
    return [grasp_arrays(g) for g in grasps]


def test_same_seed_identical_different_seed_differs(tmp_path):
    a = simulate_grasps(TABLE.K.iloc[:4], 3, n_rows=30, random_state=3, folder=tmp_path / "a")
    b = simulate_grasps(TABLE.K.iloc[:4], 3, n_rows=30, random_state=3, folder=tmp_path / "b")
    c = simulate_grasps(TABLE.K.iloc[:4], 3, n_rows=30, random_state=4)
    for x, y in zip(_all_arrays(a.grasps), _all_arrays(b.grasps), strict=True):
        for key in x:
            np.testing.assert_array_equal(x[key], y[key])
    pd.testing.assert_frame_equal(a.truth, b.truth)
    assert (tmp_path / "a" / "grasps.csv").read_bytes() == (tmp_path / "b" / "grasps.csv").read_bytes()
    read_a, read_b = read_grasps(tmp_path / "a"), read_grasps(tmp_path / "b")
    for x, y in zip(_all_arrays(read_a), _all_arrays(read_b), strict=True):
        for key in x:
            np.testing.assert_array_equal(x[key], y[key])
    assert not np.array_equal(a.grasps[0].fingers[0].pdc, c.grasps[0].fingers[0].pdc)
    assert not np.array_equal(a.grasps[0].joints, c.grasps[0].joints)


def test_written_folder_reads_back_with_truth(tmp_path):
    out = simulate_grasps(TABLE.K.iloc[[0, 5]], 2, n_rows=25, random_state=0, folder=tmp_path)
    table = pd.read_csv(tmp_path / "grasps.csv", keep_default_na=False)
    assert table["object"].tolist() == ["cardboard box"] * 2 + ["thermal mug"] * 2
    assert "n_contacts" in table.columns and "f0_material" in table.columns
    back = read_grasps(tmp_path)
    assert [g.grasp_id for g in back] == [g.grasp_id for g in out.grasps] == [
        "cardboard_box_000", "cardboard_box_001", "thermal_mug_000", "thermal_mug_001",
    ]  # fmt: skip
    np.testing.assert_allclose(back[3].joints, out.grasps[3].joints)
    assert out.params["simulated"] is True


def test_sizes_and_contact_counts(sim):
    assert len(sim.grasps) == 16 * 40
    n = sim.truth["n_contacts"].to_numpy()
    assert n.min() == 1 and n.max() == 5
    assert set(np.unique(n)) == {1, 2, 3, 4, 5}
    flags = sim.truth[[f"f{i}_contact" for i in range(5)]].to_numpy()
    np.testing.assert_array_equal(flags.sum(axis=1), n)
    g = sim.grasps[0]
    assert len(g.fingers) == len(FINGER_NAMES) and g.joints.shape == (100, 19)


def test_contacts_visible_in_pdc(sim):
    """Touching fingers' PDC rises well above their first rows; the others' does not."""
    pdc = np.stack([[f.pdc for f in g.fingers] for g in sim.grasps])  # (n, 5, R)
    rise = pdc[..., 50:].mean(axis=-1) - pdc[..., :10].mean(axis=-1)
    flags = sim.truth[[f"f{i}_contact" for i in range(5)]].to_numpy()
    assert rise[flags].min() > 30.0
    assert np.abs(rise[~flags]).max() < 10.0


def test_heterogeneous_objects_show_several_materials(sim):
    mats = sim.truth[[f"f{i}_material" for i in range(5)]].to_numpy()
    n_distinct = np.array([len(set(row) - {""}) for row in mats])
    obj = sim.truth["object"].to_numpy()
    multi = sim.truth["n_contacts"].to_numpy() >= 2
    for name in ("jar", "salter", "thermal mug"):
        sel = (obj == name) & multi
        assert (n_distinct[sel] == 2).mean() > 0.4, name
        touched = set(mats[obj == name].ravel()) - {""}
        expected = {a for a in TABLE.material_attributes if TABLE.K.loc[name, a] == 1}
        assert touched == expected
    for name in ("ball", "mug", "glass"):
        assert (n_distinct[obj == name] == 1).all()


def test_materials_differ_in_signals(sim):
    """On the salter, fingers on steel and on glass give different temperature drops."""
    obj = sim.truth["object"].to_numpy()
    drops = {"steel": [], "glass": []}
    for g_index in np.flatnonzero(obj == "salter"):
        g = sim.grasps[g_index]
        for f in range(5):
            m = sim.truth.iloc[g_index][f"f{f}_material"]
            if m:
                drops[m].append(g.fingers[f].tdc[60:].mean() - g.fingers[f].tdc[:10].mean())
    assert abs(np.mean(drops["steel"]) - np.mean(drops["glass"])) > 3 * np.std(drops["glass"]) / np.sqrt(
        len(drops["glass"])
    )


@pytest.mark.parametrize("rate", [0.0, 0.3, 1.0])
def test_shape_miss_rate(rate):
    out = simulate_grasps(TABLE.K, 60, shape_miss_rate=rate, n_rows=25, random_state=1)
    obj = out.truth["object"].to_numpy()
    local = [a for a in LOCAL_SHAPE_ATTRIBUTES]
    has = TABLE.K.loc[obj, local].to_numpy() == 1  # (n, 3): object has the local attribute
    missed = np.array([[a in s.split(";") for a in local] for s in out.truth["missed_shape"]])
    assert not missed[~has].any()
    observed = missed[has].mean()
    assert abs(observed - rate) < 0.05
    # homogeneous objects (no local attribute) never miss anything
    assert (out.truth.loc[np.isin(obj, ["ball", "tube"]), "missed_shape"] == "").all()


def test_missed_attribute_changes_posture():
    """A grasp missing the handle of the mug ends in a different posture than one feeling it."""
    out = simulate_grasps(TABLE.K.loc[["mug"]], 300, noise=0.0, difficulty=0.0, n_rows=25, random_state=2)
    missed = out.truth["missed_shape"].str.contains("has_handle").to_numpy()
    all_touch = out.truth["n_contacts"].to_numpy() == 5
    q = np.stack([g.joints[-1] for g in out.grasps])
    with_handle = q[~missed & all_touch & ~out.truth["missed_shape"].str.contains("concave").to_numpy()]
    without = q[missed & all_touch & ~out.truth["missed_shape"].str.contains("concave").to_numpy()]
    assert len(with_handle) and len(without)
    assert np.abs(with_handle.mean(axis=0) - without.mean(axis=0)).max() > 0.05


def test_parameter_errors():
    with pytest.raises(ConfigError, match="n_grasps_per_object"):
        simulate_grasps(TABLE.K, 0)
    with pytest.raises(ConfigError, match="noise"):
        simulate_grasps(TABLE.K, 2, noise=-1)
    with pytest.raises(ConfigError, match="shape_miss_rate"):
        simulate_grasps(TABLE.K, 2, shape_miss_rate=1.5)
    with pytest.raises(ConfigError, match="not columns of K"):
        simulate_grasps(TABLE.K, 2, material_attributes=["wood"])
    with pytest.raises(ConfigError, match="no material attribute"):
        simulate_grasps(TABLE.K[["cylindrical", "round"]].assign(plastic=0), 2, material_attributes=["plastic"])
    with pytest.raises(ConfigError, match="0/1"):
        simulate_grasps(TABLE.K * 2, 2)
