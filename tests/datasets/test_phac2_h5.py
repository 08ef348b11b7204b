"""Raw PHAC-2 HDF5 in the release layout: round trip and every bad-input case."""

from __future__ import annotations

import h5py
import numpy as np
import pytest

from tzsl.datasets import (
    PHAC2_EPS,
    BiotacSignals,
    RawTrial,
    iter_phac2_h5,
    list_phac2_h5_trials,
    load_phac2_h5,
    require_eps,
    write_phac2_h5,
)
from tzsl.exceptions import DataFileError

SEGMENTS = ["MOVE_ARM_START_POSITION", *PHAC2_EPS.values(), "OPEN_GRIPPER_BY_2CM"]


def make_trial(trial_id="car_sponge_101_01", rows_per_state=40, states=SEGMENTS, seed=0):
    rng = np.random.default_rng(seed)
    n = rows_per_state * len(states)
    fingers = tuple(
        BiotacSignals(
            pdc=rng.integers(1800, 2200, n).astype(np.int64),
            pac=rng.integers(1900, 2100, (n, 22)).astype(np.int64),
            tac=rng.integers(1900, 2100, n).astype(np.int64),
            tdc=rng.integers(2000, 2600, n).astype(np.int64),
            electrodes=rng.integers(2800, 3400, (n, 19)).astype(np.int64),
        )
        for _ in range(2)
    )
    name, oid, idx = trial_id.rsplit("_", 2)
    return RawTrial(
        trial_id=trial_id,
        object_id=int(oid),
        object_name=f"{name}_{oid}",
        trial_index=int(idx),
        source="memory",
        fingers=fingers,
        gripper_aperture=np.linspace(0.08, 0.02, n),
        phase=np.repeat(np.array(states), rows_per_state),
        tool_z=np.linspace(0.9, 0.85, n),
        adjectives=("compressible", "soft"),
    )


@pytest.fixture
def h5file(tmp_path):
    trials = [make_trial("car_sponge_101_01", seed=1), make_trial("rock_202_02", rows_per_state=25, seed=2)]
    path = write_phac2_h5(tmp_path / "phac.h5", trials)
    return path, trials


def test_round_trip(h5file):
    path, trials = h5file
    back = load_phac2_h5(path, eps=PHAC2_EPS)
    assert [t.trial_id for t in back] == [t.trial_id for t in trials]
    for a, b in zip(trials, back, strict=True):
        assert (b.object_name, b.object_id, b.trial_index) == (a.object_name, a.object_id, a.trial_index)
        assert b.source == str(path)
        for fa, fb in zip(a.fingers, b.fingers, strict=True):
            for sig in ("pdc", "pac", "tac", "tdc", "electrodes"):
                np.testing.assert_array_equal(getattr(fb, sig), getattr(fa, sig))
                assert getattr(fb, sig).dtype == np.float64
        np.testing.assert_array_equal(b.gripper_aperture, a.gripper_aperture)
        np.testing.assert_array_equal(b.phase, a.phase)
        np.testing.assert_array_equal(b.tool_z, a.tool_z)
        assert b.adjectives == a.adjectives
        for ep in PHAC2_EPS:  # segmentation by controller_detail_state
            assert b.ep_mask(ep).sum() == (40 if b.object_id == 101 else 25)


def test_iterator_yields_the_same_trials(h5file):
    path, trials = h5file
    it = iter_phac2_h5(path, trials=["rock_202_02", "car_sponge_101_01"])
    first = next(it)
    assert first.trial_id == "rock_202_02" and first.n_rows == 150
    assert [t.trial_id for t in it] == ["car_sponge_101_01"]


def test_layout_is_the_release_layout(h5file):
    path, _ = h5file
    with h5py.File(path, "r") as fh:
        g = fh["car_sponge_101_01"]
        assert g["biotacs/finger_1/electrodes"].shape == (240, 19)
        assert g["biotacs/finger_0/pac"].shape == (240, 22)
        assert g["state/controller_detail_state"].dtype == np.dtype("S30")
        assert g["transforms/translation"].shape == (240, 3)
        assert g["gripper_aperture/joint_position"].shape == (240,)


def test_select_trials_and_skip_non_trial_groups(h5file):
    path, _ = h5file
    with h5py.File(path, "a") as fh:
        fh.create_group("adjectives/soft").create_dataset("car_sponge_101_01", data=1)
        fh.create_group("adjectives_neg")
        fh.create_group("train_test_0").create_dataset("train", data=np.array([b"x"]))
    assert list_phac2_h5_trials(path) == ["car_sponge_101_01", "rock_202_02"]
    only = load_phac2_h5(path, trials=["rock_202_02"])
    assert [t.trial_id for t in only] == ["rock_202_02"]
    with pytest.raises(DataFileError, match="trial not in file"):
        load_phac2_h5(path, trials=["felt_303_01"])


def test_unknown_top_level_group(h5file):
    path, _ = h5file
    with h5py.File(path, "a") as fh:
        fh.create_group("something_else")
    with pytest.raises(DataFileError, match="'something_else' is not a trial group"):
        load_phac2_h5(path)


def test_optional_fields_may_be_absent(h5file):
    path, _ = h5file
    with h5py.File(path, "a") as fh:
        del fh["car_sponge_101_01/transforms"]
        del fh["car_sponge_101_01/adjectives"]
    t = load_phac2_h5(path, trials=["car_sponge_101_01"])[0]
    assert t.tool_z is None and t.adjectives is None


def test_variable_length_string_states(tmp_path):
    trial = make_trial()
    path = write_phac2_h5(tmp_path / "v.h5", [trial])
    with h5py.File(path, "a") as fh:
        del fh["car_sponge_101_01/state/controller_detail_state"]
        fh["car_sponge_101_01/state"].create_dataset(
            "controller_detail_state", data=trial.phase.astype(object), dtype=h5py.string_dtype()
        )
    np.testing.assert_array_equal(load_phac2_h5(path)[0].phase, trial.phase)


