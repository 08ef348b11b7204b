"""Predict from saved bundles: class tables, hand grasps (SC-MDAP / DF-MDAP) and PHAC-2 feature tables."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy.special import softmax

from tzsl.datasets import FeatureSet, load_hand_table4, read_grasps, simulate_grasps
from tzsl.datasets._feature_table import write_feature_table
from tzsl.exceptions import ConfigError, DataFileError, ModelBundleError
from tzsl.features import grasp_features
from tzsl.inference.bundle import load_bundle, save_bundle
from tzsl.inference.bundle_kinds import ZERO_SHOT_KIND
from tzsl.inference.model_bundles import train_hand_bundle
from tzsl.inference.predict import format_prediction, read_class_table
from tzsl.inference.recogniser import predict_grasps
from tzsl.inference.zero_shot_bundles import load_predictor, save_model_bundle, save_zero_shot_bundle
from tzsl.models import (
    AttributeClassifierBank,
    AttributeSVM,
    DAPRule,
    ZeroShotClassifier,
)
from tzsl.models.dap import attribute_prior, dap_log_scores, fuse_attribute_posteriors
from tzsl.models.multigrasp import df_mdap_log_scores, sc_mdap
from tzsl.studies.config import HandSettings
from tzsl.studies.hand.study import feature_params

TABLE = load_hand_table4()
TABLE4_CSV = TABLE.source  # the shipped Table 4 file works as a class table


@pytest.fixture(scope="module")
def hand(tmp_path_factory):
    root = tmp_path_factory.mktemp("hand")
    simulate_grasps(TABLE.K, 20, random_state=1, folder=root / "grasps")
    model, meta = train_hand_bundle(root / "grasps", TABLE, root / "model.tzsl", seed=0)
    classes = root / "classes.csv"
    TABLE.K.loc[TABLE.test_objects].rename_axis("object").to_csv(classes)
    return root, model, meta, classes


# ---------------------------------------------------------------------------- class table
def test_class_table_from_table4_file_keeps_model_order():
    names = ["plastic", "porcelain", "cardboard", "glass", "steel", "concave", "cylindrical", "round",
             "rectangular", "has_handle", "has_narrow_part"]
    K = read_class_table(TABLE4_CSV, names)
    assert list(K.columns) == names and len(K) == 16
    assert K.loc["salter", "steel"] == 1 and K.loc["salter", "plastic"] == 0


@pytest.mark.parametrize("text, message", [
    ("name,hard,soft\na,1,0\n", "missing attribute column(s) ['round']"),
    ("name,hard,soft,round,furry\na,1,0,1,0\n", "unknown attribute column(s) ['furry']"),
    ("name,hard,soft,round\na,1,0,2\n", "class 'a', attribute 'round': value '2' is not 0 or 1"),
    ("name,hard,soft,round\na,1,0,\n", "class 'a', attribute 'round'"),
    ("name,hard,soft,round\na,1,0,1\na,0,1,0\n", "duplicate class name(s) ['a']"),
    ("name\n", "needs a class-name column"),
])
def test_class_table_errors_name_file_and_problem(tmp_path, text, message):
    path = tmp_path / "classes.csv"
    path.write_text(text)
    with pytest.raises(DataFileError) as err:
        read_class_table(path, ["hard", "soft", "round"])
    assert message in str(err.value) and str(path) in str(err.value)


def test_missing_class_table(tmp_path):
    with pytest.raises(DataFileError, match="not found"):
        read_class_table(tmp_path / "nope.csv", ["a"])


# ---------------------------------------------------------------------------- hand bundles
def _direct(model, files, K):
    """Per-grasp LDAP posteriors and decisions computed without the predict module."""
    grasps = [g for f in files for g in read_grasps(f.parent, [f.stem])]
    feats = grasp_features(grasps, **feature_params(HandSettings()))
    P = model.predict_attribute_proba(feats.to_array(), "ldap")
    scores = dap_log_scores(P, K.to_numpy(dtype=float), np.full(P.shape[1], 0.5))
    return P, scores


def test_bundle_metadata(hand):
    root, model, meta, _ = hand
    loaded, got = load_bundle(root / "model.tzsl", expected_kind=ZERO_SHOT_KIND)
    assert got["attribute_names"] == list(model.K_.columns)
    assert got["training_objects"] == TABLE.train_objects
    assert got["n_training_grasps"] == 6 * 20 and got["n_ignored_grasps"] == 10 * 20
    assert got["input"]["format"] == "hand-grasps" and got["input"]["feature_params"]["contact_threshold"] == 20.0
    assert got["method"] == "hand-dap" and isinstance(loaded["decision_rule"], DAPRule)


@pytest.mark.parametrize("k", [1, 2, 3])
def test_sc_mdap_decision_matches_sc_mdap_directly(hand, k):
    root, model, _, classes = hand
    files = [root / "grasps" / f"measuring_cup_{i:03d}.npz" for i in range(8)]
    predictor = load_predictor(root / "model.tzsl")
    K = read_class_table(classes, predictor.attribute_names)
    pred = predict_grasps(predictor, K, files, mode="sc", k=k)
    _, scores = _direct(model, files, K)
    decisions = scores.argmax(axis=1)
    d, used, ok = sc_mdap(decisions[None], k)
    np.testing.assert_array_equal(pred.decisions, decisions)
    assert (pred.final, pred.n_used, pred.decided) == (int(d[0]), int(used[0]), bool(ok[0]))
    np.testing.assert_allclose(pred.grasp_posteriors, softmax(scores, axis=1))
    text = format_prediction(pred)
    assert f"SC-MDAP (k={k}): decided {pred.classes[pred.final]!r} after grasp {pred.n_used} of 8" in text


def test_sc_mdap_says_when_not_decided(hand):
    root, _, _, classes = hand
    files = [root / "grasps" / f"jar_{i:03d}.npz" for i in range(2)]
    predictor = load_predictor(root / "model.tzsl")
    pred = predict_grasps(predictor, read_class_table(classes, predictor.attribute_names), files, k=5)
    assert not pred.decided and pred.n_used == 2
    assert "SC-MDAP (k=5): NOT decided after 2 grasps" in format_prediction(pred)


def test_df_mdap_matches_eqs_11_12(hand):
    root, model, _, classes = hand
    files = [root / "grasps" / f"salter_{i:03d}.npz" for i in range(5)]
    predictor = load_predictor(root / "model.tzsl")
    K = read_class_table(classes, predictor.attribute_names)
    pred = predict_grasps(predictor, K, files, mode="df")
    P, _ = _direct(model, files, K)
    for t in range(1, 6):
        expected = df_mdap_log_scores(P[None, :t], K.to_numpy()).argmax(axis=1)[0]
        assert pred.running[t - 1] == expected
    assert pred.final == pred.running[-1] and pred.decided and pred.n_used == 5
    assert pred.final_posteriors.sum() == pytest.approx(1.0)
    assert "DF-MDAP: decided" in format_prediction(pred)


def test_grasp_folder_input_and_no_contact_grasp_skipped(hand, tmp_path):
    root, _, _, classes = hand
    with np.load(root / "grasps" / "ball_000.npz") as npz:
        arrays = {k: npz[k] for k in npz.files}
    for i in range(5):  # nothing touched: flat static pressure
        arrays[f"f{i}_pdc"] = np.full_like(arrays[f"f{i}_pdc"], 2000.0)
    np.savez(tmp_path / "air.npz", **arrays)
    predictor = load_predictor(root / "model.tzsl")
    K = read_class_table(classes, predictor.attribute_names)
    pred = predict_grasps(predictor, K, [tmp_path / "air.npz", root / "grasps" / "ball_001.npz"], k=1)
    assert pred.grasp_ids == ["ball_001"]
    assert "skipped grasp air" in format_prediction(pred)
    with pytest.raises(DataFileError, match="no grasp with a touching BioTac"):
        predict_grasps(predictor, K, [tmp_path / "air.npz"])


@pytest.mark.parametrize("name, content, message", [
    ("g.csv", b"a,b\n", "grasp .npz file or a grasp folder"),
    ("g.npz", b"not a zip", "not a readable .npz archive"),
])
def test_bad_grasp_files(hand, tmp_path, name, content, message):
    root, _, _, classes = hand
    (tmp_path / name).write_bytes(content)
    predictor = load_predictor(root / "model.tzsl")
    with pytest.raises(DataFileError, match=message):
        predict_grasps(predictor, read_class_table(classes, predictor.attribute_names), [tmp_path / name])


def test_bad_mode_and_k(hand):
    root, _, _, classes = hand
    predictor = load_predictor(root / "model.tzsl")
    K = read_class_table(classes, predictor.attribute_names)
    with pytest.raises(ConfigError, match="'sc'"):
        predict_grasps(predictor, K, [], mode="vote")
    with pytest.raises(ConfigError, match="k must"):
        predict_grasps(predictor, K, [], k=0)


def test_unknown_kind_and_wrong_payload(tmp_path):
    save_bundle(tmp_path / "x.tzsl", {"w": 1}, kind="mystery")
    with pytest.raises(ModelBundleError, match="no predictor for bundles of kind 'mystery'"):
        load_predictor(tmp_path / "x.tzsl")
    save_bundle(tmp_path / "y.tzsl", {"w": 1}, kind=ZERO_SHOT_KIND,
                metadata={"attribute_names": [], "input": {"format": "hand-grasps", "feature_params": {}}})
    with pytest.raises(ModelBundleError, match="holds"):
        load_predictor(tmp_path / "y.tzsl")


# ---------------------------------------------------------------------------- PHAC-2 bundles
def _phac2_features(seed: int, objects: list[str], A: np.ndarray, n_trials: int = 4) -> FeatureSet:
    """Synthetic 2-BioTac trials whose 5 features shift with the object's 3 attributes."""
    rng = np.random.default_rng(seed)
    rows = [(o, t) for o in objects for t in range(n_trials)]
    attrs = pd.DataFrame(A, index=pd.Index(objects, name="object_name"), columns=["hard", "soft", "rough"])
    signal = np.array([[2.0, 0, 0, 1, 0], [0, 2.0, 0, 0, 1], [0, 0, 2.0, 1, 1]])
    X = attrs.loc[[o for o, _ in rows]].to_numpy() @ signal
    X = np.stack([X + rng.normal(0, 0.5, X.shape), 1.5 * X + rng.normal(0, 0.5, X.shape)], axis=1)
    trials = pd.DataFrame({
        "trial_id": [f"{o}_{t:02d}" for o, t in rows],
        "object_id": [objects.index(o) for o, _ in rows],
        "object_name": [o for o, _ in rows],
        "trial_index": [t for _, t in rows],
    })
    return FeatureSet(X=X, trials=trials, sensors=("finger_0", "finger_1"),
                      feature_names=tuple(f"f{i}" for i in range(5)), attributes=attrs, dataset="synthetic")


