"""Raw HOLD-phase MAT files and the PHAC-2 label matrix."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
import scipy.io

from tzsl.datasets import (
    PHAC2_EPS,
    load_phac2_hold_mat,
    load_phac2_labels,
    load_phac2_penn,
    read_hold_mat,
    read_phac2_labels_csv,
)
from tzsl.exceptions import DataFileError

HOLD = "phac2/imperial_cvpr2021_hold"
ONE = "car_sponge_101_01_HOLD.mat"


def _synthetic_mat(n=120, seed=0):
    rng = np.random.default_rng(seed)
    mat = {}
    for f in (0, 1):
        mat[f"F{f}Electrodes"] = rng.integers(0, 4000, size=(19, n)).astype(np.uint16)
        mat[f"F{f}pac"] = rng.integers(0, 4000, size=(22, n)).astype(np.uint16)
        for s in ("pdc", "tac", "tdc"):
            mat[f"F{f}{s}"] = rng.integers(0, 4000, size=(1, n)).astype(np.uint16)
    for s in ("JPos", "JVel", "JEff"):
        mat[s] = rng.normal(size=(1, n))
    return mat


def _save(tmp_path, mat, name="rock_202_03_HOLD.mat"):
    path = tmp_path / name
    scipy.io.savemat(path, mat)
    return path


def test_synthetic_mat_is_read(tmp_path):
    mat = _synthetic_mat()
    trial = read_hold_mat(_save(tmp_path, mat))
    assert (trial.trial_id, trial.object_name, trial.object_id, trial.trial_index) == (
        "rock_202_03", "rock_202", 202, 3,
    )
    assert trial.n_rows == 120 and len(trial.fingers) == 2
    f1 = trial.fingers[1]
    np.testing.assert_array_equal(f1.electrodes, mat["F1Electrodes"].T)
    np.testing.assert_array_equal(f1.pac, mat["F1pac"].T)
    np.testing.assert_array_equal(f1.tdc, mat["F1tdc"][0])
    assert f1.pdc.dtype == np.float64  # no uint16 wrap-around downstream
    np.testing.assert_array_equal(trial.gripper_aperture, mat["JPos"][0])
    assert set(trial.phase) == {PHAC2_EPS["hold"]} and trial.tool_z is None


def test_truncated_mat(tmp_path):
    good = _save(tmp_path, _synthetic_mat())
    data = good.read_bytes()
    bad = tmp_path / "rock_202_04_HOLD.mat"
    bad.write_bytes(data[: len(data) // 2])
    with pytest.raises(DataFileError, match="rock_202_04_HOLD.mat"):
        read_hold_mat(bad)


def test_garbage_mat(tmp_path):
    bad = tmp_path / "rock_202_05_HOLD.mat"
    bad.write_bytes(b"this is not a MATLAB file" * 10)
    with pytest.raises(DataFileError, match="cannot read MAT file"):
        read_hold_mat(bad)


@pytest.mark.parametrize("var", ["F1pac", "F0tdc", "JPos"])
def test_missing_variable(tmp_path, var):
    mat = _synthetic_mat()
    del mat[var]
    with pytest.raises(DataFileError, match=f"no variable '{var}'") as err:
        read_hold_mat(_save(tmp_path, mat))
    assert "rock_202_03_HOLD.mat" in str(err.value)


def test_wrong_shape(tmp_path):
    mat = _synthetic_mat()
    mat["F0Electrodes"] = mat["F0Electrodes"][:18]
    with pytest.raises(DataFileError, match=r"'F0Electrodes' has shape \(18, 120\); expected \(19, T\)"):
        read_hold_mat(_save(tmp_path, mat))


def test_inconsistent_lengths(tmp_path):
    mat = _synthetic_mat()
    mat["F1tac"] = mat["F1tac"][:, :-1]
    with pytest.raises(DataFileError, match="different lengths"):
        read_hold_mat(_save(tmp_path, mat))


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_nan_in_mat(tmp_path, bad):
    mat = _synthetic_mat()
    mat["JPos"][0, 17] = bad
    with pytest.raises(DataFileError, match="'JPos' holds NaN/inf") as err:
        read_hold_mat(_save(tmp_path, mat))
    assert "rock_202_03" in str(err.value)


def test_bad_file_name(tmp_path):
    with pytest.raises(DataFileError, match="<object>_<id3>_<trial2>"):
        read_hold_mat(_save(tmp_path, _synthetic_mat(), name="rock_HOLD.mat"))


def test_explicit_files_are_sorted_and_unique(tmp_path):
    a = _save(tmp_path, _synthetic_mat(), name="rock_202_02_HOLD.mat")
    b = _save(tmp_path, _synthetic_mat(), name="felt_101_01_HOLD.mat")
    trials = load_phac2_hold_mat(files=[a, b])
    assert [t.trial_id for t in trials] == ["felt_101_01", "rock_202_02"]
    (tmp_path / "x").mkdir()
    c = _save(tmp_path / "x", _synthetic_mat(), name="rock_202_02_HOLD.mat")
    with pytest.raises(DataFileError, match="also read from"):
        load_phac2_hold_mat(files=[a, c])


# ---------------------------------------------------------------- labels CSV
def _csv(tmp_path, text):
    path = tmp_path / "labels.csv"
    path.write_text(text)
    return path


def test_labels_csv_validation(tmp_path):
    ok = read_phac2_labels_csv(_csv(tmp_path, "object_id,object_name,soft,hard\n202,rock,0,1\n101,sponge,1,0\n"))
    assert list(ok.index) == ["sponge_101", "rock_202"] and list(ok.columns) == ["hard", "soft"]
    with pytest.raises(DataFileError, match="expected 0 or 1"):
        read_phac2_labels_csv(_csv(tmp_path, "object_id,object_name,soft\n1,a,2\n"))
    with pytest.raises(DataFileError, match="expected 0 or 1"):
        read_phac2_labels_csv(_csv(tmp_path, "object_id,object_name,soft\n1,a,\n"))
    with pytest.raises(DataFileError, match="duplicate object_id 1"):
        read_phac2_labels_csv(_csv(tmp_path, "object_id,object_name,soft\n1,a,0\n1,b,1\n"))
    with pytest.raises(DataFileError, match="no 'object_id' column"):
        read_phac2_labels_csv(_csv(tmp_path, "object_name,soft\na,0\n"))


# ---------------------------------------------------------------- the real data
@pytest.mark.realdata
def test_real_labels(data_dir):
    labels = load_phac2_labels(data_dir)
    assert labels.shape == (60, 24) and labels.index.is_unique
    assert set(np.unique(labels.to_numpy())) == {0, 1}
    # PHAC-2 has two car sponges: the id keeps them apart
    assert {"car_sponge_101", "car_sponge_109"} <= set(labels.index)


@pytest.mark.realdata
def test_real_hold_trials(data_dir):
    trials = load_phac2_hold_mat(data_dir)
    assert len(trials) == 60
    assert len({t.object_name for t in trials}) == 6
    rows = {t.trial_id: t.n_rows for t in trials}
    assert set(rows.values()) == {1000, 1001}
    assert [k for k, v in rows.items() if v == 1001] == ["black_foam_110_08"]
    for t in trials:
        for f in t.fingers:
            assert f.electrodes.shape == (t.n_rows, 19) and f.pac.shape == (t.n_rows, 22)
            assert f.pdc.shape == f.tac.shape == f.tdc.shape == (t.n_rows,)
    # labels for every raw trial's object
    labels = load_phac2_labels(data_dir)
    assert labels.loc[[t.object_name for t in trials]].shape == (60, 24)


@pytest.mark.realdata
def test_hold_gripper_matches_penn_features(data_dir):
    """Two independent sources of the same trials: min/mean aperture agree to 1e-9."""
    penn = load_phac2_penn(data_dir)
    hold = penn.eps.index("hold")
    row = {t: i for i, t in enumerate(penn.trials["trial_id"])}
    trials = load_phac2_hold_mat(data_dir)
    idx = [row[t.trial_id] for t in trials]
    got = np.array([[t.gripper_aperture.min(), t.gripper_aperture.mean()] for t in trials])
    expected = penn.X[idx, hold][:, [20, 21]]
    assert penn.feature_names[20:22] == ("gripper_min", "gripper_mean")
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-9)
    # and the check has teeth: another EP's gripper features do not match
    assert not np.allclose(got, penn.X[idx, penn.eps.index("squeeze")][:, [20, 21]], atol=1e-9)


@pytest.mark.realdata
def test_real_truncated_copy(data_dir, tmp_path):
    data = (data_dir / HOLD / ONE).read_bytes()
    bad = tmp_path / ONE
    bad.write_bytes(data[:20000])
    with pytest.raises(DataFileError, match=ONE):
        load_phac2_hold_mat(files=[bad])


def test_labels_frame_type(tmp_path):
    df = read_phac2_labels_csv(_csv(tmp_path, "object_id,object_name,a\n5,x,1\n"))
    assert isinstance(df, pd.DataFrame) and df.dtypes.iloc[0] == np.int64
