"""Fuzz: broken plain-file datasets, grasp folders and model bundles never end in a traceback.

Each example starts from a valid input, applies one random damage (random bytes, truncation, a
cell replaced by hostile text such as ``../x`` or ``nan``, a trailing comma, a deleted file, a
symlink pointing outside, a header field of the wrong JSON type, ...) and runs the command. It
must exit 0, or exit with tzsl's error code (2 = click usage, 3 = bad input; older builds used 2
for both) with exactly one line on stderr naming the offending path; never a traceback, and it
must not create or change any file (these commands write nothing).

Grasp folders are also given to ``tzsl predict`` with a trained hand bundle.
Experiment files (TOML) are damaged the same way (bytes, truncation, a line dropped or doubled,
a value replaced by a hostile one, an unknown key) and given to ``tzsl run FILE --check``, which
reads the dataset and split file but fits nothing; besides the rules above, no file may appear
anywhere (the check writes nothing, not even under ``--out``).

Bounded: ``max_examples`` per property keeps the suite under a minute.
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tzsl.cli import EXIT_TZSL_ERROR, cli
from tzsl.datasets import read_grasps, write_plain_dataset
from tzsl.exceptions import TzslError

# CI: 25 fixed examples per property; TZSL_FUZZ_EXAMPLES=500 explores with fresh random examples
_EXPLORE = os.environ.get("TZSL_FUZZ_EXAMPLES")
FUZZ = settings(max_examples=int(_EXPLORE or 25), deadline=None, suppress_health_check=[HealthCheck.too_slow],
                derandomize=not _EXPLORE)
ERROR_CODES = {EXIT_TZSL_ERROR, 2, 3}
HOSTILE = ["", "../x.npz", "/etc/passwd", "signals/../../x.csv", "nan", "inf", "-1e400", "0x1", "é", "\x00",
           "1,2", '"', "a" * 300, "1.0", "2", "yes", "C:\\x.npz", "signals/t1.npz"]


def _tree(root: Path) -> dict[str, tuple[int, int]]:
    return {str(p.relative_to(root)): (p.lstat().st_size, p.lstat().st_mtime_ns) for p in root.rglob("*")}


def _check(result, path: Path, before: dict, root: Path) -> None:
    assert result.exception is None or isinstance(result.exception, SystemExit), repr(result.exception)
    assert "Traceback" not in result.output
    assert _tree(root) == before, "a file was created or changed"
    if result.exit_code == 0:
        return
    assert result.exit_code in ERROR_CODES, result.output
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert str(path) in lines[0], lines[0]


# ------------------------------------------------------------------ damage
def _damage(folder: Path, files: list[str], data: st.DataObject) -> None:
    name = data.draw(st.sampled_from(files), label="file")
    path = folder / name
    kind = data.draw(st.sampled_from(["bytes", "truncate", "cell", "trailing_comma", "delete", "line",
                                      "symlink_out", "empty"]), label="damage")
    raw = path.read_bytes() if path.is_file() else b""
    if kind == "bytes":
        path.write_bytes(data.draw(st.binary(min_size=0, max_size=200), label="bytes"))
    elif kind == "truncate":
        path.write_bytes(raw[: data.draw(st.integers(0, max(0, len(raw) - 1)), label="cut")])
    elif kind == "empty":
        path.write_bytes(b"")
    elif kind == "delete":
        path.unlink()
    elif kind == "symlink_out":
        outside = folder.parent / f"outside{path.suffix}"
        outside.write_bytes(raw)
        path.unlink()
        os.symlink(outside, path)
    elif path.suffix == ".csv":
        lines = raw.decode("utf-8", "replace").splitlines() or [""]
        row = data.draw(st.integers(0, len(lines) - 1), label="row")
        if kind == "trailing_comma":
            lines = [ln + "," if i else ln for i, ln in enumerate(lines)]
        elif kind == "line":
            lines.insert(row, data.draw(st.text(max_size=40), label="line"))
        else:
            cells = lines[row].split(",")
            col = data.draw(st.integers(0, len(cells) - 1), label="col")
            cells[col] = data.draw(st.sampled_from(HOSTILE) | st.text(max_size=12), label="cell")
            lines[row] = ",".join(cells)
        path.write_bytes(("\n".join(lines) + "\n").encode("utf-8", "surrogatepass"))
    else:
        path.write_bytes(raw[::-1])


# ------------------------------------------------------------------ plain-file datasets
def _dataset(root: Path, signals: bool) -> tuple[Path, list[str]]:
    rng = np.random.default_rng(0)
    classes = pd.DataFrame({"hard": [1, 0, 1], "soft": [0, 1, 1], "round": [0, 1, 0]},
                           index=pd.Index(["cube", "ball", "disc"], name="class"))
    trials = pd.DataFrame({"trial_id": ["t1", "t2", "t3", "t4"], "class": ["cube", "ball", "disc", "cube"],
                           "object": ["c1", "b1", "d1", "c2"]})
    groups = {"hard": "material", "soft": "material", "round": "shape"}
    if signals:
        sig = [[rng.normal(size=(6, 2))] for _ in range(4)]
        folder = write_plain_dataset(root / "ds", classes, trials, signals=sig, channels=("p", "q"),
                                     attribute_groups=groups, signal_format="csv",
                                     settings={"signals": {"statistics": ["mean", "std"]}})
    else:
        folder = write_plain_dataset(root / "ds", classes, trials, sensors=("l", "r"), X=rng.normal(size=(4, 2, 2)),
                                     feature_names=("f_a", "f_b"), attribute_groups=groups)
    (folder / "splits.csv").write_text("split,object,role\ns1,c1,train\ns1,b1,train\ns1,d1,test\n")
    files = sorted(str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file())
    return folder, files


@pytest.mark.parametrize("signals", [False, True], ids=["columns", "signals"])
@FUZZ
@given(data=st.data())
def test_validate_broken_dataset(signals, data):
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        folder, files = _dataset(root, signals)
        _damage(folder, files, data)
        before = _tree(root)
        result = CliRunner().invoke(cli, ["validate", str(folder)])
        _check(result, folder, before, root)


# ------------------------------------------------------------------ grasp folders
@FUZZ
@given(data=st.data())
def test_read_broken_grasp_folder(data):
    from tzsl.datasets import load_hand_table4, simulate_grasps

    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        folder = root / "grasps"
        simulate_grasps(load_hand_table4().K.iloc[:2], 1, random_state=0, folder=folder)
        files = sorted(str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file())
        _damage(folder, files, data)
        before = _tree(root)
        try:
            read_grasps(folder)
        except TzslError as exc:
            text = str(exc)
            assert "\n" not in text and str(folder) in text, text
        assert _tree(root) == before


# ------------------------------------------------------------------ bundles
@pytest.fixture(scope="module")
def phac2_model(tmp_path_factory):
    from tzsl.datasets import FeatureSet
    from tzsl.datasets._feature_table import write_feature_table
    from tzsl.inference.zero_shot_bundles import save_zero_shot_bundle
    from tzsl.models import AttributeClassifierBank, AttributeSVM, DAPRule, ZeroShotClassifier

    root = tmp_path_factory.mktemp("fuzz_model")
    rng = np.random.default_rng(0)
    objects = [f"o{i}" for i in range(4)]
    A = pd.DataFrame([[1, 0], [0, 1], [1, 1], [0, 0]], index=pd.Index(objects, name="object_name"),
                     columns=["hard", "soft"])
    rows = [(o, t) for o in objects for t in range(4)]
    X = A.loc[[o for o, _ in rows]].to_numpy() @ np.array([[2.0, 0, 1], [0, 2.0, 1]])
    X = np.stack([X + rng.normal(0, 0.3, X.shape)] * 2, axis=1)
    trials = pd.DataFrame({"trial_id": [f"{o}_{t}" for o, t in rows], "object_id": [objects.index(o) for o, _ in rows],
                           "object_name": [o for o, _ in rows], "trial_index": [t for _, t in rows]})
    fs = FeatureSet(X=X, trials=trials, sensors=("s0", "s1"), feature_names=("f0", "f1", "f2"), attributes=A)
    svm = AttributeSVM(n_C=1, n_gamma=1, n_draws=1, cv=2, undersampling="none", random_state=0)
    bank = AttributeClassifierBank(estimator=svm, attribute_names=["hard", "soft"], n_jobs=1, random_state=0)
    clf = ZeroShotClassifier(attribute_model=bank, decision_rule=DAPRule(prior="uni"))
    clf.fit(fs.X, fs.trial_attributes(), fs.trials["object_name"])
    save_zero_shot_bundle(root / "model.tzsl", clf, fs, method="dap-avg", ndim=3)
    write_feature_table(fs, root / "table.npz")
    (root / "classes.csv").write_text("class,hard,soft\na,1,0\nb,0,1\n")
    return root


def _rechecksum(raw: bytes, edit: dict) -> bytes:
    magic, line, payload = raw.split(b"\n", 2)
    header = json.loads(line)
    header.update(edit)
    fields = {k: v for k, v in header.items() if k not in ("header_sha256", "hmac_sha256")}
    header["header_sha256"] = hashlib.sha256(
        json.dumps(fields, sort_keys=True, separators=(",", ":")).encode()).hexdigest()
    return magic + b"\n" + json.dumps(header).encode() + b"\n" + payload


JSON = st.recursive(st.none() | st.booleans() | st.integers() | st.text(max_size=5),
                    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=3), inner, max_size=3),
                    max_leaves=5)


@FUZZ
@given(data=st.data())
def test_predict_with_broken_bundle(phac2_model, data):
    raw = (phac2_model / "model.tzsl").read_bytes()
    kind = data.draw(st.sampled_from(["flip", "truncate", "field", "payload"]), label="damage")
    if kind == "flip":
        pos = data.draw(st.integers(0, len(raw) - 1), label="pos")
        raw = raw[:pos] + bytes([raw[pos] ^ 0xFF]) + raw[pos + 1:]
    elif kind == "truncate":
        raw = raw[: data.draw(st.integers(0, len(raw) - 1), label="cut")]
    elif kind == "field":
        key = data.draw(st.sampled_from(["metadata", "kind", "format_version", "tzsl_version", "payload_format",
                                         "payload_sha256", "format"]), label="key")
        raw = _rechecksum(raw, {key: data.draw(JSON, label="value")})
    else:
        payload = data.draw(st.binary(max_size=300), label="payload")
        magic, line, _ = raw.split(b"\n", 2)
        raw = _rechecksum(magic + b"\n" + line + b"\n" + payload,
                          {"payload_sha256": hashlib.sha256(payload).hexdigest(), "payload_bytes": len(payload)})
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        bundle = root / "broken.tzsl"
        bundle.write_bytes(raw)
        before = _tree(root)
        result = CliRunner().invoke(cli, ["predict", "--model", str(bundle), "--classes",
                                          str(phac2_model / "classes.csv"), str(phac2_model / "table.npz")])
        _check(result, bundle, before, root)


# ------------------------------------------------------------------ experiment files
EXPERIMENT = """study = "phac2-dap"
description = "fuzz base"
[dataset]
plain = "ds"
min_objects = 1
[methods]
fusions = ["avg"]
priors = ["uni"]
[splits]
kinds = ["file"]
seed = 0
[svm]
cv = 2
undersampling = "none"
n_C = 1
[compute]
n_jobs = 1
progress = false
cache = false
[output]
folder = "elsewhere"
"""
TOML_VALUES = ['"../x"', '"/etc/passwd"', '"/"', '"ds/splits.csv"', "-1", "0", "1099511627776", "nan", "inf",
               "true", "[]", "{}", '["file", "file"]', '"é"', '"a\\u0000b"', "1.5", '"', "[", "'''", '""']


def _damage_toml(text: str, data: st.DataObject) -> tuple[bytes, list[str]]:
    """The damaged file's bytes and the hostile values it holds (an error may name them instead of the file)."""
    lines = text.splitlines()
    kind = data.draw(st.sampled_from(["bytes", "truncate", "drop", "double", "value", "unknown", "value"]),
                     label="damage")
    values: list[str] = []
    if kind == "bytes":
        return data.draw(st.binary(max_size=120), label="bytes"), values
    if kind == "truncate":
        raw = text.encode()
        return raw[: data.draw(st.integers(0, len(raw) - 1), label="cut")], values
    row = data.draw(st.sampled_from([i for i, ln in enumerate(lines) if "=" in ln or ln.startswith("[")]),
                    label="row")
    if kind == "drop":
        del lines[row]
    elif kind == "double":
        lines.insert(row, lines[row])
    elif kind == "unknown":
        lines.insert(row + 1, data.draw(st.sampled_from(["bogus = 1", "[bogus]", "n_jobs = 2", "study = 'hand'"]),
                                        label="line"))
    elif "=" in lines[row]:
        value = data.draw(st.sampled_from(TOML_VALUES) | st.text(max_size=8), label="value")
        lines[row] = lines[row].split("=")[0] + "= " + value
        values.append(value.strip('"'))
    return ("\n".join(lines) + "\n").encode("utf-8", "surrogatepass"), values