def test_not_hdf5(tmp_path):
    path = tmp_path / "fake.h5"
    path.write_text("not an hdf5 file")
    with pytest.raises(DataFileError, match="not a readable HDF5 file") as err:
        load_phac2_h5(path)
    assert "fake.h5" in str(err.value)


def test_missing_file(tmp_path):
    with pytest.raises(DataFileError, match="file not found"):
        load_phac2_h5(tmp_path / "none.h5")


def test_truncated_file(h5file, tmp_path):
    path, _ = h5file
    data = path.read_bytes()
    cut = tmp_path / "cut.h5"
    cut.write_bytes(data[: len(data) // 2])
    with pytest.raises(DataFileError) as err:
        load_phac2_h5(cut)
    assert "cut.h5" in str(err.value)


def test_missing_finger(h5file):
    path, _ = h5file
    with h5py.File(path, "a") as fh:
        del fh["rock_202_02/biotacs/finger_1"]
    with pytest.raises(DataFileError) as err:
        load_phac2_h5(path)
    msg = str(err.value)
    assert "phac.h5" in msg and "trial rock_202_02" in msg and "missing group rock_202_02/biotacs/finger_1" in msg


@pytest.mark.parametrize("signal", ["pac", "tdc", "electrodes"])
def test_missing_signal(h5file, signal):
    path, _ = h5file
    with h5py.File(path, "a") as fh:
        del fh[f"car_sponge_101_01/biotacs/finger_0/{signal}"]
    with pytest.raises(DataFileError, match=f"missing dataset car_sponge_101_01/biotacs/finger_0/{signal}"):
        load_phac2_h5(path)


@pytest.mark.parametrize("rel", ["gripper_aperture/joint_position", "state/controller_detail_state"])
def test_missing_gripper_or_state(h5file, rel):
    path, _ = h5file
    with h5py.File(path, "a") as fh:
        del fh[f"rock_202_02/{rel}"]
    with pytest.raises(DataFileError, match=f"rock_202_02/{rel}"):
        load_phac2_h5(path)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_nan_or_inf(h5file, bad):
    path, _ = h5file
    with h5py.File(path, "a") as fh:
        g = fh["rock_202_02/biotacs/finger_1"]
        pdc = g["pdc"][()].astype(float)
        pdc[33] = bad
        del g["pdc"]
        g.create_dataset("pdc", data=pdc)
    with pytest.raises(DataFileError, match=r"biotacs/finger_1/pdc holds NaN/inf \(first at row 33\)") as err:
        load_phac2_h5(path)
    assert "trial rock_202_02" in str(err.value)


def test_nan_in_tool_height(h5file):
    path, _ = h5file
    with h5py.File(path, "a") as fh:
        fh["car_sponge_101_01/transforms/translation"][5, 2] = np.nan
    with pytest.raises(DataFileError, match="transforms/translation holds NaN/inf"):
        load_phac2_h5(path)


def test_absent_ep(tmp_path):
    states = [s for s in SEGMENTS if s != PHAC2_EPS["slow_slide"]]
    path = write_phac2_h5(tmp_path / "noslide.h5", [make_trial("felt_303_04", states=states)])
    (trial,) = load_phac2_h5(path)  # reading alone is fine
    with pytest.raises(DataFileError) as err:
        require_eps(trial, PHAC2_EPS)
    msg = str(err.value)
    assert "noslide.h5" in msg and "felt_303_04" in msg and "slow_slide" in msg and "SLIDE_5CM" in msg
    require_eps(trial, ["squeeze", "hold", "fast_slide"])
    with pytest.raises(DataFileError, match="'slow_slide'"):
        load_phac2_h5(path, eps=PHAC2_EPS)


def test_inconsistent_lengths(h5file):
    path, _ = h5file
    with h5py.File(path, "a") as fh:
        g = fh["car_sponge_101_01/biotacs/finger_0"]
        tac = g["tac"][()][:-3]
        del g["tac"]
        g.create_dataset("tac", data=tac)
    with pytest.raises(DataFileError, match="inconsistent lengths") as err:
        load_phac2_h5(path)
    assert "biotacs/finger_0/tac: 237" in str(err.value) and "car_sponge_101_01" in str(err.value)


def test_wrong_signal_shape(h5file):
    path, _ = h5file
    with h5py.File(path, "a") as fh:
        g = fh["car_sponge_101_01/biotacs/finger_1"]
        el = g["electrodes"][()][:, :18]
        del g["electrodes"]
        g.create_dataset("electrodes", data=el)
    with pytest.raises(DataFileError, match=r"electrodes has shape \(240, 18\); expected \(N, 19\)"):
        load_phac2_h5(path)


def test_signal_stored_as_group(h5file):
    path, _ = h5file
    with h5py.File(path, "a") as fh:
        del fh["car_sponge_101_01/biotacs/finger_0/pdc"]
        fh.create_group("car_sponge_101_01/biotacs/finger_0/pdc")
    with pytest.raises(DataFileError, match="is a group, expected a dataset"):
        load_phac2_h5(path)


def test_writer_rejects_bad_trials(tmp_path):
    t = make_trial()
    with pytest.raises(DataFileError, match="duplicate trial id"):
        write_phac2_h5(tmp_path / "d.h5", [t, t])
    with pytest.raises(DataFileError, match="<object>_<id3>_<trial2>"):
        write_phac2_h5(tmp_path / "d.h5", [make_trial("felt_3_1")])
    assert not (tmp_path / "d.h5").exists()
