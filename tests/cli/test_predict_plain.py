"""Plain-file dataset -> ``tzsl train-attributes --plain`` -> ``tzsl predict`` on its signal or feature files.

The datasets are SIMULATED (generated here): 8 classes = every 0/1 row of 3 attributes, each
attribute shifting one channel (or feature). Two classes are held out of training, and predict
ranks them from their trials' files alone: no attribute row of the grasped object is given.
"""

from __future__ import annotations

import itertools

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from tzsl.cli import cli
from tzsl.datasets import write_plain_dataset
from tzsl.inference.bundle import read_bundle_header
from tzsl.models.choices import DEFAULT_METHOD

ATTRS = ["hard", "soft", "rough"]
CLASSES = pd.DataFrame(list(itertools.product([0, 1], repeat=3)), columns=ATTRS,
                       index=pd.Index([f"c{i}" for i in range(8)], name="class"))
UNSEEN = ["c1", "c6"]  # rows 001 and 110: every attribute keeps both values among the 6 training classes
N_TRIALS = 6


def _run(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


def _ok(*args):
    result = _run(*args)
    assert result.exit_code == 0, result.output
    return result.output


def _trials() -> pd.DataFrame:
    rows = [(f"{c}_{t}", c) for c in CLASSES.index for t in range(N_TRIALS)]
    return pd.DataFrame(rows, columns=["trial_id", "class"])


def _splits(folder) -> None:
    roles = ["test" if c in UNSEEN else "train" for c in CLASSES.index]
    pd.DataFrame({"split": "held_out", "object": CLASSES.index, "role": roles}).to_csv(folder / "splits.csv",
                                                                                      index=False)


@pytest.fixture(scope="module")
def signal_dataset(tmp_path_factory):
    """One sensor, signal files of 3 channels whose level follows the class's attributes."""
    rng = np.random.default_rng(0)
    trials = _trials()
    levels = CLASSES.loc[trials["class"]].to_numpy(dtype=float) * 3.0
    signals = [[lv + rng.normal(0, 0.5, (40, 3))] for lv in levels]
    folder = write_plain_dataset(tmp_path_factory.mktemp("plain") / "sig", CLASSES, trials, signals=signals,
                                 channels=("p", "q", "r"), settings={"signals": {"statistics": ["mean", "std"]}})
    _splits(folder)
    return folder


def test_signal_dataset_train_then_predict_unseen_from_signal_files(signal_dataset, tmp_path):
    folder, model = signal_dataset, tmp_path / "model.tzsl"
    out = _ok("train-attributes", "--plain", folder, "--splits", folder / "splits.csv", "--cv", 2, "--no-cache",
              "--no-progress", "--out", model)
    assert "wrote" in out
    meta = read_bundle_header(model).metadata
    assert meta["method"] == DEFAULT_METHOD and meta["attribute_names"] == ATTRS
    assert sorted(meta["training_objects"]) == sorted(set(CLASSES.index) - set(UNSEEN))
    assert meta["input"]["signals"] == {"channels": ["p", "q", "r"], "statistics": ["mean", "std"],
                                        "baseline_rows": 0}
    # candidates from the dataset's own classes table; inputs are the unseen object's signal files
    for obj in UNSEEN:
        files = [folder / "signals" / f"{obj}_{t}.npz" for t in range(N_TRIALS)]
        text = _ok("predict", "--model", model, "--classes", folder, "--candidates", ",".join(UNSEEN), "--k", 3,
                   *files)
        assert f"SC-MDAP (k=3): decided {obj!r}" in text, text
    # a CSV naming signal files (here: trial_id + signal_file only, no class column) works the same
    manifest = tmp_path / "new_trials.csv"
    pd.DataFrame({"trial_id": [f"{UNSEEN[1]}_{t}" for t in range(3)],
                  "signal_file": [str(folder / "signals" / f"{UNSEEN[1]}_{t}.npz") for t in range(3)]}).to_csv(
        manifest, index=False)
    text = _ok("predict", "--model", model, "--classes", folder, "--candidates", ",".join(UNSEEN),
               "--multi-grasp", "df", manifest)
    assert f"DF-MDAP: decided {UNSEEN[1]!r} from all 3 grasps" in text and "grasp 3/3: c6_2" in text


def test_signal_file_missing_a_channel_is_one_line(signal_dataset, tmp_path):
    folder, model = signal_dataset, tmp_path / "model.tzsl"
    _ok("train-attributes", "--plain", folder, "--method", "eszsl", "--out", model)
    bad = tmp_path / "bad.npz"
    np.savez(bad, p=np.zeros(40), q=np.zeros(40))
    result = _run("predict", "--model", model, "--classes", folder, bad)
    assert result.exit_code == 3, result.output
    assert "channel(s) ['r'] missing" in result.output and str(bad) in result.output


def test_feature_dataset_any_method_predicts_from_a_bare_feature_csv(tmp_path):
    """Feature columns, two sensors, ESZSL (a registry method fitted on the sensors side by side)."""
    rng = np.random.default_rng(1)
    trials = _trials()
    A = CLASSES.loc[trials["class"]].to_numpy(dtype=float)
    X = np.stack([A @ rng.normal(0, 1, (3, 4)) * 2, A @ rng.normal(0, 1, (3, 4)) * 2], axis=1)
    X += rng.normal(0, 0.3, X.shape)
    names = [f"f{i}" for i in range(4)]
    folder = write_plain_dataset(tmp_path / "feat", CLASSES, trials, sensors=("left", "right"), X=X,
                                 feature_names=names)
    _splits(folder)
    model = tmp_path / "eszsl.tzsl"
    _ok("train-attributes", "--plain", folder, "--splits", folder / "splits.csv", "--method", "eszsl", "--out", model)
    meta = read_bundle_header(model).metadata
    assert meta["method"] == "eszsl" and meta["input"]["ndim"] == 2 and meta["input"]["sensors"] == ["left", "right"]
    # the new trials: trial_id, sensor and feature columns only (no class, no object, no attributes)
    obj = UNSEEN[0]
    rows = trials.index[trials["class"] == obj]
    new = pd.DataFrame([{"trial_id": f"new_{i}", "sensor": s, **dict(zip(names, X[r, j], strict=True))}
                        for i, r in enumerate(rows) for j, s in enumerate(("right", "left"))])
    new.sample(frac=1.0, random_state=0).to_csv(tmp_path / "new.csv", index=False)  # any row order
    classes = tmp_path / "candidates.csv"
    CLASSES.loc[UNSEEN].to_csv(classes)
    text = _ok("predict", "--model", model, "--classes", classes, "--multi-grasp", "df", tmp_path / "new.csv")
    assert f"DF-MDAP: decided {obj!r} from all {N_TRIALS} grasps" in text, text
    # the dataset's own trials.csv (class column ignored) is a valid input too
    text = _ok("predict", "--model", model, "--classes", classes, folder / "trials.csv")
    assert f"grasp {len(trials)}/{len(trials)}" in text
    missing = _run("predict", "--model", model, "--classes", classes, "--candidates", "c9", tmp_path / "new.csv")
    assert missing.exit_code == 3 and "candidate class(es) ['c9'] not in the table" in missing.output


def test_train_attributes_option_conflicts_are_one_line(signal_dataset, tmp_path):
    out = tmp_path / "m.tzsl"
    for args, message in [(("--method", "eszsl", "--fusion", "max"), "--fusion set(s) the default DAP model"),
                          (("--method", "eszsl", "--per-ep"), "exclude each other"),
                          (("--method", "nope"), "unknown method 'nope'"),
                          (("--method", "ldap"), "self-contained estimator")]:
        result = _run("train-attributes", "--plain", signal_dataset, "--out", out, *args)
        assert result.exit_code == 3 and message in result.output, result.output
    assert not out.exists()


@pytest.mark.parametrize("rows, message", [
    ("trial_id,f0,f1,f2,f3\nt,1,2,3,4\n", "no 'sensor' column"),
    ("sensor,f0,f1,f2,f3\nleft,1,2,3,4\nright,1,2,3,4\n", "no 'trial_id' column"),
    ("trial_id,sensor,f0,f1,f2,f3\nt,left,1,2,3,4\nt,right,1,x,3,4\n", "holds text that is not a number"),
    ("trial_id,sensor,f0,f1,f2,f3\nt,left,1,2,3,4\nt,right,1,,3,4\n", "NaN or infinite feature value"),
    ("trial_id,sensor,f0,f1,f2,f3\nt,left,1,2,3,4\nt,left,1,2,3,4\nt,right,1,2,3,4\n", "duplicate row for trial 't'"),
    ("trial_id,sensor,f0,f1,f2,f3\nt,left,1,2,3,4\nt,right,1,2,3,4\nu,left,1,2,3,4\n", "exactly one row per sensor"),
    ("trial_id,sensor,f0,f1,f3\nt,left,1,2,4\nt,right,1,2,4\n", "feature column(s) the model needs are missing"),
    ("trial_id,sensor,f0,f1,f2,f3\nt,left,1,2,3,4\nt,middle,1,2,3,4\n", "sensor(s) ['right'] missing"),
])
def test_bad_feature_rows_are_one_line(tmp_path, rows, message):
    rng = np.random.default_rng(2)
    trials = _trials()
    X = CLASSES.loc[trials["class"]].to_numpy(dtype=float)[:, None, :] @ rng.normal(0, 1, (3, 4)) + np.zeros((1, 2, 1))
    folder = write_plain_dataset(tmp_path / "feat", CLASSES, trials, sensors=("left", "right"),
                                 X=X + rng.normal(0, 0.3, X.shape), feature_names=[f"f{i}" for i in range(4)])
    model = tmp_path / "m.tzsl"
    _ok("train-attributes", "--plain", folder, "--method", "eszsl", "--out", model)
    bad = tmp_path / "bad.csv"
    bad.write_text(rows)
    result = _run("predict", "--model", model, "--classes", folder, bad)
    assert result.exit_code == 3, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and message in lines[0] and str(bad) in lines[0], result.output