@FUZZ
@given(data=st.data())
def test_run_check_broken_experiment_file(data):
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        _dataset(root, signals=False)
        toml = root / "exp.toml"
        raw, values = _damage_toml(EXPERIMENT, data)
        toml.write_bytes(raw)
        before = _tree(root)
        cwd = os.getcwd()
        os.chdir(root)  # a relative output folder or cache would land here, where it is seen
        try:
            result = CliRunner().invoke(cli, ["run", str(toml), "--check", "--out", str(root / "out")])
        finally:
            os.chdir(cwd)
        assert result.exception is None or isinstance(result.exception, SystemExit), repr(result.exception)
        assert "Traceback" not in result.output + result.stderr
        assert _tree(root) == before, "a file was created or changed"
        if result.exit_code == 0:
            return
        assert result.exit_code in ERROR_CODES, result.output
        lines = result.stderr.strip().splitlines()
        assert lines and lines[0].startswith("tzsl: error: "), result.stderr
        assert len(lines) == 1 or lines[0].endswith("problem(s):"), result.stderr  # several: one per line
        for line in lines:
            assert str(toml) in line or str(root) in line or any(v and v in line for v in values), line


RUNNABLE = EXPERIMENT.replace('kinds = ["file"]', 'kinds = ["random"]\nn_splits = 1\nn_test = 3').replace(
    "n_C = 1", "n_C = 1\nn_gamma = 1\nn_draws = 1")


