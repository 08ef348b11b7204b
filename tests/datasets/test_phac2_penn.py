"""Penn static PHAC-2 features: the real 96 pickles and fabricated bad sets."""

from __future__ import annotations

import collections
import pickle
import time

import numpy as np
import pandas as pd
import pytest

from tzsl.datasets import (
    PENN_FEATURE_NAMES,
    PHAC2_EPS,
    TRIAL_COLUMNS,
    load_phac2_labels,
    load_phac2_penn,
    read_penn_static_pickles,
)
from tzsl.exceptions import DataFileError

# ---------------------------------------------------------------- fabricated pickles
OBJECTS = {101: "car_sponge", 202: "rock", 303: "felt"}
LABELS = {"hard": {101: 0, 202: 1, 303: 0}, "soft": {101: 1, 202: 0, 303: 1}}
N_TRIALS = 3


def _trial_names():
    return [f"{name}_{oid}_{t:02d}" for oid, name in OBJECTS.items() for t in range(1, N_TRIALS + 1)]


def _features(seed):
    return np.random.default_rng(seed).normal(size=(len(OBJECTS) * N_TRIALS, 47))


def _write_set(folder, mutate=None):
    """Write a full 2-adjective x 4-EP grid; ``mutate(adj, ep, block_dict)`` may alter one."""
    folder.mkdir(parents=True, exist_ok=True)
    names = _trial_names()
    ids = np.array([int(n.rsplit("_", 2)[1]) for n in names])
    paths = []
    for e, (ep, state) in enumerate(PHAC2_EPS.items()):
        feats = _features(e)
        for adj, lab in LABELS.items():
            labels = np.array([lab[i] for i in ids])
            block = {
                "features": feats.copy(),
                "labels": labels,
                "object_ids": ids.copy(),
                "object_names": np.array([n.encode() for n in names]),
            }
            if mutate is not None:
                mutate(adj, ep, block)
            # object 303 is the test object; reverse order to exercise re-alignment
            test = block["object_ids"] == 303
            data = collections.defaultdict(dict)
            for part, mask in (("train", ~test), ("test", test)):
                data[part] = collections.defaultdict(
                    None, {k: v[mask][::-1] for k, v in block.items()}
                )
            path = folder / f"static_feature_{adj}_{state}.pkl"
            path.write_bytes(pickle.dumps(data, protocol=2))
            paths.append(path)
    return paths


def _write_csv(path, labels=LABELS):
    rows = [
        {"object_id": oid, "object_name": name, **{a: labels[a][oid] for a in sorted(labels)}}
        for oid, name in OBJECTS.items()
    ]
    pd.DataFrame(rows).to_csv(path, index=False)
    return path


def test_fabricated_set_is_read_and_aligned(tmp_path):
    paths = _write_set(tmp_path / "p")
    data = read_penn_static_pickles(paths, labels_csv=_write_csv(tmp_path / "l.csv"))
    assert data.X.shape == (9, 4, 47)
    assert list(data.trials.columns) == list(TRIAL_COLUMNS)
    assert list(data.trials["trial_id"]) == _trial_names()  # sorted by object id, trial
    for e in range(4):
        np.testing.assert_array_equal(data.X[:, e, :], _features(e))
    assert data.eps == tuple(PHAC2_EPS)
    assert data.feature_names == PENN_FEATURE_NAMES
    assert list(data.labels.index) == ["car_sponge_101", "rock_202", "felt_303"]
    assert data.labels.loc["rock_202"].to_dict() == {"hard": 1, "soft": 0}
    assert data.object_ids.to_dict() == {"car_sponge_101": 101, "rock_202": 202, "felt_303": 303}
    assert not data.X.flags.writeable


def test_features_disagreeing_between_adjective_files(tmp_path):
    def mutate(adj, ep, block):
        if adj == "soft" and ep == "slow_slide":
            block["features"][4, 7] += 1e-6  # trial rock_202_02

    paths = _write_set(tmp_path, mutate)
    with pytest.raises(DataFileError) as err:
        read_penn_static_pickles(paths)
    msg = str(err.value)
    assert "static_feature_soft_SLIDE_5CM.pkl" in msg and "static_feature_hard_SLIDE_5CM.pkl" in msg
    assert "rock_202_02" in msg


def test_trials_of_one_object_with_different_labels(tmp_path):
    def mutate(adj, ep, block):
        if adj == "hard":
            block["labels"][5] = 0  # rock_202_03 says "not hard" in every EP

    paths = _write_set(tmp_path, mutate)
    with pytest.raises(DataFileError, match="trials of one object with different labels") as err:
        read_penn_static_pickles(paths)
    assert "rock_202" in str(err.value) and "rock_202_03" in str(err.value)


def test_label_differing_between_eps(tmp_path):
    def mutate(adj, ep, block):
        if adj == "soft" and ep == "fast_slide":
            block["labels"][0] = 0

    paths = _write_set(tmp_path, mutate)
    with pytest.raises(DataFileError, match="car_sponge_101_01") as err:
        read_penn_static_pickles(paths)
    assert "static_feature_soft_MOVE_DOWN_5CM.pkl" in str(err.value)


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_nan_or_inf_feature(tmp_path, bad):
    def mutate(adj, ep, block):
        if adj == "hard" and ep == "hold":
            block["features"][7, 20] = bad  # felt_303_02

    paths = _write_set(tmp_path, mutate)
    with pytest.raises(DataFileError, match="NaN/inf") as err:
        read_penn_static_pickles(paths)
    msg = str(err.value)
    assert "static_feature_hard_HOLD_FOR_10_SECONDS.pkl" in msg and "felt_303_02" in msg
    assert "gripper_min" in msg