@pytest.fixture(scope="module")
def phac2(tmp_path_factory):
    root = tmp_path_factory.mktemp("phac2")
    train_objects = [f"tr{i}" for i in range(6)]
    A_train = np.array([[1, 0, 1], [1, 0, 0], [0, 1, 1], [0, 1, 0], [1, 1, 1], [0, 0, 0]])
    train = _phac2_features(0, train_objects, A_train)
    svm = AttributeSVM(n_C=1, n_gamma=1, n_draws=1, cv=2, undersampling="none", random_state=0)
    bank = AttributeClassifierBank(estimator=svm, attribute_names=["hard", "soft", "rough"], n_jobs=1, random_state=0)
    clf = ZeroShotClassifier(attribute_model=bank, decision_rule=DAPRule(fusion="avg", prior="train"))
    clf.fit(train.X, train.trial_attributes(), train.trials["object_name"])
    prior = attribute_prior("train", train_attributes=train.trial_attributes(), groups=train.objects)
    np.testing.assert_allclose(clf.decision_rule_.train_prior_, prior)
    path = save_zero_shot_bundle(root / "phac2.tzsl", clf, train, method="dap-avg", ndim=3,
                                 training_objects=train_objects)
    bank = clf.attribute_model_
    test = _phac2_features(1, ["te0", "te1"], np.array([[1, 0, 1], [0, 1, 0]]), n_trials=3)
    write_feature_table(test, root / "test.npz")
    write_feature_table(test, root / "test.csv")
    classes = root / "classes.csv"
    pd.DataFrame({"object": ["te0", "te1", "te2"], "hard": [1, 0, 1], "soft": [0, 1, 1],
                  "rough": [1, 0, 0]}).to_csv(classes, index=False)
    return root, bank, prior, test, path, classes, clf