def _runnable_dataset(root: Path) -> Path:
    """12 objects with distinct 4-bit attribute rows, 2 trials each, features that follow the attributes."""
    rng = np.random.default_rng(0)
    A = (np.arange(1, 13)[:, None] >> np.arange(4)) & 1
    names = [f"k{i:02d}" for i in range(12)]
    classes = pd.DataFrame(A, index=pd.Index(names, name="class"), columns=["a0", "a1", "a2", "a3"])
    trials = pd.DataFrame({"trial_id": [f"t{i}" for i in range(24)], "class": np.repeat(names, 2),
                           "object": np.repeat(names, 2)})
    X = np.repeat(A, 2, axis=0)[:, None, :2] + 0.2 * rng.normal(size=(24, 1, 2))
    return write_plain_dataset(root / "ds", classes, trials, sensors=("s",), X=X, feature_names=("f_a", "f_b"))


@settings(FUZZ, max_examples=min(FUZZ.max_examples, 6))
@given(data=st.data())
def test_run_broken_experiment_file_writes_only_under_out(data):
    """A real run (tiny SVM grid): exit 0 or 2/3 with the file named; files appear only under --out."""
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        _runnable_dataset(root)
        toml = root / "exp.toml"
        raw, values = _damage_toml(RUNNABLE, data)
        toml.write_bytes(raw)
        before = _tree(root)
        cwd = os.getcwd()
        os.chdir(root)
        try:
            result = CliRunner().invoke(cli, ["run", str(toml), "--out", str(root / "out")])
        finally:
            os.chdir(cwd)
        assert result.exception is None or isinstance(result.exception, SystemExit), repr(result.exception)
        assert "Traceback" not in result.output + result.stderr
        after = {k: v for k, v in _tree(root).items() if k != "out" and not k.startswith("out/")}
        assert after == before, "a file outside --out was created or changed"
        if result.exit_code == 0:
            assert (root / "out" / "manifest.json").is_file()
            return
        assert result.exit_code in ERROR_CODES, result.output
        lines = result.stderr.strip().splitlines()
        assert len(lines) == 1 or lines[0].endswith("problem(s):"), result.stderr
        for line in lines:
            assert str(toml) in line or str(root) in line or any(v and v in line for v in values), line


