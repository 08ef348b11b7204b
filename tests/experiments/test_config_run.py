"""Experiment files: shipped files match reproduce-tables, every problem is named, a run end to end."""

from __future__ import annotations

import inspect
import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from tzsl.datasets import FeatureSet, feature_set_to_plain
from tzsl.exceptions import ConfigError
from tzsl.experiments.config_run import (
    SCHEMAS,
    dap_config,
    fabric_arguments,
    gzsl_config,
    hand_config,
    load_experiment,
    run_experiment,
)

REPO = Path(__file__).resolve().parents[2]
EXPERIMENTS = REPO / "experiments"


def _write(tmp_path: Path, text: str, name: str = "exp.toml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


# --------------------------------------------------------------------------- shipped files


def test_phac2_file_gives_reproduce_tables_settings():
    """experiments/phac2_dap.toml == what `tzsl reproduce-tables` (default options) runs."""
    from tzsl.cli._dap_commands import _config

    exp = load_experiment(EXPERIMENTS / "phac2_dap.toml")
    # reproduce-tables' CLI defaults: seed 0, n_jobs 1, loky, select, cv 5, progress, cache, multilabel
    assert dap_config(exp) == _config(0, 1, "loky", None, "select", 5, False, False, multilabel=True)
    methods = exp.settings["methods"]
    # run_dap_study(kinds=("random", "challenging"), sweep=True, compare_methods=True) with
    # method_comparison's defaults
    from tzsl.experiments.phac2_dap import method_comparison

    defaults = inspect.signature(method_comparison).parameters
    assert exp.settings["splits"]["kinds"] == ["random", "challenging"]
    assert methods["sweep"] and methods["eszsl"] and methods["embedding"] and not methods["gzsl"]
    assert tuple(methods["embedding_lambdas"]) == defaults["embedding_lams"].default
    assert methods["eszsl"] is defaults["eszsl"].default
    assert exp.settings["dataset"]["builtin"] == "phac2-penn" and exp.settings["dataset"]["min_objects"] == 3


def test_fabric_and_hand_files_give_reproduce_tables_settings():
    from tzsl.experiments.fabric import run_fabric_study
    from tzsl.experiments.hand import HandStudyConfig
    from tzsl.experiments.reproduce import reproduce_tables

    fabric = fabric_arguments(load_experiment(EXPERIMENTS / "fabric.toml"))
    params = inspect.signature(run_fabric_study).parameters
    reproduce = inspect.signature(reproduce_tables).parameters
    assert fabric["seeds"] == reproduce["fabric_seeds"].default
    for key in ("configs", "attributes", "lams", "alphas", "conditions", "seed", "max_iter", "gelsight_root",
                "gelsight_conditions", "data_dir"):
        assert fabric[key] == params[key].default, key
    exp = load_experiment(EXPERIMENTS / "hand_simulated.toml")
    assert hand_config(exp) == HandStudyConfig()
    assert tuple(exp.settings["splits"]["seeds"]) == reproduce["hand_seeds"].default
    assert exp.settings["dataset"]["builtin"] == "hand-simulated"


def test_every_shipped_file_loads():
    names = sorted(p.name for p in EXPERIMENTS.glob("*.toml"))
    assert {"phac2_dap.toml", "fabric.toml", "hand_simulated.toml", "my_dataset_template.toml",
            "phac2_gzsl.toml"} <= set(names)
    for name in names:
        exp = load_experiment(EXPERIMENTS / name)
        assert exp.study in SCHEMAS
    gzsl = gzsl_config(load_experiment(EXPERIMENTS / "phac2_gzsl.toml"))
    assert gzsl.calibrated_stacking and gzsl.methods == ("dap", "eszsl") and gzsl.holdout_fraction == 0.3


# --------------------------------------------------------------------------- problems


def test_every_problem_is_listed_with_file_and_key_path(tmp_path):
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
[methods]
embedding_lambdas = [0.1, 0.1]
[extra]
x = 1
""")
    with pytest.raises(ConfigError) as err:
        load_experiment(path)
    text = str(err.value)
    assert "9 problem(s)" in text
    for expected in (
        f"{path}: unknown key [dataset] colour",
        f"{path}: [svm] n_C = 'three': expected an integer",
        f"{path}: [svm] cv = True: expected an integer",
        f"{path}: [svm] undersampling = 'sometimes': 'sometimes' is not one of",
        f"{path}: [svm] C_range = [100.0, 1.0]: expected [low, high]",
        f"{path}: [splits] n_splits = 0: must be >= 1",
        f"{path}: [splits] kinds = ['random', 3]: expected a list of strings, got 3",
        f"{path}: [methods] embedding_lambdas = [0.1, 0.1]: lists a value twice",
        f"{path}: unknown key 'extra'",
    ):
        assert expected in text, expected


@pytest.mark.parametrize(("text", "message"), [
    ("study = 'phac2-dap'\n[dataset]\n", "needs exactly one of builtin, plain, features"),
    ("study = 'phac2-dap'\n[dataset]\nbuiltin = 'phac2-penn'\nplain = 'x'\n", "needs exactly one of"),
    ("study = 'phac2-dap'\n[dataset]\nbuiltin = 'phac2-h5'\n", "needs path"),
    ("study = 'phac2-dap'\n[dataset]\nbuiltin = 'phac2-penn'\n[features]\nstatistics = ['mean']\n",
     "apply to plain signal datasets only"),
    ("study = 'phac2-dap'\n[dataset]\nbuiltin = 'phac2-penn'\n[splits]\nkinds = ['file', 'random']\n",
     "cannot be combined"),
    ("study = 'phac2-dap'\n[dataset]\nbuiltin = 'phac2-penn'\n[svm]\ncv = 1\n", "cv = 1"),
    ("study = 'phac2-dap'\n[dataset]\nbuiltin = 'phac2-penn'\n[methods]\ndap = false\n", "always runs DAP"),
    ("study = 'phac2-dap'\n[dataset]\nbuiltin = 'phac2-penn'\n[gzsl]\nholdout_fraction = 1.5\n", "(0, 1)"),
    ("study = 'phac2-dap'\n[dataset]\nbuiltin = 'phac2-penn'\n[compute]\nscheduler = 'tcp://x:1'\n",
     "needs backend = 'dask'"),
    ("study = 'hand'\n[dataset]\n", "exactly one of builtin = 'hand-simulated', grasps"),
    ("study = 'fabric'\n[features]\nconditions = []\n", "conditions is empty"),
    ("study = 'fabric'\n[splits]\nconfigs = [3]\n", "3 is not one of [1, 2]"),
    ("study = 'clustering'\n", "expected one of phac2-dap, fabric, hand"),
    ("[dataset]\nbuiltin = 'phac2-penn'\n", "missing key study"),
    ("study = 'phac2-dap'\ndataset = 3\n", "dataset must be a table"),
    ("study = 'phac2-dap\n", "not valid TOML"),
])
def test_bad_files_are_config_errors_naming_the_file(tmp_path, text, message):
    path = _write(tmp_path, text)
    with pytest.raises(ConfigError, match=None) as err:
        load_experiment(path)
    assert message in str(err.value)
    assert str(path) in str(err.value)


def test_missing_file(tmp_path):
    with pytest.raises(ConfigError, match="experiment file not found"):
        load_experiment(tmp_path / "nope.toml")


def test_svm_settings_keep_only_departures_from_attribute_svm_defaults(tmp_path):
    path = _write(tmp_path, "study = 'phac2-dap'\n[dataset]\nbuiltin = 'phac2-penn'\n[svm]\ncv = 0\nn_C = 3\n"
                            "n_gamma = 2\nC_range = [1, 10]\n[compute]\nn_jobs = 2\n")
    config = dap_config(load_experiment(path))
    assert config.svm_params == {"n_gamma": 2, "C_range": (1.0, 10.0)}  # cv None and n_C 3 are the defaults
    assert config.n_jobs == 2
    assert dap_config(load_experiment(path), n_jobs=4, progress=False).n_jobs == 4


def test_paths_are_relative_to_the_file(tmp_path):
    sub = tmp_path / "exps"
    sub.mkdir()
    exp = load_experiment(_write(sub, "study = 'phac2-dap'\n[dataset]\nplain = '../data/set'\n"))
    assert exp.resolve(exp.settings["dataset"]["plain"]) == sub / "../data/set"
    assert exp.resolve("/abs/x") == Path("/abs/x")


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
multilabel = false
sweep = false
eszsl = true
embedding = false
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
    results = run_experiment(path, out=tmp_path / "res", echo=lines.append)
    names = {p.name for p in results.written}
    assert {"table1_fusion.csv", "table2_priors.csv", "phac2_methods.csv", "gzsl.csv", "manifest.json",
            "attribute_accuracy.png"} <= names
    assert not {"multilabel.csv", "attribute_sweep.csv", "table3_challenging.csv"} & names
    t1 = pd.read_csv(tmp_path / "res" / "table1_fusion.csv")
    assert "avgdap" in t1.columns and "maxdap" not in t1.columns and "paper_maxdap" not in t1.columns
    t2 = pd.read_csv(tmp_path / "res" / "table2_priors.csv")
    assert {"uni", "train", "paper_uni"} <= set(t2.columns) and "test" not in t2.columns
    methods = pd.read_csv(tmp_path / "res" / "phac2_methods.csv")
    assert "eszsl" in methods.columns and not any(c.startswith("embedding") for c in methods.columns)
    gzsl = pd.read_csv(tmp_path / "res" / "gzsl.csv")
    assert set(gzsl["method"]) == {"eszsl"} and not gzsl["calibrated"].any()
    manifest = json.loads((tmp_path / "res" / "manifest.json").read_text())
    assert manifest["experiment_toml"] == RUN_TOML
    assert manifest["config"]["phac2_dap"]["svm_params"] == {"cv": 3, "n_C": 1, "n_gamma": 1, "n_draws": 1}
    assert manifest["config"]["gzsl"]["holdout_fraction"] == 0.25
    assert any("Generalised zero-shot" in line for line in lines)
    assert not any("maxdap" in line for line in lines)
    # existing results are refused before any computation, replaced with force
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
