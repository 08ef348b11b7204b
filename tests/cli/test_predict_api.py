"""The load-once Python API (:class:`tzsl.inference.Recogniser`) against ``tzsl predict``, and what loading imports.

The datasets are SIMULATED (generated here): 16 classes = every 0/1 row of 4 attributes, five
"fingers" (sensors) whose 6 features are a random linear image of the class's attributes plus
noise. Two classes are held out of training and recognised from their trials alone.
"""

from __future__ import annotations

import itertools
import json
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from tzsl.cli import cli
from tzsl.datasets import FeatureSet, write_plain_dataset
from tzsl.exceptions import ConfigError, ModelBundleError
from tzsl.inference import Recogniser
from tzsl.inference.bundle import read_bundle_header, save_bundle
from tzsl.inference.predict_active import train_per_ep_bundle
from tzsl.inference.zero_shot_bundles import load_predictor

REPO = Path(__file__).resolve().parents[2]
ATTRS = ["hard", "soft", "rough", "smooth"]
CLASSES = pd.DataFrame(list(itertools.product([0, 1], repeat=4)), columns=ATTRS,
                       index=pd.Index([f"c{i}" for i in range(16)], name="class"))
UNSEEN = ["c5", "c10"]  # rows 0101 and 1010
SENSORS = [f"finger_{i}" for i in range(5)]
FEATURES = [f"f{i}" for i in range(6)]
TRAINED: dict = {}  # the fitted DAP classifier behind the fixture's dap.tzsl


def _ok(*args) -> str:
    result = CliRunner().invoke(cli, [str(a) for a in args])
    assert result.exit_code == 0, result.output
    return result.output


@pytest.fixture(scope="module")
def five_fingers(tmp_path_factory):
    """A plain feature dataset of 5 sensors, ESZSL, SAE, ALE (linear) and DAP (detector arrays) bundles, new trials."""
    rng = np.random.default_rng(0)
    root = tmp_path_factory.mktemp("api")
    trials = pd.DataFrame([(f"{c}_{t}", c) for c in CLASSES.index for t in range(5)], columns=["trial_id", "class"])
    A = CLASSES.loc[trials["class"]].to_numpy(dtype=float)
    X = np.stack([A @ rng.normal(0, 1, (4, len(FEATURES))) * 2 for _ in SENSORS], axis=1)
    X += rng.normal(0, 0.3, X.shape)
    folder = write_plain_dataset(root / "five", CLASSES, trials, sensors=SENSORS, X=X, feature_names=FEATURES)
    pd.DataFrame({"split": "held_out", "object": CLASSES.index,
                  "role": ["test" if c in UNSEEN else "train" for c in CLASSES.index]}).to_csv(
        folder / "splits.csv", index=False)
    common = ("train-attributes", "--plain", folder, "--splits", folder / "splits.csv", "--no-progress")
    _ok(*common, "--method", "eszsl", "--out", root / "eszsl.tzsl")
    _ok(*common, "--method", "sae", "--out", root / "sae.tzsl")
    _ok(*common, "--method", "ale", "--out", root / "ale.tzsl")
    import tzsl.inference.model_bundles as model_bundles

    save = model_bundles.save_zero_shot_bundle

    def keep(path, classifier, *args, **kwargs):  # the fitted DAP model, to compare its arrays with
        TRAINED["dap"] = classifier
        return save(path, classifier, *args, **kwargs)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(model_bundles, "save_zero_shot_bundle", keep)
        _ok(*common, "--method", "dap-avg", "--no-cache", "--out", root / "dap.tzsl")  # the paper's RBF-SVM DAP
    # the same model as tzsl wrote DAP bundles before they were arrays: the estimator, with skops
    zsl = TRAINED["dap"].estimator_
    calibration = {k: v if isinstance(v, str | int) else float(v) for k, v in TRAINED["dap"].calibration_info_.items()}
    save_bundle(root / "dap-skops.tzsl",
                {"model": zsl, "decision_rule": zsl.decision_rule_, "calibration": calibration},
                kind="zero-shot", metadata=read_bundle_header(root / "dap.tzsl").metadata)
    new = trials[trials["class"].isin(UNSEEN)].index
    rows = [{"trial_id": trials.at[i, "trial_id"], "sensor": s, **dict(zip(FEATURES, X[i, j], strict=True))}
            for i in new for j, s in enumerate(SENSORS)]
    pd.DataFrame(rows).to_csv(root / "new.csv", index=False)
    candidates = root / "candidates.csv"
    CLASSES.loc[UNSEEN + ["c0", "c15"]].to_csv(candidates)
    return root, candidates, X[new]


