"""The experiment schema: built-in files, every problem named (file, key, reason), defaults written once."""

from __future__ import annotations

import json
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from tzsl.datasets import FeatureSet, feature_set_to_plain
from tzsl.exceptions import ConfigError
from tzsl.studies.config import builtin_names, load_experiment, study_names, to_toml, validate
from tzsl.studies.engine import check_experiment, run_experiment
from tzsl.studies.reproduce import EVIDENCE_STUDIES, REPRODUCE_STUDIES

REPO = Path(__file__).resolve().parents[2]


def _write(tmp_path: Path, text: str, name: str = "exp.toml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


# --------------------------------------------------------------------------- built-in files


def test_builtin_studies_ship_inside_the_package_only():
    names = builtin_names()  # read from the package's folder: a new preset needs no edit here
    assert names == sorted(set(names))
    # the papers' presets and the studies reproduce-tables and evidence run are among them
    papers = {"phac2-dap", "fabric", "hand-simulated", "active-touch"}
    assert papers | set(REPRODUCE_STUDIES) | set(EVIDENCE_STUDIES) <= set(names)
    for name in names:
        assert load_experiment(name).study in study_names()
    # one copy: the top-level folder holds the README, the user template and the benchmark scripts, no study file
    assert sorted(p.name for p in (REPO / "experiments").iterdir()) == ["README.md", "benchmarks",
                                                                         "my_dataset_template.toml"]
    assert not list((REPO / "experiments" / "benchmarks").glob("*.toml"))
    # the generic study, no paper preset
    assert load_experiment(REPO / "experiments" / "my_dataset_template.toml").study == "zero-shot"


def test_studies_read_the_schema_defaults():
    """A study file is the study's settings: the zero-shot study's tables are ZeroShotSettings' own defaults,
    its PHAC-2 preset's those with PRESET_DEFAULTS["phac2-dap"] on top (and nothing else differs)."""
    from tzsl.studies.config import PRESET_DEFAULTS, HandSettings, ZeroShotSettings

    minimal = validate({"study": "phac2-dap", "dataset": {"features": "x.csv"}}, "t", Path("."))
    assert isinstance(minimal.config, ZeroShotSettings)
    for table in ("methods", "gzsl", "splits", "svm", "compute"):
        assert getattr(minimal.config, table) == getattr(ZeroShotSettings.of_preset("phac2-dap"), table), table
    generic = validate({"study": "zero-shot", "dataset": {"features": "x.csv"}}, "t", Path("."))
    for table in ("methods", "gzsl", "splits", "svm", "compute"):
        assert getattr(generic.config, table) == getattr(ZeroShotSettings(), table), table
    differ = {table: {key for key, value in getattr(minimal.config, table).model_dump().items()
                      if value != getattr(generic.config, table).model_dump()[key]}
              for table in ("methods", "gzsl", "splits", "svm", "compute")}
    assert {t: k for t, k in differ.items() if k} == {t: set(v) for t, v in PRESET_DEFAULTS["phac2-dap"].items()}
    hand = validate({"study": "hand", "dataset": {"builtin": "hand-simulated"}}, "t", Path("."))
    assert isinstance(hand.config, HandSettings)
    for table in ("simulation", "features", "methods", "compute"):
        assert getattr(hand.config, table) == getattr(HandSettings(), table), table


def test_svm_defaults_are_read_from_the_estimator():
    from tzsl.models import AttributeSVM

    svm = load_experiment("phac2-gzsl").config.svm  # the file leaves the grids out
    params = AttributeSVM().get_params()
    for key in ("C_range", "gamma_range", "n_C", "n_gamma", "n_draws", "scoring", "platt_weighting", "undersampling",
                "search"):
        value = getattr(svm, key)
        assert (tuple(value) if isinstance(value, list) else value) == params[key], key


def test_fabric_file_is_the_schema_defaults():
    """The built-in fabric file changes no paper-protocol default: the study runs the schema's values."""
    from tzsl.studies.config import FabricStudy

    fabric = load_experiment("fabric").config
    for table in ("dataset", "features", "methods", "splits"):
        ours = getattr(fabric, table).model_dump()
        default = getattr(FabricStudy(), table).model_dump()
        differ = {k for k in ours if ours[k] != default[k]}
        assert differ <= {"compare"}, (table, differ)  # the file adds registry methods beside ESZSL
    assert fabric.splits.n_seeds == 5


def test_print_config_round_trip(tmp_path):
    """The printed config, read again, resolves to the same config (every built-in study)."""
    for name in builtin_names():
        exp = load_experiment(name)
        text = to_toml(exp.config)
        again = load_experiment(_write(tmp_path, text, f"{name}.toml"))
        assert again.config == exp.config, name
        assert to_toml(again.config) == text
        assert tomllib.loads(text)["study"] == exp.study


def test_template_promise_holds_keys_left_out_take_the_printed_defaults(tmp_path):
    """Leaving a key out of a file gives the default --print-config shows (issue 11)."""
    path = _write(tmp_path, "study = 'phac2-dap'\n[dataset]\nplain = 'd'\n")
    printed = tomllib.loads(to_toml(load_experiment(path).config))
    assert printed["methods"]["multilabel"] is False and printed["splits"]["n_test"] == 10


# --------------------------------------------------------------------------- problems


def test_every_problem_is_listed_with_file_key_and_reason(tmp_path):
    path = _write(tmp_path, """
study = "phac2-dap"
[dataset]
builtin = "phac2-penn"
colour = "red"
[svm]
n_C = "three"
cv = true
undersampling = "sometimes"
C_range = [100.0, 1.0]
[splits]
n_splits = 0
kinds = ["random", 3]
seed = 4294967296
[methods]
embedding_lambdas = [0.1, 0.1]
[compute]
n_jobs = 0
[extra]
x = 1
""")
    with pytest.raises(ConfigError) as err:
        load_experiment(path)
    text = str(err.value)
    assert "11 problem(s)" in text
    for expected in (
        f"{path}: dataset.colour: unknown key",
        f"{path}: svm.n_C: 'three': expected a valid integer",
        f"{path}: svm.cv: True: expected a valid integer",
        f"{path}: svm.undersampling: 'sometimes': expected 'select', 'bagging' or 'none'",
        f"{path}: svm.C_range: expected [low, high] with 0 < low <= high",
        f"{path}: splits.n_splits: 0: must be >= 1",
        f"{path}: splits.kinds[1]: 3: expected 'random', 'challenging' or 'file'",
        f"{path}: splits.seed: 4294967296: must be < 4294967296",
        f"{path}: methods.embedding_lambdas: lists a value twice",
        f"{path}: compute.n_jobs: n_jobs = 0 runs nothing",
        f"{path}: extra: unknown key",
    ):
        assert expected in text, expected
    assert "Traceback" not in text and "pydantic" not in text and "For further information" not in text


@pytest.mark.parametrize(("text", "message"), [
    ("study = 'phac2-dap'\n[dataset]\n", "dataset: needs exactly one of builtin, plain, features"),
    ("study = 'phac2-dap'\n[dataset]\nbuiltin = 'phac2-penn'\nplain = 'x'\n", "needs exactly one of"),
    ("study = 'phac2-dap'\n[dataset]\nbuiltin = 'phac2-h5'\n", "needs path"),
    ("study = 'phac2-dap'\n[dataset]\nbuiltin = 'phac2-penn'\n[features]\nstatistics = ['mean']\n",
     "features: statistics apply to plain signal datasets only"),
    ("study = 'phac2-dap'\n[dataset]\nbuiltin = 'phac2-penn'\n[splits]\nkinds = ['file', 'random']\n",
     "cannot be combined"),
    ("study = 'phac2-dap'\n[dataset]\nbuiltin = 'phac2-penn'\n[splits]\nkinds = ['file']\n",
     "splits.kinds: ['file'] needs file"),
    ("study = 'phac2-dap'\n[dataset]\nbuiltin = 'phac2-penn'\n[svm]\ncv = 1\n", "svm.cv: use 0"),
    ("study = 'phac2-dap'\n[dataset]\nbuiltin = 'phac2-penn'\n[methods]\ndap = false\n", "methods.dap"),
    ("study = 'phac2-dap'\n[dataset]\nbuiltin = 'phac2-penn'\n[gzsl]\nholdout_fraction = 1.5\n",
     "gzsl.holdout_fraction: 1.5: must be < 1"),
    ("study = 'phac2-dap'\n[dataset]\nbuiltin = 'phac2-penn'\n[compute]\nscheduler = 'tcp://x:1'\n",
     "compute.scheduler: needs backend = 'dask'"),
    ("study = 'phac2-dap'\n[dataset]\nbuiltin = 'phac2-penn'\n[splits]\nn_test = nan\n", "finite"),
    ("study = 'hand'\n[dataset]\n", "exactly one of builtin = 'hand-simulated', grasps"),
    ("study = 'hand'\n[dataset]\nbuiltin = 'hand-simulated'\n[methods.model]\nfoo = 1\n",
     "methods.model: unknown HandDAPClassifier parameter(s) ['foo']"),
    ("study = 'hand'\n[dataset]\nbuiltin = 'hand-simulated'\n[splits]\nseeds = [1, 1]\n", "lists a value twice"),
    ("study = 'fabric'\n[features]\nconditions = []\n", "features.conditions: is empty"),
    ("study = 'fabric'\n[splits]\nconfigs = [3]\n", "splits.configs[0]: 3: expected 1 or 2"),
    ("study = 'fabric'\n[methods]\nembedding_lambdas = [0, 'x']\n", "embedding_lambdas[1]: 'x'"),
    ("study = 'fabric-deep'\n[methods.model]\nlam = 1\n", "are set by the study"),
    ("study = 'clustering'\n", "study: 'clustering': expected one of zero-shot, phac2-dap, fabric, fabric-deep, hand"),
    ("[dataset]\nbuiltin = 'phac2-penn'\n", "study: missing"),
    ("study = 'phac2-dap'\ndataset = 3\n", "dataset: 3: expected a table"),
    ("study = 'phac2-dap\n", "not valid TOML"),
])
def test_bad_files_are_config_errors_naming_the_file(tmp_path, text, message):
    path = _write(tmp_path, text)
    with pytest.raises(ConfigError) as err:
        load_experiment(path)
    assert message in str(err.value)
    assert str(err.value).startswith(str(path))


def test_binary_and_missing_files(tmp_path):
    binary = tmp_path / "exp.toml"
    binary.write_bytes(b"\x89PNG\r\n\x1a\n\xff\xfe\x00")
    with pytest.raises(ConfigError, match="not a text .UTF-8. TOML file"):
        load_experiment(binary)
    with pytest.raises(ConfigError, match="experiment file not found"):
        load_experiment(tmp_path / "nope.toml")
    with pytest.raises(ConfigError, match="no such experiment file or built-in study .built-in: active-touch, fabric"):
        load_experiment("phac2-dapp")


def test_svm_settings_keep_only_departures_from_attribute_svm_defaults(tmp_path):
    path = _write(tmp_path, "study = 'phac2-dap'\n[dataset]\nbuiltin = 'phac2-penn'\n[svm]\ncv = 0\nn_C = 3\n"
                            "n_gamma = 2\nC_range = [1, 10]\n[compute]\nn_jobs = 2\n")
    config = load_experiment(path).config
    assert config.svm.estimator_params() == {"n_gamma": 2, "C_range": (1.0, 10.0)}  # cv None, n_C 3: the defaults
    assert config.compute.n_jobs == 2
    assert load_experiment(path, {"compute.n_jobs": 4}).config.compute.n_jobs == 4


def test_paths_are_relative_to_the_file(tmp_path):
    sub = tmp_path / "exps"
    sub.mkdir()
    exp = load_experiment(_write(sub, "study = 'phac2-dap'\n[dataset]\nplain = '../data/set'\n"))
    assert exp.resolve(exp.config.dataset.plain) == sub / "../data/set"
    assert exp.resolve("/abs/x") == Path("/abs/x")


# --------------------------------------------------------------------------- checks before any fit


def test_check_finds_what_a_run_would_fail_on(tmp_path):
    (tmp_path / "toy").mkdir()
    path = _write(tmp_path, "study = 'phac2-dap'\n[dataset]\nplain = 'toy'\ndata_dir = 'nowhere'\n"
                            "[splits]\nkinds = ['file']\n")
    with pytest.raises(ConfigError) as err:
        check_experiment(load_experiment(path))
    text = str(err.value)
    assert f"{path}: dataset.data_dir: folder {tmp_path / 'nowhere'} not found" in text
    assert f"{path}: splits.kinds: file {tmp_path / 'toy' / 'splits.csv'} not found" in text
    missing = _write(tmp_path, "study = 'phac2-dap'\n[dataset]\nplain = 'gone'\n", "m.toml")
    with pytest.raises(ConfigError, match="dataset.plain: folder .* not found"):
        check_experiment(load_experiment(missing))


@pytest.mark.parametrize("address", ["tcp://unreachable:8786", "tcp://127.0.0.1:1", "tcp://10.255.255.1:8786"])
def test_unreachable_dask_scheduler_fails_fast(tmp_path, address):
    import time

    pytest.importorskip("distributed")
    path = _write(tmp_path, "study = 'phac2-dap'\n[dataset]\nbuiltin = 'phac2-penn'\n[compute]\nbackend = 'dask'\n"
                            f"scheduler = '{address}'\nconnect_timeout = 1\n")
    start = time.perf_counter()
    with pytest.raises(ConfigError, match=f"compute.scheduler: cannot reach the Dask scheduler {address} within 1 s"):
        check_experiment(load_experiment(path))
    assert time.perf_counter() - start < 8


# --------------------------------------------------------------------------- a run


def _plain_dataset(folder: Path, n_objects: int = 20, trials: int = 4) -> None:
    rng = np.random.default_rng(0)
    m = 5
    bits = 1 << np.arange(m)
    codes = np.concatenate([bits, 31 - bits, rng.permutation([c for c in range(1, 31) if c not in
                                                              set(bits) | set(31 - bits)])])[:n_objects]
    A = (codes[:, None] & bits[None, :] > 0).astype(int)
    names = [f"o{i:02d}" for i in range(n_objects)]
    W = rng.normal(size=(2, m, 4))
    X = np.repeat(np.einsum("om,smd->osd", A.astype(float), W), trials, axis=0)
    X += 0.3 * rng.normal(size=X.shape)
    table = pd.DataFrame({"trial_id": [f"{o}_{t}" for o in names for t in range(trials)],
                          "object_id": np.repeat(np.arange(n_objects), trials),
                          "object_name": np.repeat(names, trials),
                          "trial_index": np.tile(np.arange(1, trials + 1), n_objects)})
    attrs = pd.DataFrame(A, index=pd.Index(names, name="object_name"), columns=[f"a{j}" for j in range(m)])
    fs = FeatureSet(X=X, trials=table, sensors=("left", "right"), feature_names=tuple(f"f{i}" for i in range(4)),
                    attributes=attrs, dataset="toy")
    feature_set_to_plain(fs, folder)


RUN_TOML = """
study = "phac2-dap"
[dataset]
plain = "toy"
[methods]
fusions = ["avg"]
priors = ["uni", "train"]
eszsl = true
gzsl = true
[gzsl]
holdout_fraction = 0.25
methods = ["eszsl"]
calibrated_stacking = false
[splits]
kinds = ["random"]
n_splits = 2
n_test = 4
[svm]
cv = 3
n_C = 1
n_gamma = 1
n_draws = 1
[compute]
cache = false
progress = false
[output]
folder = "unused"
"""


@pytest.mark.slow
def test_run_writes_selected_tables_and_manifest(tmp_path):
    _plain_dataset(tmp_path / "toy")
    path = _write(tmp_path, RUN_TOML)
    lines: list[str] = []
    results, _ = run_experiment(path, out=tmp_path / "res", echo=lines.append)
    names = {p.name for p in results.written}
    assert {"table1_fusion.csv", "table2_priors.csv", "methods_per_split.csv", "method_comparison.csv", "gzsl.csv",
            "manifest.json", "attribute_accuracy.png"} <= names
    assert not {"multilabel.csv", "attribute_sweep.csv", "table3_challenging.csv"} & names
    t1 = pd.read_csv(tmp_path / "res" / "table1_fusion.csv")
    assert "avgdap" in t1.columns and "maxdap" not in t1.columns and "paper_maxdap" not in t1.columns
    t2 = pd.read_csv(tmp_path / "res" / "table2_priors.csv")
    assert {"uni", "train"} <= set(t2.columns) and "test" not in t2.columns
    assert not [c for c in t2.columns if c.startswith("paper")]  # a user's dataset: no paper numbers (issue 20)
    comparison = pd.read_csv(tmp_path / "res" / "method_comparison.csv")
    assert set(comparison["study"]) == {"zero-shot"} and "paper_accuracy" not in comparison.columns
    assert set(comparison["data"]) == {"toy"} and not comparison["note"].fillna("").str.contains("paper").any()
    methods = pd.read_csv(tmp_path / "res" / "methods_per_split.csv")
    assert "eszsl" in methods.columns and not any(c.startswith("embedding") for c in methods.columns)
    gzsl = pd.read_csv(tmp_path / "res" / "gzsl.csv")
    assert set(gzsl["method"]) == {"eszsl"} and not gzsl["calibrated"].any()
    manifest = json.loads((tmp_path / "res" / "manifest.json").read_text())
    assert manifest["experiment_toml"] == RUN_TOML
    assert manifest["config"]["svm_params"] == {"cv": 3, "n_C": 1, "n_gamma": 1, "n_draws": 1}
    assert manifest["config"]["study_settings"]["gzsl"]["holdout_fraction"] == 0.25
    solvers = manifest["config"]["attribute_solver"]  # 2 random splits of 80 trials: exact, and why
    assert [c["solver"] for c in solvers] == ["exact", "exact"] and "max_exact_trials" in solvers[0]["reason"]
    assert any(line.startswith("attribute models: exact (solver='auto'") for line in lines)
    assert tomllib.loads(manifest["config"]["resolved_toml"])["splits"]["n_test"] == 4
    assert any("Generalised zero-shot" in line for line in lines)
    assert not any("maxdap" in line for line in lines)
    # existing results are refused before any computation
    with pytest.raises(ConfigError, match="already exists"):
        run_experiment(path, out=tmp_path / "res")


def test_run_uses_the_plain_folder_splits_csv(tmp_path):
    from tzsl.evaluation import Split, write_splits_csv

    _plain_dataset(tmp_path / "toy")
    objects = [f"o{i:02d}" for i in range(20)]
    test = ["o00", "o07", "o13", "o19"]
    write_splits_csv([Split(name="mine-1", train_objects=tuple(o for o in objects if o not in test),
                            test_objects=tuple(test), attributes=tuple(f"a{j}" for j in range(5)), kind="file")],
                     tmp_path / "toy" / "splits.csv")
    text = RUN_TOML.replace('kinds = ["random"]', 'kinds = ["file"]').replace("gzsl = true", "gzsl = false")
    text = text.replace("eszsl = true", "eszsl = false")
    run_experiment(_write(tmp_path, text), out=tmp_path / "res")
    t1 = pd.read_csv(tmp_path / "res" / "table1_fusion.csv")
    assert list(t1["split"][:1]) == ["1"] and t1["n_test_objects"].iloc[0] == 4


def test_too_many_cv_folds_are_relaxed_and_recorded(tmp_path):
    """Issue 20: the folds are lowered to the fewest training objects; the manifest records it."""
    _plain_dataset(tmp_path / "toy")
    path = _write(tmp_path, RUN_TOML.replace("cv = 3", "cv = 50"))
    results, run = run_experiment(path, out=tmp_path / "res")
    assert (tmp_path / "res" / "table1_fusion.csv").exists()
    relaxed = json.loads((tmp_path / "res" / "manifest.json").read_text())["config"]["relaxations"]
    assert relaxed == run.record["relaxations"]
    assert relaxed == [{"setting": "svm.cv", "asked": 50, "used": 16, "why": "a split has only 16 training objects"}]


def test_grid_passes_through_and_reproduction_studies_pin_the_paper_grid(tmp_path):
    from tzsl.models import AttributeSVM

    assert AttributeSVM().grid == "extended"
    for name in ("phac2-dap", "phac2-evidence", "phac2-gzsl", "phac2-headlines"):
        exp = load_experiment(name)
        assert exp.config.svm.grid == "paper"
        assert exp.config.svm.estimator_params()["grid"] == "paper"
    path = _write(tmp_path, "study = 'phac2-dap'\n[dataset]\nbuiltin = 'phac2-penn'\n")
    assert load_experiment(path).config.svm.grid == "extended"
    assert "grid" not in load_experiment(path).config.svm.estimator_params()  # the estimator's default
    bad = _write(tmp_path, "study = 'phac2-dap'\n[dataset]\nbuiltin = 'phac2-penn'\n[svm]\ngrid = 'wide'\n", "bad.toml")
    with pytest.raises(ConfigError, match="svm.grid"):
        load_experiment(bad)
