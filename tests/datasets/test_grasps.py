"""Grasp folder format (read/write/validation) and the shipped Table 4 matrix K."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from tzsl.datasets._grasps import (
    BIOTAC_ARRAYS,
    FINGER_NAMES,
    JOINT_NAMES,
    Grasp,
    grasp_arrays,
    grasp_from_arrays,
    grasp_table,
    load_hand_table4,
    read_grasps,
    write_grasps,
)
from tzsl.exceptions import DataFileError


def _arrays(rng: np.random.Generator, n_rows: int = 12, n_joint_rows: int = 9) -> dict[str, np.ndarray]:
    arrays = {}
    for i in range(len(FINGER_NAMES)):
        for name, tail in BIOTAC_ARRAYS.items():
            arrays[f"f{i}_{name}"] = rng.normal(2000.0, 5.0, (n_rows,) + tail)
    arrays["joints"] = rng.uniform(-0.5, 1.5, (n_joint_rows, len(JOINT_NAMES)))
    return arrays


def _grasps(n: int = 3, seed: int = 0) -> list[Grasp]:
    rng = np.random.default_rng(seed)
    objects = ["mug", "glass bottle", ""]
    return [
        grasp_from_arrays(_arrays(rng, 10 + i), f"g {i}/x", objects[i % 3]) for i in range(n)
    ]


# ---------------------------------------------------------------------- Table 4
def test_table4_shape_split_and_kinds():
    t = load_hand_table4()
    assert t.K.shape == (16, 11)
    assert t.train_objects == [
        "cardboard box", "glass bottle", "plastic bottle", "round container", "mug", "thermal mug",
    ]  # fmt: skip
    assert len(t.test_objects) == 10
    assert t.material_attributes == ("porcelain", "plastic", "cardboard", "glass", "steel")
    assert t.shape_attributes == (
        "cylindrical", "round", "rectangular", "concave", "has_handle", "has_narrow_part",
    )  # fmt: skip
    assert set(t.K.to_numpy().ravel()) == {0, 1}
    assert "Table 4" in t.source or "hand_table4.csv" in t.source


def test_table4_rows_as_printed():
    K = load_hand_table4().K
    assert K.loc["cardboard box"].tolist() == [0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0]
    assert K.loc["salter"].tolist() == [0, 0, 0, 1, 1, 1, 0, 0, 0, 0, 1]
    assert K.loc["measuring cup"].tolist() == [0, 1, 0, 0, 0, 1, 0, 0, 1, 1, 0]
    # the printed column order puts cardboard before glass (the box is cardboard, the bottle glass)
    assert K.loc["cardboard box", "cardboard"] == 1 and K.loc["glass bottle", "glass"] == 1
    assert K.loc["glass", "glass"] == 1 and K.loc["bowl", "porcelain"] == 1


def test_table4_test_vectors_distinct_and_subsets():
    t = load_hand_table4()
    test = t.K.loc[t.test_objects]
    assert not test.duplicated().any()
    counts = t.subset.loc[t.test_objects].value_counts().to_dict()
    assert counts == {"heterogeneous_shape": 5, "homogeneous": 3, "heterogeneous_material": 2}
    assert (t.subset.loc[t.train_objects] == "").all()
    # heterogeneous-material test objects are exactly those with two materials
    n_mat = test[list(t.material_attributes)].sum(axis=1)
    assert set(n_mat.index[n_mat > 1]) == {"jar", "salter"}


def test_table4_custom_file_errors(tmp_path):
    good = (tmp_path / "k.csv")
    good.write_text(
        "# material attributes: a\n# shape attributes: b\nobject,split,subset,a,b\nx,train,,1,0\ny,test,,0,1\n"
    )
    t = load_hand_table4(good)
    assert t.K.loc["y"].tolist() == [0, 1]
    no_kinds = tmp_path / "nokinds.csv"
    no_kinds.write_text("object,split,subset,a\nx,train,,1\n")
    with pytest.raises(DataFileError, match="material attributes"):
        load_hand_table4(no_kinds)
    bad_value = tmp_path / "bad.csv"
    bad_value.write_text("# material attributes: a\n# shape attributes: b\nobject,split,subset,a,b\nx,train,,2,0\n")
    with pytest.raises(DataFileError, match="0 or 1"):
        load_hand_table4(bad_value)
    with pytest.raises(DataFileError, match="cannot read"):
        load_hand_table4(tmp_path / "missing.csv")


# ---------------------------------------------------------------------- round trip
def test_round_trip(tmp_path):
    grasps = _grasps(3)
    table_path = write_grasps(tmp_path, grasps, extra=pd.DataFrame({"note": ["a", "b", "c"]}))
    table = pd.read_csv(table_path, dtype=str, keep_default_na=False)
    assert list(table.columns) == ["grasp_id", "object", "file", "note"]
    assert table["file"].tolist() == ["g_0_x.npz", "g_1_x.npz", "g_2_x.npz"]
    back = read_grasps(tmp_path)
    assert [g.grasp_id for g in back] == [g.grasp_id for g in grasps]
    assert [g.object_name for g in back] == ["mug", "glass bottle", ""]
    for a, b in zip(grasps, back, strict=True):
        assert b.source.endswith(".npz")
        for key, value in grasp_arrays(a).items():
            np.testing.assert_array_equal(grasp_arrays(b)[key], value)
            assert grasp_arrays(b)[key].dtype == np.float64
    subset = read_grasps(tmp_path, grasp_ids=["g 2/x", "g 0/x"])
    assert [g.grasp_id for g in subset] == ["g 2/x", "g 0/x"]
    assert grasp_table(back)["object_name"].tolist() == ["mug", "glass bottle", ""]


def test_float32_and_int_arrays_accepted(tmp_path):
    rng = np.random.default_rng(1)
    arrays = {k: v.astype(np.int16 if k != "joints" else np.float32) for k, v in _arrays(rng).items()}
    write_grasps(tmp_path, [grasp_from_arrays(arrays, "a")], compress=True)
    (back,) = read_grasps(tmp_path)
    np.testing.assert_array_equal(back.fingers[2].pdc, arrays["f2_pdc"].astype(float))


def test_colliding_file_names_rejected(tmp_path):
    rng = np.random.default_rng(2)
    grasps = [grasp_from_arrays(_arrays(rng), gid) for gid in ("a b", "a/b")]
    with pytest.raises(DataFileError, match="same file name"):
        write_grasps(tmp_path, grasps)


# ---------------------------------------------------------------------- bad input
def _write_raw(folder, arrays, grasp_id="bad_1", file="bad_1.npz"):
    folder.mkdir(exist_ok=True)
    np.savez(folder / file, **arrays)
    pd.DataFrame({"grasp_id": [grasp_id], "object": ["mug"], "file": [file]}).to_csv(folder / "grasps.csv", index=False)


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda a: a.pop("f3_pdc"), r"missing array\(s\) \['f3_pdc'\]"),
        (lambda a: a.update(f1_electrodes=a["f1_electrodes"][:, :18]), r"f1_electrodes has shape \(12, 18\)"),
        (lambda a: a.update(f0_pac=a["f0_pac"][:, 0]), r"f0_pac has shape \(12,\)"),
        (lambda a: a.update(f4_tac=a["f4_tac"][:-1]), "finger 4 .* differ in length"),
        (lambda a: a["joints"].__setitem__((3, 4), np.nan), "joints holds NaN"),
        (lambda a: a["f2_tdc"].__setitem__(0, np.inf), "f2_tdc holds NaN or infinite"),
        (lambda a: a.update(joints=a["joints"][:, :18]), r"joints has shape \(9, 18\)"),
        (lambda a: a.update(f0_pdc=np.array(["x"] * 12)), "non-numeric"),
    ],
)
def test_bad_grasp_file(tmp_path, edit, message):
    arrays = _arrays(np.random.default_rng(3))
    edit(arrays)
    _write_raw(tmp_path, arrays)
    with pytest.raises(DataFileError, match=message) as info:
        read_grasps(tmp_path)
    assert info.value.trial == "bad_1"
    assert info.value.path.endswith("bad_1.npz")


def test_missing_files_and_table_errors(tmp_path):
    with pytest.raises(DataFileError, match="grasp table not found"):
        read_grasps(tmp_path)
    _write_raw(tmp_path, _arrays(np.random.default_rng(4)))
    (tmp_path / "bad_1.npz").unlink()
    with pytest.raises(DataFileError, match="grasp file not found") as info:
        read_grasps(tmp_path)
    assert info.value.trial == "bad_1"
    (tmp_path / "bad_1.npz").write_text("not a zip")
    with pytest.raises(DataFileError, match="not a readable .npz archive"):
        read_grasps(tmp_path)
    pd.DataFrame({"grasp_id": ["a"], "file": ["a.npz"]}).to_csv(tmp_path / "grasps.csv", index=False)
    with pytest.raises(DataFileError, match=r"missing column\(s\) \['object'\]"):
        read_grasps(tmp_path)
    pd.DataFrame({"grasp_id": ["a", "a"], "object": ["m", "m"], "file": ["a.npz", "a.npz"]}).to_csv(
        tmp_path / "grasps.csv", index=False
    )
    with pytest.raises(DataFileError, match="duplicate grasp_id"):
        read_grasps(tmp_path)


def test_unknown_grasp_id_and_invalid_write(tmp_path):
    write_grasps(tmp_path, _grasps(1))
    with pytest.raises(DataFileError, match="unknown grasp id"):
        read_grasps(tmp_path, grasp_ids=["nope"])
    g = _grasps(1)[0]
    broken = Grasp(g.grasp_id, g.object_name, "", g.fingers[:4], g.joints)
    with pytest.raises(DataFileError, match="missing array"):
        write_grasps(tmp_path / "out", [broken])
    assert not (tmp_path / "out").exists()