@pytest.mark.parametrize("bundle", ["eszsl", "sae", "dap"])
@pytest.mark.parametrize("mode", ["sc", "df"])
def test_api_grasp_by_grasp_equals_the_command_line(five_fingers, bundle, mode):
    root, candidates, X = five_fingers
    model = root / f"{bundle}.tzsl"
    cli_report = json.loads(_ok("predict", "--model", model, "--classes", candidates, "--multi-grasp", mode,
                                "--k", 2, "--top", 0, "--json", root / "new.csv"))
    recogniser = Recogniser.load(model, candidates, mode=mode, k=2)
    for i, grasp in enumerate(X):  # (n_sensors, n_features) arrays, as a robot has them
        ranking = recogniser.rank(grasp)
        expected = [(r["class"], r["probability"]) for r in cli_report["grasps"][i]["ranking"]]
        assert [c for c, _ in ranking] == [c for c, _ in expected]
        np.testing.assert_allclose([p for _, p in ranking], [p for _, p in expected], rtol=1e-12, atol=1e-15)
        result = recogniser.add(grasp)
    fusion = cli_report["fusion"]
    assert result.decided == fusion["decided"] and result.classes[result.final] == fusion["decision"]
    assert result.n_used == fusion["grasps_used"] and len(result.grasp_ids) == len(X)
    if mode == "df":
        probs = dict(zip(result.classes, result.final_posteriors, strict=True))
        for r in fusion["ranking"]:
            assert probs[r["class"]] == pytest.approx(r["probability"], rel=1e-12, abs=1e-15)


@pytest.mark.parametrize("method, rule", [("eszsl", "compatibility"), ("sae", "nearest-cosine"),
                                          ("ale", "compatibility")])
def test_linear_bundles_are_arrays_and_rank_as_their_estimator(five_fingers, method, rule):
    root, candidates, X = five_fingers
    path = root / f"{method}.tzsl"
    assert read_bundle_header(path).payload_format == "npz"
    predictor = load_predictor(path)
    assert predictor.rule.name == rule and "as arrays" in predictor.describe()
    assert read_bundle_header(root / "dap.tzsl").payload_format == "npz"
    # the arrays rank as the fitted estimator does: refit it in memory the way train-attributes does
    from tzsl.features import load_features
    from tzsl.inference.model_bundles import training_subset
    from tzsl.models.protocol import attribute_rows
    from tzsl.studies.comparison.method_runs import method_input, study_estimator

    sub, _, _ = training_subset(load_features(plain=root / "five"), root / "five" / "splits.csv")
    attributes = list(sub.attributes.columns)
    clf = study_estimator({"name": method}, read_bundle_header(path).metadata["seed"])
    class_rows = sub.attributes.loc[np.unique(sub.objects), attributes].to_numpy(dtype=float)
    clf.fit(method_input({"name": method}, sub.X), attribute_rows(sub.objects, class_rows), sub.objects)
    K = CLASSES.loc[UNSEEN, attributes].to_numpy(dtype=float)
    recogniser = Recogniser.load(path, candidates, candidates=UNSEEN)
    expected = clf.predict_proba(X.reshape(len(X), -1), K)
    got = np.array([[p for _, p in sorted(recogniser.rank(x), key=lambda cp: UNSEEN.index(cp[0]))] for x in X])
    np.testing.assert_allclose(got, expected, rtol=1e-10, atol=1e-14)


_IMPORTS = textwrap.dedent("""
    import sys
    import numpy as np
    from tzsl.inference import Recogniser
    recogniser = Recogniser.load(sys.argv[1], sys.argv[2])
    recogniser.add(np.load(sys.argv[3]))
    print(" ".join(m for m in ("torch", "dask", "sklearn", "skops") if m in sys.modules))
""")


@pytest.mark.parametrize("bundle, absent", [("eszsl", {"torch", "dask", "sklearn", "skops"}),
                                            ("dap", {"torch", "dask", "sklearn", "skops"}),
                                            ("dap-skops", {"torch", "dask"})])
def test_loading_and_ranking_does_not_import_torch(five_fingers, tmp_path, bundle, absent):
    """Linear and DAP bundles need numpy alone; skops bundles need scikit-learn, never torch (deep bundles do)."""
    root, candidates, X = five_fingers
    np.save(tmp_path / "grasp.npy", X[0])
    done = subprocess.run([sys.executable, "-c", _IMPORTS, str(root / f"{bundle}.tzsl"), str(candidates),
                           str(tmp_path / "grasp.npy")], capture_output=True, text=True, cwd=REPO,
                          env={"PYTHONPATH": str(REPO), "PATH": ""}, check=False)
    assert done.returncode == 0, done.stderr
    imported = set(done.stdout.split())
    assert not imported & absent, f"loading a {bundle} bundle imported {sorted(imported & absent)}"