def test_phac2_bundle_predicts_like_the_bank(phac2):
    root, bank, prior, test, path, classes, _ = phac2
    predictor = load_predictor(path)
    assert predictor.kind == ZERO_SHOT_KIND and predictor.attribute_names == ["hard", "soft", "rough"]
    assert predictor.metadata["input"] == {"format": "features", "sensors": ["finger_0", "finger_1"],
                                           "feature_names": [f"f{i}" for i in range(5)], "ndim": 3}
    K = read_class_table(classes, predictor.attribute_names)
    pred = predict_grasps(predictor, K, [root / "test.npz"], mode="sc", k=2)
    present, absent = fuse_attribute_posteriors(bank.predict_proba(test.X), "avg")
    scores = dap_log_scores(present, K.to_numpy(dtype=float), prior, P_absent=absent)
    np.testing.assert_allclose(pred.grasp_posteriors, softmax(scores, axis=1))
    assert pred.grasp_ids == list(test.trials["trial_id"])
    d, used, ok = sc_mdap(scores.argmax(axis=1)[None], 2)
    assert (pred.final, pred.n_used, pred.decided) == (int(d[0]), int(used[0]), bool(ok[0]))
    # the CSV form of the same table, and DF-MDAP over all six trials
    same = predict_grasps(predictor, K, [root / "test.csv"], mode="sc", k=2)
    np.testing.assert_allclose(same.grasp_posteriors, pred.grasp_posteriors)
    df = predict_grasps(predictor, K, [root / "test.npz"], mode="df")
    expected = dap_log_scores(present.mean(0, keepdims=True), K.to_numpy(dtype=float), prior,
                              P_absent=absent.mean(0, keepdims=True)).argmax()
    assert df.final == expected


