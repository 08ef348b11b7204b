"""One choice, carried (issue 43, item 1): the study's deploy choice is the model a robot loads.

The choice rule (:func:`tzsl.studies.zero_shot.deployment.choose_deployment`) on hand-made per-split
tables, one test per branch; then, on a small SIMULATED plain dataset (8 objects, features as columns
that follow the attributes with noise), ``tzsl run`` of the fast template writes ``deployment.json``
and, with ``[output] model = true``, ``model.tzsl``; ``tzsl train-attributes --from-results`` trains
the same method entry (the bundles' metadata name it, and they predict the same posteriors), and
``tzsl predict`` reports it; the command refuses, in one line, what would not be that choice.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from tests.study_settings import FAST_TEMPLATE
from tzsl.cli import cli
from tzsl.datasets import write_plain_dataset
from tzsl.inference.bundle import read_bundle_header
from tzsl.models.choices import DEFAULT_METHOD
from tzsl.studies.zero_shot.deployment import (
    DEPLOYMENT_FILE,
    MIN_SPLITS,
    MODEL_FILE,
    choose_deployment,
    default_entry,
)

REPO = Path(__file__).resolve().parents[2]
TEMPLATE = REPO / "experiments" / "my_dataset_template.toml"
ROWS = {  # hard rough cold soft
    "mug": [1, 0, 1, 0], "sponge": [0, 1, 0, 1], "can": [1, 0, 1, 1], "towel": [0, 1, 0, 0],
    "stone": [1, 1, 1, 0], "tissue": [0, 0, 0, 1], "bottle": [1, 0, 0, 0], "brush": [0, 1, 1, 1],
}
DEFAULT = default_entry()["label"]


# ----------------------------------------------------------------------------- the rule, on hand-made tables


def _entry(label: str) -> dict:
    return {"label": label, "method": {"name": label}, "svm": None}


def _table(accuracies: dict[str, list[list[float]]]) -> pd.DataFrame:
    """``{method: [[class accuracies of split 1], ...]}`` -> the (method, split, class, accuracy) table."""
    rows = [{"method": m, "split": str(i + 1), "class": f"c{j}", "accuracy": a}
            for m, splits in accuracies.items() for i, split in enumerate(splits) for j, a in enumerate(split)]
    return pd.DataFrame(rows)


def test_too_few_splits_keep_the_generic_default_and_say_so():
    table = _table({DEFAULT: [[0.2, 0.4, 0.3, 0.1]], "eszsl": [[1.0, 1.0, 1.0, 1.0]]})
    chosen = choose_deployment(table, {DEFAULT: _entry(DEFAULT), "eszsl": _entry("eszsl")}, default_entry())
    assert chosen["label"] == DEFAULT_METHOD and chosen["branch"] == "too-few-splits"
    assert f"fewer than the {MIN_SPLITS}" in chosen["reason"] and "generic default" in chosen["reason"]
    assert chosen["n_splits"] == 1 and chosen["paired"] is None
    # no split at all (challenging splits only): the default, said so
    empty = choose_deployment(table.iloc[0:0], {"eszsl": _entry("eszsl")}, default_entry())
    assert empty["label"] == DEFAULT and empty["method"] == {"name": DEFAULT_METHOD} and empty["n_splits"] == 0


def test_a_clear_winner_replaces_the_default():
    table = _table({DEFAULT: [[0.25, 0.0, 0.5, 0.25]] * 5, "eszsl": [[1.0, 0.75, 1.0, 1.0]] * 5,
                    "sae": [[0.5, 0.5, 0.5, 0.5]] * 5})
    candidates = {m: _entry(m) for m in (DEFAULT, "eszsl", "sae")}
    chosen = choose_deployment(table, candidates, default_entry())
    assert chosen["label"] == "eszsl" and chosen["branch"] == "clear-winner"
    assert chosen["paired"]["ci95_low"] > 0 and chosen["paired"]["mean"] == pytest.approx(0.6875)
    assert chosen["chosen"]["mean"] == pytest.approx(0.9375) and chosen["chance"] == pytest.approx(0.25)
    assert [c["label"] for c in chosen["candidates"]] == ["eszsl", "sae", DEFAULT]
    assert "beats the generic default" in chosen["reason"] and "optimistic" in chosen["selection_note"]


def test_a_gain_whose_interval_includes_zero_keeps_the_default():
    table = _table({DEFAULT: [[0.5, 0.5, 0.5, 0.5], [0.5, 0.5, 0.5, 0.5], [0.5, 0.5, 0.5, 0.5]],
                    "eszsl": [[1.0, 1.0, 1.0, 1.0], [0.0, 0.25, 0.5, 0.5], [0.5, 0.75, 0.5, 0.5]]})
    chosen = choose_deployment(table, {DEFAULT: _entry(DEFAULT), "eszsl": _entry("eszsl")}, default_entry())
    assert chosen["label"] == DEFAULT and chosen["branch"] == "default-kept"
    assert chosen["paired"]["method"] == "eszsl" and chosen["paired"]["ci95_low"] <= 0
    assert "does not clear 0" in chosen["reason"]


def test_the_default_most_accurate_stays_and_ties_go_to_it():
    table = _table({"eszsl": [[0.5, 0.5]] * 3, DEFAULT: [[0.5, 0.5]] * 3})
    chosen = choose_deployment(table, {"eszsl": _entry("eszsl"), DEFAULT: _entry(DEFAULT)}, default_entry())
    assert chosen["label"] == DEFAULT and chosen["branch"] == "default-most-accurate"


def test_without_the_default_the_most_accurate_complete_method_is_chosen_and_said():
    table = _table({"eszsl": [[0.5, 0.5]] * 3, "sae": [[1.0, 1.0]] * 2, "dap-max": [[0.75, 0.75]] * 3})
    candidates = {m: _entry(m) for m in ("eszsl", "sae", "dap-max")}
    chosen = choose_deployment(table, candidates, default_entry())
    assert chosen["label"] == "dap-max" and chosen["branch"] == "default-not-run"
    assert chosen["incomplete"] == ["sae"]  # missed a split: not a candidate
    assert f"the generic default {DEFAULT} was not run" in chosen["reason"]


# ----------------------------------------------------------------------------- the command line, end to end


def _ok(args) -> str:
    result = CliRunner().invoke(cli, [str(a) for a in args])
    assert result.exit_code == 0, result.output + (result.stderr or "")
    return result.stdout


def _refused(args) -> str:
    result = CliRunner().invoke(cli, [str(a) for a in args])
    assert result.exit_code != 0, result.output
    lines = [line for line in result.stderr.splitlines() if line.startswith("tzsl: error")]
    assert len(lines) == 1, result.stderr
    return lines[0]


def _dataset(root: Path, noise: float = 0.6, force: bool = False) -> Path:
    classes = pd.DataFrame.from_dict(ROWS, orient="index", columns=["hard", "rough", "cold", "soft"])
    classes.index.name = "class"
    rng = np.random.default_rng(0)
    names = np.repeat(classes.index.to_numpy(), 4)
    levels = classes.loc[names].to_numpy(dtype=float)
    X = np.stack([levels * 2 + rng.normal(0, noise, levels.shape) + k for k in range(2)], axis=1)
    write_plain_dataset(root, classes, pd.DataFrame({"trial_id": [f"t{i}" for i in range(len(names))],
                                                     "class": names}),
                        sensors=["left", "right"], X=X, feature_names=["f0", "f1", "f2", "f3"],
                        settings={"name": "lab-sim"}, force=force)
    return root


@pytest.mark.slow
def test_run_train_from_results_and_predict_use_the_same_method(tmp_path, monkeypatch):
    """One test for the run and what reads its choice (the run takes a few seconds)."""
    monkeypatch.chdir(tmp_path)
    dataset = _dataset(tmp_path / "my_dataset")
    text = TEMPLATE.read_text().replace('folder = "results/my_dataset"', 'folder = "results/lab"\nmodel = true')
    (tmp_path / "lab.toml").write_text(text + FAST_TEMPLATE)  # the study's own DAP is the default: it is run
    out = _ok(["run", "lab.toml"])
    results = tmp_path / "results" / "lab"
    record = json.loads((results / DEPLOYMENT_FILE).read_text())
    manifest = json.loads((results / "manifest.json").read_text())
    assert manifest["config"]["deployment"] == record and DEPLOYMENT_FILE in manifest["outputs"]
    assert record["n_splits"] == 2 and record["dataset"]["fingerprint"] and record["rule"]
    assert record["label"] in {c["label"] for c in record["candidates"]} and record["default"]["ran"]
    assert record["branch"] in ("default-most-accurate", "clear-winner", "default-kept")
    assert f"deploy: {record['label']} (deployment.json): " in out and "optimistic" in out
    assert f"model: {Path('results/lab') / MODEL_FILE}, trained on every object" in out
    # the run's bundle and train-attributes --from-results: the same entry, the same posteriors
    _ok(["train-attributes", "--from-results", results, "--out", "robot.tzsl"])
    ran, trained = (read_bundle_header(p).metadata for p in (results / MODEL_FILE, tmp_path / "robot.tzsl"))
    for key in ("method", "method_entry", "svm_settings", "seed", "training_objects", "attribute_names"):
        assert ran[key] == trained[key], key
    assert trained["method"] == record["label"] and trained["method_entry"] == record["method"]
    assert trained["deployment"]["branch"] == record["branch"] and len(trained["training_objects"]) == 8
    shown = _ok(["predict", "--model", "robot.tzsl", "--classes", dataset, dataset / "trials.csv"])
    assert shown.startswith(f"model: {record['label']} (")
    ran_json = _ok(["predict", "--model", results / MODEL_FILE, "--classes", dataset, "--json",
                    dataset / "trials.csv"])
    trained_json = _ok(["predict", "--model", "robot.tzsl", "--classes", dataset, "--json", dataset / "trials.csv"])
    assert json.loads(trained_json)["model"]["method"] == record["label"]
    assert ran_json == trained_json  # same model, same posteriors
    report = _ok(["report", results])
    assert "report" in report and "What a robot would be given" in (results / "report.html").read_text()
    # another method entry in the file is trained as written: a registry method
    other = {**record, "label": "eszsl", "method": {"name": "eszsl"}, "svm": None}
    (tmp_path / "other").mkdir()
    (tmp_path / "other" / DEPLOYMENT_FILE).write_text(json.dumps(other))
    _ok(["train-attributes", "--from-results", tmp_path / "other", "--out", "eszsl.tzsl"])
    assert read_bundle_header(tmp_path / "eszsl.tzsl").metadata["method_entry"] == {"name": "eszsl"}
    # refusals, one line each
    assert "leave out --method" in _refused(["train-attributes", "--from-results", results, "--out", "x.tzsl",
                                             "--method", "eszsl"])
    assert "the study ran on plain" in _refused(["train-attributes", "--from-results", results, "--out", "x.tzsl",
                                                 "--plain", tmp_path])
    assert "no deploy choice here" in _refused(["train-attributes", "--from-results", tmp_path, "--out", "x.tzsl"])
    (tmp_path / "bad").mkdir()
    (tmp_path / "bad" / DEPLOYMENT_FILE).write_text("{not json")
    assert "not a readable deploy choice" in _refused(["train-attributes", "--from-results", tmp_path / "bad",
                                                       "--out", "x.tzsl"])
    _dataset(dataset, noise=0.7, force=True)  # the data changed since the study
    assert "differ from those the study read" in _refused(["train-attributes", "--from-results", results,
                                                           "--out", "x.tzsl"])


def test_train_attributes_without_a_method_trains_the_generic_default(tmp_path):
    dataset = _dataset(tmp_path / "my_dataset")
    _ok(["train-attributes", "--plain", dataset, "--out", tmp_path / "m.tzsl", "--cv", "2", "--grid", "paper",
         "--no-progress"])
    meta = read_bundle_header(tmp_path / "m.tzsl").metadata
    assert meta["method"] == DEFAULT and meta["method_entry"] == {"name": DEFAULT_METHOD}
    assert meta["svm_settings"]["cv"] == 2 and meta["svm_settings"]["grid"] == "paper"