def test_skops_import_leaves_torch_importable_afterwards(tmp_path):
    code = ("import sys; from tzsl.inference.skops_bundles import skops_io; skops_io(); "
            "assert 'torch' not in sys.modules; "
            "import importlib.util; print(importlib.util.find_spec('torch') is not None and 'ok')")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=REPO,
                          env={"PYTHONPATH": str(REPO), "PATH": ""}, check=False)
    assert done.returncode == 0 and done.stdout.strip() in ("ok", "False"), done.stderr


def test_api_errors_are_one_line(five_fingers, tmp_path):
    root, candidates, X = five_fingers
    recogniser = Recogniser.load(root / "eszsl.tzsl", candidates)
    with pytest.raises(ConfigError, match="no grasp added yet"):
        recogniser.prediction()
    with pytest.raises(ConfigError, match=r"shape \(4, 6\); the model needs \(5, 6\)"):
        recogniser.rank(X[0][:4])
    bad = X[0].copy()
    bad[1, 2] = np.nan
    with pytest.raises(ConfigError, match="NaN or infinite"):
        recogniser.add(bad)
    with pytest.raises(ConfigError, match="needs a per-EP bundle"):
        recogniser.suggest_next_ep({"squeeze": X[0]})
    with pytest.raises(ConfigError, match="fusion mode"):
        Recogniser.load(root / "eszsl.tzsl", candidates, mode="vote")


@pytest.mark.parametrize("tree, message", [
    ({"linear": {"weights": np.zeros((30, 3))}, "rule": {"name": np.asarray("compatibility")}}, "for 4 attributes"),
    ({"linear": {"weights": np.zeros((30, 4))}, "rule": {"name": np.asarray("exec")}}, "unknown rule 'exec'"),
    ({"linear": {"weights": np.zeros((30, 4)), "mean": np.zeros(30)}, "rule": {"name": np.asarray("compatibility")}},
     "mean and scale come together"),
    ({"linear": {"weights": np.full((30, 4), np.nan)}, "rule": {"name": np.asarray("compatibility")}}, "NaN"),
    ({"weights": np.zeros((30, 4))}, "needs linear/weights and rule/name"),
])
def test_bad_linear_payload_is_one_line(five_fingers, tmp_path, tree, message):
    root, candidates, _ = five_fingers
    metadata = dict(read_bundle_header(root / "eszsl.tzsl").metadata)
    path = save_bundle(tmp_path / "bad.tzsl", tree, kind="zero-shot", metadata=metadata)
    with pytest.raises(ModelBundleError, match=message) as info:
        Recogniser.load(path, candidates)
    assert str(path) in str(info.value) and "\n" not in str(info.value)


# ---------------------------------------------------------------------------- active touch
def _per_ep_features(seed: int, objects: list[str], A: np.ndarray, n_trials: int) -> FeatureSet:
    """SIMULATED: squeeze features follow hard/soft, hold features follow rough; two sensors alike."""
    rng = np.random.default_rng(seed)
    rows = [(o, t) for o in objects for t in range(n_trials)]
    attrs = pd.DataFrame(A, index=pd.Index(objects, name="object_name"), columns=["hard", "soft", "rough"])
    a = attrs.loc[[o for o, _ in rows]].to_numpy(dtype=float)
    X = np.column_stack([2 * a[:, 0], 2 * a[:, 1], 2 * a[:, 2], -2 * a[:, 2]])
    X = np.stack([X + rng.normal(0, 0.4, X.shape) for _ in range(2)], axis=1)
    trials = pd.DataFrame({"trial_id": [f"{o}_{t}" for o, t in rows], "object_id": [objects.index(o) for o, _ in rows],
                           "object_name": [o for o, _ in rows], "trial_index": [t for _, t in rows]})
    names = tuple(f"{ep}:{f}" for ep in ("squeeze", "hold") for f in ("a", "b"))
    return FeatureSet(X=X, trials=trials, sensors=("finger_0", "finger_1"), feature_names=names, attributes=attrs,
                      dataset="simulated")


