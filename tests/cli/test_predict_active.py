"""``tzsl predict --eps-done ... --suggest-next [--json]`` on a saved per-EP (active touch) bundle.

A SIMULATED per-EP dataset (always run) and real PHAC-2 (skipped without the data unless CI is set).
"""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from tzsl.cli import cli
from tzsl.datasets import FeatureSet
from tzsl.inference.predict_active import PER_EP_KIND, load_per_ep_model, train_per_ep_bundle
from tzsl.models.active_touch import suggest_next_ep

ATTRS = ["hard", "soft", "rough"]
EP_NAMES = [f"{ep}:{f}" for ep in ("squeeze", "hold") for f in ("a", "b")]
SENSORS = ("finger_0", "finger_1")


def _run(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


def _ok(*args):
    result = _run(*args)
    assert result.exit_code == 0, result.output
    return result.output


def _simulated(seed: int, objects: list[str], A: np.ndarray, n_trials: int = 5) -> FeatureSet:
    """SIMULATED: squeeze features follow hard/soft, hold features follow rough, both sensors alike."""
    rng = np.random.default_rng(seed)
    rows = [(o, t) for o in objects for t in range(n_trials)]
    attrs = pd.DataFrame(A, index=pd.Index(objects, name="object_name"), columns=ATTRS)
    a = attrs.loc[[o for o, _ in rows]].to_numpy(dtype=float)
    X = np.column_stack([2 * a[:, 0], 2 * a[:, 1], 2 * a[:, 2], -2 * a[:, 2]])
    X = np.stack([X + rng.normal(0, 0.4, X.shape) for _ in SENSORS], axis=1)
    trials = pd.DataFrame({"trial_id": [f"{o}_{t}" for o, t in rows], "object_id": [objects.index(o) for o, _ in rows],
                           "object_name": [o for o, _ in rows], "trial_index": [t for _, t in rows]})
    return FeatureSet(X=X, trials=trials, sensors=SENSORS, feature_names=tuple(EP_NAMES), attributes=attrs,
                      dataset="simulated")


@pytest.fixture(scope="module")
def simulated(tmp_path_factory):
    root = tmp_path_factory.mktemp("active")
    A = np.array([[1, 0, 0], [0, 1, 0], [1, 0, 1], [0, 1, 1], [1, 1, 0], [0, 0, 1], [1, 1, 1], [0, 0, 0]])
    train = _simulated(0, [f"tr{i}" for i in range(len(A))], A)
    meta = train_per_ep_bundle(train, root / "per_ep.tzsl", seed=0, cv=3)
    classes = root / "classes.csv"
    pd.DataFrame({"class": ["u0", "u1", "u2"], "hard": [1, 0, 1], "soft": [0, 1, 0], "rough": [1, 1, 0]}).to_csv(
        classes, index=False)
    test = _simulated(1, ["u0"], np.array([[1, 0, 1]]), n_trials=1)
    # what the robot measured so far: the squeeze columns of one trial, nothing else
    robot = pd.DataFrame([{"trial_id": "t0", "sensor": s, "squeeze:a": test.X[0, j, 0], "squeeze:b": test.X[0, j, 1]}
                          for j, s in enumerate(SENSORS)])
    robot.to_csv(root / "squeeze_only.csv", index=False)
    return root, meta, classes, test


def test_bundle_records_eps_and_schema(simulated):
    root, meta, _, _ = simulated
    model, loaded = load_per_ep_model(root / "per_ep.tzsl")
    assert loaded["bundle"]["kind"] == PER_EP_KIND and loaded["eps"] == ["squeeze", "hold"]
    assert loaded["ep_seconds"] == [6.0, 10.0] and loaded["input"]["feature_names"] == EP_NAMES
    assert model.confusion_.shape == (2, 3, 2, 10)


def test_bundle_round_trip_keeps_the_fitted_exponents(simulated, tmp_path):
    from tzsl.exceptions import ModelBundleError
    from tzsl.inference.bundle import save_bundle

    root, meta, _, _ = simulated
    model, loaded = load_per_ep_model(root / "per_ep.tzsl")
    assert model.exponents_.shape == (4,) and model.exponents_[0] == 1.0 and (model.exponents_ > 0).all()
    assert loaded["posterior"]["tempering"] == model.tempering == "subset"
    np.testing.assert_allclose(loaded["posterior"]["exponents"], model.exponents_)
    assert loaded["posterior"]["fitted_on_trials"] == model.tempering_trials_ > 0
    del model.exponents_  # a bundle written before the tempered update
    save_bundle(tmp_path / "old.tzsl", model, kind=PER_EP_KIND, metadata=meta)
    with pytest.raises(ModelBundleError, match="no fitted posterior exponents"):
        load_per_ep_model(tmp_path / "old.tzsl")


def test_suggest_next_json_matches_the_policy(simulated):
    root, _, classes, test = simulated
    out = _ok("predict", "--model", root / "per_ep.tzsl", "--classes", classes, "--eps-done", "squeeze",
              "--suggest-next", "--json", "--threshold", "0.999", root / "squeeze_only.csv")
    report = json.loads(out)
    model, _ = load_per_ep_model(root / "per_ep.tzsl")
    K = pd.read_csv(classes, index_col=0)
    direct = suggest_next_ep(model, K.to_numpy(), {"squeeze": test.X[0][:, :2]}, class_names=list(K.index),
                             threshold=0.999)
    assert report["ranking"] == direct["ranking"] and report["next_ep"] == direct["next_ep"]
    assert report["done_eps"] == ["squeeze"] and report["seconds_used"] == 6.0 and report["threshold"] == 0.999
    assert report["trial"] == "t0" and sum(r["probability"] for r in report["ranking"]) == pytest.approx(1.0)
    # squeeze tells hard/soft apart: u1 (soft) is least likely; u0 and u2 differ only in rough, which hold senses
    assert report["ranking"][-1]["class"] == "u1"
    assert not report["decided"] and report["next_ep"] == "hold" and report["expected_gain_bits"] > 0
    assert [c["ep"] for c in report["candidates"]] == ["hold"]
    post = report["posterior"]
    assert set(post) == {"tempering", "exponent", "untempered_top_probability", "fitted_on"}
    assert post == direct["posterior"] and post["exponent"] == pytest.approx(model.exponents_[1])
    assert "pseudo-unseen training objects" in post["fitted_on"]


def test_suggest_next_text_and_decided(simulated):
    root, _, classes, _ = simulated
    text = _ok("predict", "--model", root / "per_ep.tzsl", "--classes", classes, "--eps-done", "squeeze",
               "--suggest-next", "--threshold", "0.999", root / "squeeze_only.csv")
    assert "EPs done squeeze (6 s)" in text and "not decided: top posterior" in text
    assert "suggested next EP: hold (expected entropy reduction" in text
    assert "posterior: tempering 'subset', exponent" in text
    decided = json.loads(_ok("predict", "--model", root / "per_ep.tzsl", "--classes", classes, "--eps-done",
                             "squeeze", "--suggest-next", "--json", "--threshold", "0.01", root / "squeeze_only.csv"))
    assert decided["decided"] and decided["stop_reason"] == "threshold" and decided["next_ep"] is None
    assert decided["decision"] == decided["ranking"][0]["class"]


def test_active_errors_are_one_line(simulated, tmp_path):
    root, _, classes, _ = simulated
    model = root / "per_ep.tzsl"
    cases = [
        (("--eps-done", "squeeze,hold"), "feature column(s) the model needs are missing"),
        (("--eps-done", "poke"), "unknown EP(s) ['poke']"),
        ((), "needs --eps-done"),
    ]
    for extra, message in cases:
        result = _run("predict", "--model", model, "--classes", classes, *extra, root / "squeeze_only.csv")
        assert result.exit_code == 3 and message in result.output, result.output


@pytest.fixture(scope="module")
def phac2(data_dir, tmp_path_factory):
    from tzsl.datasets._feature_table import read_feature_table

    root = tmp_path_factory.mktemp("active_phac2")
    splits, model, feats = root / "splits.csv", root / "per_ep.tzsl", root / "features.npz"
    _ok("splits", "--split", "random", "--n-splits", 1, "--out", splits, "--data-dir", data_dir)
    out = _ok("train-attributes", "--per-ep", "--splits", splits, "--out", model, "--data-dir", data_dir)
    assert "per-EP model: EPs squeeze, hold, slow_slide, fast_slide (6 s, 10 s, 5 s, 2 s)" in out
    _ok("extract", "--dataset", "phac2-penn", "--out", feats, "--data-dir", data_dir)
    return root, splits, model, read_feature_table(feats)


def test_phac2_per_ep_bundle_suggests_next_ep(phac2):
    root, splits, model, fs = phac2
    table = pd.read_csv(splits)
    test_objects = table.loc[table["role"] == "test", "object"].tolist()
    _, meta = load_per_ep_model(model)
    assert set(meta["training_objects"]).isdisjoint(test_objects) and len(meta["training_objects"]) == 50
    classes = root / "classes.csv"
    fs.attributes.loc[test_objects, meta["attribute_names"]].rename_axis("class").reset_index().to_csv(
        classes, index=False)
    trial = fs.subset(np.flatnonzero(fs.objects == test_objects[0])[:1])
    cols = [i for i, n in enumerate(fs.feature_names) if n.split(":")[0] in ("squeeze", "hold")]
    robot = pd.DataFrame([{"trial_id": trial.trials["trial_id"][0], "sensor": s,
                           **{fs.feature_names[c]: trial.X[0, j, c] for c in cols}}
                          for j, s in enumerate(fs.sensors)])
    robot.to_csv(root / "robot.csv", index=False)
    report = json.loads(_ok("predict", "--model", model, "--classes", classes, "--eps-done", "squeeze,hold",
                            "--suggest-next", "--json", root / "robot.csv"))
    assert report["done_eps"] == ["squeeze", "hold"] and report["seconds_used"] == 16.0
    assert sorted(r["class"] for r in report["ranking"]) == sorted(test_objects)
    assert sum(r["probability"] for r in report["ranking"]) == pytest.approx(1.0)
    if report["decided"]:
        assert report["next_ep"] is None and report["ranking"][0]["probability"] >= report["threshold"]
    else:
        assert report["next_ep"] in ("slow_slide", "fast_slide") and report["expected_gain_bits"] >= 0
        assert {c["ep"] for c in report["candidates"]} == {"slow_slide", "fast_slide"}
    text = _ok("predict", "--model", model, "--classes", classes, "--eps-done", "squeeze,hold", "--suggest-next",
               root / "robot.csv")
    assert "EPs done squeeze, hold (16 s)" in text and "suggested next EP:" in text