# ------------------------------------------------------------------ grasp folders through 'tzsl predict'
@pytest.fixture(scope="module")
def hand_model(tmp_path_factory):
    from tzsl.datasets import load_hand_table4, simulate_grasps
    from tzsl.inference.model_bundles import train_hand_bundle

    root = tmp_path_factory.mktemp("fuzz_hand")
    table = load_hand_table4()
    simulate_grasps(table.K, 20, random_state=1, folder=root / "train")
    train_hand_bundle(root / "train", table, root / "model.tzsl", seed=0)
    table.K.loc[table.test_objects].rename_axis("object").to_csv(root / "classes.csv")
    return root, table


@settings(FUZZ, max_examples=min(FUZZ.max_examples, 10))  # each example loads the bundle
@given(data=st.data())
def test_predict_broken_grasp_folder(hand_model, data):
    from tzsl.datasets import simulate_grasps

    model_root, table = hand_model
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        folder = root / "grasps"
        simulate_grasps(table.K.loc[list(table.test_objects)[:2]], 1, random_state=2, folder=folder)
        files = sorted(str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file())
        _damage(folder, files, data)
        before = _tree(root)
        result = CliRunner().invoke(cli, ["predict", "--model", str(model_root / "model.tzsl"), "--classes",
                                          str(model_root / "classes.csv"), "--k", "1", str(folder)])
        _check(result, folder, before, root)