def test_suggest_next_ep_equals_the_command_line(tmp_path):
    A = np.array([[1, 0, 0], [0, 1, 0], [1, 0, 1], [0, 1, 1], [1, 1, 0], [0, 0, 1], [1, 1, 1], [0, 0, 0]])
    train_per_ep_bundle(_per_ep_features(0, [f"tr{i}" for i in range(len(A))], A, 5), tmp_path / "per_ep.tzsl",
                        seed=0, cv=3)
    pd.DataFrame({"class": ["u0", "u1", "u2"], "hard": [1, 0, 1], "soft": [0, 1, 0], "rough": [1, 1, 0]}).to_csv(
        tmp_path / "classes.csv", index=False)
    test = _per_ep_features(1, ["u0"], np.array([[1, 0, 1]]), 1)
    pd.DataFrame([{"trial_id": "t0", "sensor": s, "squeeze:a": test.X[0, j, 0], "squeeze:b": test.X[0, j, 1]}
                  for j, s in enumerate(test.sensors)]).to_csv(tmp_path / "squeeze.csv", index=False)
    cli_report = json.loads(_ok("predict", "--model", tmp_path / "per_ep.tzsl", "--classes", tmp_path / "classes.csv",
                                "--eps-done", "squeeze", "--suggest-next", "--json", tmp_path / "squeeze.csv"))
    recogniser = Recogniser.load(tmp_path / "per_ep.tzsl", tmp_path / "classes.csv")
    report = recogniser.suggest_next_ep({"squeeze": test.X[0, :, :2]}, trial="t0")
    assert report == cli_report
    with pytest.raises(ConfigError, match="suggest_next_ep"):
        recogniser.rank(test.X[0])
    with pytest.raises(ConfigError, match=r"EP 'hold': features of shape \(2, 3\)"):
        recogniser.suggest_next_ep({"hold": np.zeros((2, 3))})


def test_the_user_guide_example_runs(tmp_path, monkeypatch, capsys):
    """The Python example of docs/user_guide/predict.md, on a SIMULATED feature dataset named as it says."""
    text = (REPO / "docs" / "user_guide" / "predict.md").read_text(encoding="utf-8")
    example = text.split("## On a robot", 1)[1].split("```python\n", 1)[1].split("```", 1)[0]
    rng = np.random.default_rng(3)
    names = ["mug", "sponge", "cup", "brick", "towel", "can", "ball", "box"]
    classes = pd.DataFrame(list(itertools.product([0, 1], repeat=3)), columns=["hard", "soft", "round"],
                           index=pd.Index(names, name="class"))
    objects = ["sponge"] * 4 + names  # the first grasps are of a sponge
    trials = pd.DataFrame({"trial_id": [f"t{i}" for i in range(len(objects))], "class": objects})
    A = classes.loc[trials["class"]].to_numpy(dtype=float)
    mix = rng.normal(0, 1, (3, 5))
    X = np.stack([A @ mix * 2 + rng.normal(0, 0.2, (len(A), 5)) for _ in range(2)], axis=1)
    write_plain_dataset(tmp_path / "my_dataset", classes, trials, sensors=("left", "right"), X=X,
                        feature_names=[f"f{i}" for i in range(5)])
    monkeypatch.chdir(tmp_path)
    _ok("train-attributes", "--plain", "my_dataset", "--method", "eszsl", "--out", "model.tzsl")
    exec(compile(example, "predict.md", "exec"), {})
    out = capsys.readouterr().out
    assert "decided sponge after 3 grasps" in out, out


def test_command_line_defaults_are_the_apis():
    """``tzsl predict`` types its defaults in its options (its module stays light for ``tzsl --help``)."""
    from tzsl.inference.recogniser import DEFAULT_FUSION, DEFAULT_K, FUSION_MODES

    options = {p.name: p for p in cli.commands["predict"].params}
    assert options["mode"].default == DEFAULT_FUSION and list(options["mode"].type.choices) == list(FUSION_MODES)
    assert options["k"].default == DEFAULT_K


# ---------------------------------------------------------------------------- DAP bundles as arrays
def test_dap_bundle_is_arrays_with_its_estimators_posteriors(five_fingers):
    """The trained bundle's arrays give the fitted bank's posteriors and the calibrated class posteriors."""
    from tzsl.inference.detector_bundles import DAPArrayRule, DetectorBank

    root, candidates, X = five_fingers
    predictor = load_predictor(root / "dap.tzsl")
    assert isinstance(predictor.model, DetectorBank) and isinstance(predictor.rule, DAPArrayRule)
    assert "as arrays" in predictor.describe() and "skops" not in predictor.describe()
    clf = TRAINED["dap"]
    random = np.random.default_rng(1).normal(0, 3, (40, *X.shape[1:]))
    for grasps in (X, random):
        expected = clf.estimator_.attribute_scores(grasps)
        np.testing.assert_allclose(predictor.model.attribute_scores(grasps), expected, rtol=0, atol=1e-12)
    K = CLASSES.loc[UNSEEN + ["c0", "c15"], predictor.attribute_names].to_numpy()
    recogniser = Recogniser.load(root / "dap.tzsl", candidates)
    got = np.array([[dict(recogniser.rank(x))[c] for c in UNSEEN + ["c0", "c15"]] for x in X])
    np.testing.assert_allclose(got, clf.predict_proba(X, K), rtol=0, atol=1e-12)


