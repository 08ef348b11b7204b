"""The fabric-deep study on ``physiclear`` (``[dataset] builtin = "physiclear"``, ``tzsl train-deep --dataset
physiclear``): the key-frame imprints of the small release made by the tests (tiny videos served on 127.0.0.1,
never the real data), the paper's object split, intervals and chance beside every accuracy."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from tests.datasets.fetch_server import registered_release, run_cli
from tests.datasets.physiclear_release import OBJECTS, SHAPE, write_release
from tzsl.datasets import physiclear_key_frames, physiclear_split_roles, read_physiclear_attributes
from tzsl.exceptions import ConfigError
from tzsl.studies.config import FabricDeepStudy

#: A small network (random frozen CNN on 16 x 16 frames, 2 epochs): plumbing, not accuracy.
MODEL = {"backbone": "small-cnn", "image_size": 16, "hidden_size": 8, "epochs": 2, "n_threads": 1}
FAST = ["--backbone", "small-cnn", "--image-size", "16", "--hidden-size", "8", "--epochs", "2", "--no-progress",
        "--n-threads", "1"]


@pytest.fixture(scope="module")
def release(tmp_path_factory):
    """The small release, written once for the module (its videos take seconds to encode)."""
    pytest.importorskip("torch", reason="PyTorch is not installed (the optional deep extra)")
    folder = tmp_path_factory.mktemp("physiclear") / "home"
    return folder, write_release(folder)


@pytest.fixture
def home(release, tmp_path, monkeypatch):
    """A data home holding the small release, registered instead of tzsl's registry; the test's own cache."""
    folder, files = release
    monkeypatch.setenv("TZSL_CACHE_DIR", str(tmp_path / "cache"))
    with registered_release(folder, files, tmp_path / "registry.txt", monkeypatch):
        yield folder


def test_the_sequences_are_the_key_frame_imprints_of_every_video(home):
    from tzsl.studies.fabric.deep_physiclear import physiclear_sequences

    seqs = physiclear_sequences(home)
    assert seqs.frames.shape == (2 * len(OBJECTS), 5, *SHAPE[1:]) and seqs.frames.dtype == np.float32
    assert set(seqs.table["object"]) == set(OBJECTS) and seqs.source == "physiclear"
    first = seqs.table.iloc[0]
    images, keys = physiclear_key_frames(first["path"])  # the one key-frame rule, as the descriptors read it
    assert first["frame_index"] == keys.tolist() and np.allclose(seqs.frames[0], images)
    assert np.abs(seqs.frames).max() <= 1.0


def test_the_protocols_fit_training_objects_only_and_score_distinct_rows():
    from tzsl.studies.fabric.deep_physiclear import physiclear_protocols

    classes = read_physiclear_attributes().classes
    roles = physiclear_split_roles()
    validation, test = physiclear_protocols(classes, OBJECTS)
    train = [o for o in roles["train"] if o in OBJECTS]
    assert validation.train == test.train == tuple(train)
    assert set(test.test) == {o for o in roles["test"] if o in OBJECTS}
    assert set(validation.test) <= set(roles["validation"]) and not set(validation.test) & set(train)
    rows = classes.loc[list(validation.test), list(validation.attributes)]
    assert not rows.duplicated().any()  # lemon repeats steel_wool's row over the kept attributes: left out
    positives = classes.loc[train, list(test.attributes)].sum()
    assert (positives >= 3).all() and (positives < len(train)).all()
    with pytest.raises(ConfigError, match="zero-shot scoring needs at least 2"):
        physiclear_protocols(classes, [o for o in OBJECTS if o != "orange"])


def test_the_study_reports_unseen_objects_with_intervals_and_chance(home, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "deep.toml").write_text(
        f'study = "fabric-deep"\n[dataset]\nbuiltin = "physiclear"\ndata_dir = "{home}"\n'
        f'[methods]\nembedding_lambdas = [0.1, "inf"]\n[methods.model]\n'
        + "".join(f"{k} = {json.dumps(v)}\n" for k, v in MODEL.items())
        + '[compute]\nprogress = false\n[output]\nfolder = "results"\n')
    code, out, err = run_cli("run", "deep.toml", "--no-progress")
    assert code == 0, err + out
    table = pd.read_csv(tmp_path / "results" / "fabric_deep_table.csv")
    runs = pd.read_csv(tmp_path / "results" / "fabric_deep_runs.csv")
    assert table[["protocol", "method"]].values.tolist() == [
        ["validation", "lam_0.1"], ["validation", "lam_inf"], ["test", "lam_0.1"], ["test", "lam_inf"]]
    assert (table["condition"] == "physiclear-keyframes").all()
    for col in ("accuracy", "per_class_mean_accuracy"):
        assert (table[f"{col}_ci95_low"] <= table[col]).all() and (table[col] <= table[f"{col}_ci95_high"]).all()
    assert np.allclose(table["chance"], 1 / runs["n_test_objects"])
    test = runs[runs["protocol"] == "test"]
    assert set(test["test_objects"]) == {"orange eraser"} and (test["n_test"] == 4).all()
    assert (runs["n_train"] == 2 * runs["n_train_objects"]).all() and (runs["epochs"] == 2).all()
    assert (runs["cpu_seconds"] > 0).all()
    chosen = table.loc[table["chosen_on_validation"], "method"]
    assert chosen.nunique() == 1 and len(chosen) == 2  # one lambda, marked on both protocols
    manifest = json.loads((tmp_path / "results" / "manifest.json").read_text())
    assert len(manifest["data_files"]) == 2 * len(OBJECTS)


def test_train_deep_saves_the_test_protocols_network(home, tmp_path):
    from tzsl.inference.deep_bundles import load_deep_bundle

    out = tmp_path / "m.tzsl-deep"
    code, stdout, err = run_cli("train-deep", "--dataset", "physiclear", "--data-dir", home, "--out", out,
                                "--lam", "1", *FAST)
    assert code == 0, err + stdout
    runs = pd.read_csv(tmp_path / "fabric_deep_runs.csv")
    assert runs["protocol"].tolist() == ["test"] and runs["method"].tolist() == ["lam_1"]
    model = load_deep_bundle(out)
    train = [o for o in physiclear_split_roles()["train"] if o in OBJECTS]
    assert sorted(model.classes_.tolist()) == sorted(train) and model.sequence_shape_ == (5, *SHAPE[1:], 1)


def test_fabric_only_settings_are_refused_with_physiclear(tmp_path):
    with pytest.raises(ValueError, match="gelsight_root: fabric data only"):
        FabricDeepStudy.model_validate({"dataset": {"builtin": "physiclear", "gelsight_root": "videos"}})
    with pytest.raises(ValueError, match="attributes: fabric data only"):
        FabricDeepStudy.model_validate({"dataset": {"builtin": "physiclear", "attributes": "a4"}})
    # one object split: the fabric's two configs do not stop saving a model
    study = FabricDeepStudy.model_validate({"dataset": {"builtin": "physiclear"}, "output": {"model": "m"},
                                            "methods": {"embedding_lambdas": [1.0]}})
    assert study.splits.configs == [1, 2]
    code, out, err = run_cli("train-deep", "--dataset", "physiclear", "--out", tmp_path / "m", "--attributes", "a4")
    assert code != 0 and "--attributes: fabric data only" in out + err