def test_phac2_sensor_order_and_missing_features(phac2, tmp_path):
    root, bank, prior, test, path, classes, _ = phac2
    predictor = load_predictor(path)
    K = read_class_table(classes, predictor.attribute_names)
    swapped = FeatureSet(X=test.X[:, ::-1, ::-1], trials=test.trials, sensors=test.sensors[::-1],
                         feature_names=test.feature_names[::-1], attributes=test.attributes)
    write_feature_table(swapped, tmp_path / "swapped.npz")
    a = predict_grasps(predictor, K, [root / "test.npz"])
    b = predict_grasps(predictor, K, [tmp_path / "swapped.npz"])
    np.testing.assert_allclose(a.grasp_posteriors, b.grasp_posteriors)
    fewer = FeatureSet(X=test.X[:, :, :4], trials=test.trials, sensors=test.sensors,
                       feature_names=test.feature_names[:4], attributes=test.attributes)
    write_feature_table(fewer, tmp_path / "fewer.npz")
    with pytest.raises(DataFileError, match=r"feature column\(s\) the model needs are missing, e.g. \['f4'\]"):
        predict_grasps(predictor, K, [tmp_path / "fewer.npz"])


def test_bundle_contents_are_checked(phac2, tmp_path):
    _, bank, _, test, path, _, clf = phac2
    payload, meta = load_bundle(path)
    meta.pop("bundle")
    assert set(payload) == {"detectors", "rule", "estimator"}  # a DAP model is stored as arrays
    payload, rule = {"model": clf}, clf.decision_rule_
    with pytest.raises(ConfigError, match="2 attribute names for a rule over 3"):
        save_model_bundle(tmp_path / "a.tzsl", payload["model"], rule, method="x", attribute_names=["a", "b"],
                          input_schema=meta["input"])
    with pytest.raises(ConfigError, match="no attribute_scores"):
        save_model_bundle(tmp_path / "b.tzsl", bank, rule, method="x", attribute_names=["a", "b", "c"],
                          input_schema=meta["input"])
    save_bundle(tmp_path / "c.tzsl", {"model": payload["model"], "decision_rule": rule}, kind=ZERO_SHOT_KIND,
                metadata={"attribute_names": ["hard"]})
    with pytest.raises(ModelBundleError, match="lacks"):
        load_predictor(tmp_path / "c.tzsl")
    save_bundle(tmp_path / "d.tzsl", bank, kind=ZERO_SHOT_KIND, metadata=meta)
    with pytest.raises(ModelBundleError, match="holds"):
        load_predictor(tmp_path / "d.tzsl")


# ---------------------------------------------------------------------------- bad inputs through the CLI
def _cli(*args):
    from click.testing import CliRunner

    from tzsl.cli import cli
    return CliRunner().invoke(cli, [str(a) for a in args])