def test_dap_bundle_written_with_skops_still_loads_and_ranks_as_the_arrays(five_fingers):
    from tzsl.inference.detector_bundles import DetectorBank

    root, candidates, X = five_fingers
    assert read_bundle_header(root / "dap-skops.tzsl").payload_format == "skops"
    old = Recogniser.load(root / "dap-skops.tzsl", candidates)
    assert isinstance(old.predictor.model, DetectorBank)
    assert "read from skops: re-save the model" in old.predictor.describe()
    new = Recogniser.load(root / "dap.tzsl", candidates)
    for x in X:
        assert old.rank(x) == new.rank(x)


def _tree(path: Path) -> dict:
    from tzsl.inference.bundle import load_bundle

    return load_bundle(path)[0]


@pytest.mark.parametrize("change, message", [
    (lambda t: t["detectors"].update(family=np.asarray("exec")), "family 'exec' is not one of"),
    (lambda t: t["detectors"].update(shape=np.asarray([3, 5, 6])), r"shape must be \(n_attributes = 4"),
    (lambda t: t["detectors"].update(mean=t["detectors"]["mean"][:, :3]), r"mean has shape \(20, 3\)"),
    (lambda t: t["detectors"]["platt"].__setitem__((0, 0), np.nan), "platt holds NaN"),
    (lambda t: t["detectors"].update(n_vectors=t["detectors"]["n_vectors"] + 1), "must hold n_vectors"),
    (lambda t: t["detectors"].update(gamma=-t["detectors"]["gamma"]), "gamma must be positive"),
    (lambda t: t["rule"].update(prior=np.asarray("oracle")), "prior 'oracle'"),
    (lambda t: t.pop("rule"), "rule/name = 'dap'"),
])
def test_bad_detector_payload_is_one_line(five_fingers, tmp_path, change, message):
    root, candidates, _ = five_fingers
    tree = _tree(root / "dap.tzsl")
    change(tree)
    path = save_bundle(tmp_path / "bad.tzsl", tree, kind="zero-shot",
                       metadata=read_bundle_header(root / "dap.tzsl").metadata)
    with pytest.raises(ModelBundleError, match=message) as info:
        Recogniser.load(path, candidates)
    assert str(info.value).startswith(f"{path}: detector arrays: ") and "\n" not in str(info.value)


def test_tampered_dap_bundle_is_refused_in_one_line(five_fingers, tmp_path):
    root, candidates, _ = five_fingers
    data = bytearray((root / "dap.tzsl").read_bytes())
    data[-200] ^= 0xFF  # one byte of the arrays
    (tmp_path / "tampered.tzsl").write_bytes(bytes(data))
    done = CliRunner().invoke(cli, ["predict", "--model", str(tmp_path / "tampered.tzsl"), "--classes",
                                    str(candidates), str(root / "new.csv")])
    assert done.exit_code == 3
    assert done.output.strip().count("\n") == 0 and "checksum mismatch" in done.output, done.output


def test_any_malformed_detector_array_is_a_bundle_error(five_fingers):
    """Every array of a DAP payload replaced by a group, a text or a wrong shape: a one-line ModelBundleError
    (only the display name falls back to its default), never another exception."""
    import copy

    from tzsl.inference import zero_shot_bundles

    root, _, _ = five_fingers
    tree = _tree(root / "dap.tzsl")
    tree["calibration"] = {"temperature": np.asarray(1.5)}
    metadata = {**read_bundle_header(root / "dap.tzsl").metadata, "bundle": {"path": "model.tzsl"}}
    places = [(group, key) for group in ("detectors", "rule", "calibration") for key in tree[group]]
    places += [(None, "estimator"), (None, "calibration")]
    for group, key in places:
        for bad in ({"x": np.zeros(1)}, np.asarray("x"), np.zeros((2, 2, 2))):
            broken = copy.deepcopy(tree)
            (broken if group is None else broken[group])[key] = bad
            try:
                zero_shot_bundles._checked(zero_shot_bundles._read_arrays(broken, metadata, "model.tzsl"), metadata)
            except ModelBundleError as exc:
                assert str(exc).startswith("model.tzsl: ") and "\n" not in str(exc), (group, key, exc)
            else:
                assert (group, key) == (None, "estimator"), (group, key, bad)