def test_files_covering_different_trials(tmp_path):
    def mutate(adj, ep, block):
        if adj == "soft" and ep == "squeeze":
            for key in block:
                block[key] = block[key][:-1]

    paths = _write_set(tmp_path, mutate)
    with pytest.raises(DataFileError, match="different trials") as err:
        read_penn_static_pickles(paths)
    assert "felt_303_03" in str(err.value)


def test_incomplete_grid_names_the_missing_file(tmp_path):
    paths = _write_set(tmp_path)
    paths = [p for p in paths if p.name != "static_feature_hard_MOVE_DOWN_5CM.pkl"]
    with pytest.raises(DataFileError, match="static_feature_hard_MOVE_DOWN_5CM.pkl"):
        read_penn_static_pickles(paths)


def test_wrong_feature_width(tmp_path):
    def mutate(adj, ep, block):
        if adj == "hard" and ep == "hold":
            block["features"] = block["features"][:, :46]

    with pytest.raises(DataFileError, match=r"expected \(n, 47\)"):
        read_penn_static_pickles(_write_set(tmp_path, mutate))


def test_label_matrix_must_equal_the_csv(tmp_path):
    paths = _write_set(tmp_path / "p")
    wrong = {a: dict(v) for a, v in LABELS.items()}
    wrong["soft"][202] = 1
    with pytest.raises(DataFileError, match="differs from the pickles") as err:
        read_penn_static_pickles(paths, labels_csv=_write_csv(tmp_path / "l.csv", wrong))
    assert "rock_202" in str(err.value) and "soft" in str(err.value)


def test_malicious_pickle_in_the_set_is_rejected(tmp_path):
    paths = _write_set(tmp_path)
    marker = tmp_path / "ran"
    paths[3].write_bytes(b"cposix\nsystem\n(S'touch " + str(marker).encode() + b"'\ntR.")
    with pytest.raises(DataFileError, match="forbidden global 'posix.system'"):
        read_penn_static_pickles(paths)
    assert not marker.exists()


def test_non_dict_pickle(tmp_path):
    paths = _write_set(tmp_path)
    paths[0].write_bytes(pickle.dumps([1, 2, 3], protocol=2))
    with pytest.raises(DataFileError, match="'train' and 'test'"):
        read_penn_static_pickles(paths)


# ---------------------------------------------------------------- the real data
@pytest.mark.realdata
def test_real_penn_features(data_dir):
    t0 = time.perf_counter()
    data = load_phac2_penn(data_dir)
    assert time.perf_counter() - t0 < 5.0
    assert data.X.shape == (600, 4, 47) and data.X.dtype == np.float64
    assert np.isfinite(data.X).all()
    assert data.eps == ("squeeze", "hold", "slow_slide", "fast_slide")
    assert len(data.feature_names) == 47
    assert data.feature_names[0] == "pdc_rise_count_f0"
    assert data.feature_names[20:23] == ("gripper_min", "gripper_mean", "transform_distance")
    assert data.feature_names[23] == "electrode_polyfit_00" and data.feature_names[-1] == "electrode_polyfit_23"
    trials = data.trials
    assert trials["trial_id"].is_unique and len(trials) == 600
    assert trials["object_name"].nunique() == 60
    assert (trials.groupby("object_name").size() == 10).all()
    key = list(zip(trials["object_id"], trials["trial_index"], strict=True))
    assert key == sorted(key)
    assert data.labels.shape == (60, 24)
    assert list(data.labels.columns) == sorted(data.labels.columns)
    assert int(data.labels.to_numpy().sum()) == 251
    counts = data.labels.sum()
    assert (counts["smooth"], counts["hard"], counts["nice"], counts["squishy"]) == (28, 23, 1, 24)
    # the CSV is independent of the pickles: equal element by element
    pd.testing.assert_frame_equal(data.labels, load_phac2_labels(data_dir))
    assert data.trial_labels().shape == (600, 24)


@pytest.mark.realdata
def test_real_penn_features_equal_the_derived_npz(data_dir):
    data = load_phac2_penn(data_dir)
    npz = np.load(data_dir / "phac2/derived/phac2_penn_static_features.npz")
    names = [n.decode() if isinstance(n, bytes) else str(n) for n in npz["trial_names"]]
    order = [names.index(t) for t in data.trials["trial_id"]]
    np.testing.assert_array_equal(npz["X"][order], data.X)
    assert [str(p) for p in npz["phases"]] == [PHAC2_EPS[e] for e in data.eps]


@pytest.mark.realdata
def test_real_penn_cache_is_not_corrupted_by_callers(data_dir):
    first = load_phac2_penn(data_dir)
    first.trials.loc[0, "object_name"] = "changed"
    first.labels.iloc[0, 0] = 7
    with pytest.raises(ValueError):
        first.X[0, 0, 0] = 1.0
    t0 = time.perf_counter()
    again = load_phac2_penn(data_dir)
    assert time.perf_counter() - t0 < 1.0
    assert again.trials.loc[0, "object_name"] == "car_sponge_101"
    assert again.labels.iloc[0, 0] in (0, 1)