def _one_line_error(result, path):
    from tzsl.cli import EXIT_TZSL_ERROR

    assert result.exit_code == EXIT_TZSL_ERROR, result.output
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and str(path) in lines[0] and "Traceback" not in result.output, result.stderr
    return lines[0]


def _lying_npz(path, shape):
    import io
    import zipfile

    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(buf, {"descr": "<f8", "fortran_order": False, "shape": shape})
    with zipfile.ZipFile(path, "w") as zf:
        zf.writestr("X.npy", buf.getvalue() + b"\0" * 64)
    return path


def test_predict_cli_bad_feature_files_are_one_line(phac2, tmp_path):
    root, _, _, _, model, classes, _ = phac2
    truncated = tmp_path / "truncated.npz"
    truncated.write_bytes((root / "test.npz").read_bytes()[:300])
    assert "not a readable .npz archive" in _one_line_error(_cli("predict", "--model", model, "--classes", classes,
                                                                 truncated), truncated)
    huge = _lying_npz(tmp_path / "huge.npz", (10**7, 10**6))
    assert "TZSL_MAX_NPZ_BYTES" in _one_line_error(_cli("predict", "--model", model, "--classes", classes, huge), huge)
    binary = tmp_path / "binary.csv"
    binary.write_bytes(bytes(range(256)) * 16)
    assert "not a UTF-8 text file" in _one_line_error(_cli("predict", "--model", model, "--classes", classes,
                                                           binary), binary)


def test_predict_cli_old_pickle_bundle_needs_trust_pickle(phac2, tmp_path):
    import hashlib
    import io
    import json

    import joblib

    import tzsl

    root, bank, _, _, model, classes, clf = phac2
    raw = model.read_bytes()
    header = json.loads(raw.split(b"\n")[1])
    buf = io.BytesIO()
    joblib.dump({"model": clf, "decision_rule": clf.decision_rule_}, buf)  # the same model + decision rule, pickled
    payload = buf.getvalue()
    header = {k: v for k, v in header.items() if k not in ("header_sha256", "hmac_sha256", "payload_format")}
    header.update(format_version=1, tzsl_version=tzsl.__version__, payload_bytes=len(payload),
                  payload_sha256=hashlib.sha256(payload).hexdigest())
    header["header_sha256"] = hashlib.sha256(
        json.dumps(header, sort_keys=True, separators=(",", ":")).encode()).hexdigest()
    old = tmp_path / "old.tzsl"
    old.write_bytes(b"TZSL-MODEL-BUNDLE\n" + json.dumps(header).encode() + b"\n" + payload)
    message = _one_line_error(_cli("predict", "--model", old, "--classes", classes, root / "test.npz"), old)
    assert "--out" in message and "--trust-pickle" in message
    trusted = _cli("predict", "--model", old, "--classes", classes, "--trust-pickle", root / "test.npz")
    assert trusted.exit_code == 0, trusted.output
    fresh = _cli("predict", "--model", model, "--classes", classes, root / "test.npz")
    assert trusted.stdout.splitlines()[1:] == fresh.stdout.splitlines()[1:]


def test_predict_cli_refuses_crafted_bundle(phac2, tmp_path):
    import hashlib
    import json
    import os

    import skops.io as sio

    root, _, _, _, model, classes, _ = phac2
    header = json.loads(model.read_bytes().split(b"\n")[1])
    payload = sio.dumps({"f": os.system})
    header = {k: v for k, v in header.items() if k not in ("header_sha256", "hmac_sha256")}
    header.update(payload_bytes=len(payload), payload_sha256=hashlib.sha256(payload).hexdigest(),
                  payload_format="skops")
    header["header_sha256"] = hashlib.sha256(
        json.dumps(header, sort_keys=True, separators=(",", ":")).encode()).hexdigest()
    evil = tmp_path / "evil.tzsl"
    evil.write_bytes(b"TZSL-MODEL-BUNDLE\n" + json.dumps(header).encode() + b"\n" + payload)
    assert "does not trust: posix.system" in _one_line_error(
        _cli("predict", "--model", evil, "--classes", classes, root / "test.npz"), evil)


def test_simulate_grasps_out_under_a_file_is_one_line(tmp_path):
    (tmp_path / "afile").write_text("x")
    out = tmp_path / "afile" / "grasps"
    assert "cannot create the grasp folder" in _one_line_error(
        _cli("simulate-grasps", "--out", out, "--grasps-per-object", 1), out)
