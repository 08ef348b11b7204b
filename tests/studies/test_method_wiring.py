"""A method registered in one line runs in every study kind (PHAC-2, plain dataset, fabric).

The toy method (nearest training class mean in feature space, that class's attribute row as the
attribute scores) is defined here, registered with :func:`tzsl.models.register_method`, and
named in ``[methods] compare`` of experiment files run by the engine; no study code knows it.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from sklearn.base import BaseEstimator

from tzsl.datasets import FeatureSet, feature_set_to_plain
from tzsl.exceptions import ConfigError
from tzsl.models import NearestAttributeRule, register_method, unregister_method
from tzsl.studies.config import load_experiment
from tzsl.studies.engine import run_experiment


class NearestMeanAttributes(BaseEstimator):
    """Attribute scores of a trial = the attribute row of the nearest training-class mean (softly)."""

    score_kind = "embedding"

    def __init__(self, *, temperature=1.0):
        self.temperature = temperature

    def fit(self, X, Y, groups=None):
        X, Y = np.asarray(X, dtype=float).reshape(len(X), -1), np.asarray(Y, dtype=float)
        keys = np.unique(Y, axis=0, return_inverse=True)[1].ravel() if groups is None else np.unique(
            groups, return_inverse=True)[1].ravel()
        self.means_ = np.stack([X[keys == k].mean(axis=0) for k in range(keys.max() + 1)])
        self.rows_ = np.stack([Y[keys == k][0] for k in range(keys.max() + 1)])
        self.scale_ = X.std(axis=0) + 1e-12
        return self

    def decision_function(self, X):
        Z = np.asarray(X, dtype=float).reshape(len(X), -1) / self.scale_
        d = (((Z[:, None, :] - (self.means_ / self.scale_)[None]) ** 2).sum(-1)) / Z.shape[1]
        w = np.exp(-(d - d.min(axis=1, keepdims=True)) / self.temperature)
        return (w / w.sum(axis=1, keepdims=True)) @ self.rows_


@pytest.fixture
def toy_method():
    register_method("toy", family="embedding", paper="test only", attribute_model=NearestMeanAttributes,
                    decision_rule=NearestAttributeRule)
    yield "toy"
    unregister_method("toy")


def _write(tmp_path: Path, text: str, name: str = "exp.toml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


SMALL_PHAC2 = """
study = "phac2-dap"
[dataset]
{dataset}
[methods]
fusions = ["avg"]
priors = ["uni"]
compare = ["toy", {{name = "toy", temperature = 0.5}}]
[splits]
kinds = ["random"]
n_splits = {n_splits}
n_test = {n_test}
[svm]
cv = 3
undersampling = "none"
n_C = 1
n_gamma = 1
n_draws = 1
[compute]
cache = false
progress = false
"""


def _check_comparison(folder: Path, n_splits: int, data: str) -> pd.DataFrame:
    """Neither run is the paper's protocol: generic file names, no paper column (issue 20)."""
    per_split = pd.read_csv(folder / "methods_per_split.csv")
    assert {"dap-avg", "toy", "toy_temperature_0.5"} <= set(per_split.columns)
    assert not {"eszsl", "embedding_lam_0.1"} & set(per_split.columns)  # not switched on
    table = pd.read_csv(folder / "method_comparison.csv")
    assert table["method"].tolist() == ["dap-avg", "dap-max", "toy", "toy_temperature_0.5"]
    assert (table["study"] == "zero-shot").all() and (table["data"] == data).all()
    assert "paper_accuracy" not in table.columns
    assert (table["n_splits"] == n_splits).all() and table["n_trials"].nunique() == 1
    assert (table["ci95_low"] <= table["accuracy"]).all() and (table["accuracy"] <= table["ci95_high"]).all()
    assert table["accuracy"].between(0, 1).all() and (table["fit_seconds"] >= 0).all()
    toy = table.set_index("method").loc["toy"]
    assert toy["accuracy"] == pytest.approx(per_split.loc[per_split["split"] == "mean", "toy"].iloc[0])
    dap = table.set_index("method").loc["dap-avg"]
    assert toy["difference"] == pytest.approx(toy["accuracy"] - dap["accuracy"], abs=1e-5)  # CSV rounding
    assert toy["difference_ci95_low"] <= toy["difference"] <= toy["difference_ci95_high"]
    assert np.isnan(dap["difference"])
    return table


@pytest.mark.slow  # about 25 s: attribute SVMs on the real data
def test_toy_method_runs_in_a_phac2_study(toy_method, data_dir, tmp_path):
    path = _write(tmp_path, SMALL_PHAC2.format(dataset='builtin = "phac2-penn"\n'
                                                       'min_objects = 15  # 7 attributes: a quick run',
                                                 n_splits=1, n_test=10))
    run_experiment(path, out=tmp_path / "res", data_dir=str(data_dir))
    table = _check_comparison(tmp_path / "res", n_splits=1, data="real")  # min_objects = 15: not the paper's
    assert table["n_trials"].iloc[0] == 100  # 10 test objects x 10 trials


def _plain_dataset(folder: Path, n_objects: int = 16, trials: int = 3) -> None:
    """Objects with distinct 5-bit attribute rows; two sensors whose features follow the attributes."""
    rng = np.random.default_rng(0)
    m = 5
    A = ((np.arange(1, n_objects + 1)[:, None] >> np.arange(m)) & 1).astype(int)
    names = [f"o{i:02d}" for i in range(n_objects)]
    X = np.repeat(np.einsum("om,smd->osd", A.astype(float), rng.normal(size=(2, m, 4))), trials, axis=0)
    X += 0.3 * rng.normal(size=X.shape)
    table = pd.DataFrame({"trial_id": [f"{o}_{t}" for o in names for t in range(trials)],
                          "object_id": np.repeat(np.arange(n_objects), trials),
                          "object_name": np.repeat(names, trials),
                          "trial_index": np.tile(np.arange(1, trials + 1), n_objects)})
    attrs = pd.DataFrame(A, index=pd.Index(names, name="object_name"), columns=[f"a{j}" for j in range(m)])
    fs = FeatureSet(X=X, trials=table, sensors=("left", "right"), feature_names=("f0", "f1", "f2", "f3"),
                    attributes=attrs, dataset="toy")
    feature_set_to_plain(fs, folder)


def test_toy_method_runs_in_a_plain_dataset_study(toy_method, tmp_path):
    _plain_dataset(tmp_path / "toyset")
    path = _write(tmp_path, SMALL_PHAC2.format(dataset='plain = "toyset"', n_splits=2, n_test=4))
    run_experiment(path, out=tmp_path / "res")
    table = _check_comparison(tmp_path / "res", n_splits=2, data="toy")
    assert table["n_trials"].iloc[0] == 2 * 4 * 3
    # the features follow the attributes closely: the toy method is far above chance (1/4)
    assert table.set_index("method").loc["toy", "accuracy"] > 0.5


def _press_video(group: int, press: int, n=20, h=40, w=48) -> np.ndarray:
    rng = np.random.default_rng(100 * group + press)
    yy, xx = np.mgrid[0:h, 0:w]
    texture = np.sin(2 * np.pi * (0.08 + 0.035 * group) * (xx + 0.5 * group * yy)) * (1 + 0.1 * rng.normal(size=(h, w)))
    weight = np.clip((np.arange(n) - 4) / 10.0, 0, 1)
    frames = np.clip(90 + weight[:, None, None] * (60 + 50 * texture[None]), 0, 255).astype(np.uint8)
    return np.repeat(frames[..., None], 3, axis=-1)


def test_toy_method_runs_in_a_fabric_study(toy_method, data_dir, tmp_path):
    iio = pytest.importorskip("imageio.v3")
    root = tmp_path / "gelsight"
    for g in range(8):
        folder = root / "Flat" / f"F{g + 1:04d}"
        folder.mkdir(parents=True)
        for press in range(2):
            iio.imwrite(folder / f"{press + 1}.avi", _press_video(g, press), plugin="FFMPEG", fps=30,
                        codec="mjpeg", quality=10, macro_block_size=16)
    pd.DataFrame({"fabric_id": range(1, 9), "fabric_name": [f"F{g + 1:04d}" for g in range(8)],
                  "group": range(8)}).to_csv(root / "fabric_groups.csv", index=False)
    path = _write(tmp_path, f"""
study = "fabric"
[dataset]
gelsight_root = "{root}"
[features]
conditions = []
[methods]
embedding_lambdas = [0]
alphas = [0.1]
max_iter = 50
compare = ["toy"]
[splits]
configs = [1]
n_seeds = 1
[zero_shot]
enabled = false   # the fabric comparison is what this checks; the generic tables fit every method (minutes)
[compute]
progress = false
""")
    run_experiment(path, out=tmp_path / "res", data_dir=str(data_dir))
    runs = pd.read_csv(tmp_path / "res" / "fabric_runs.csv")
    toy = runs[runs["method"] == "toy"]
    # seeded like every calibrated method (its calibrator deals pseudo-unseen folds): one fit per protocol of
    # the split (the paper's and its zero-shot variant) and seed, here one seed
    assert len(toy) == runs["protocol"].nunique() and toy["seed"].notna().all()
    assert 0 <= toy["accuracy"].iloc[0] <= 1 and toy["fit_seconds"].iloc[0] >= 0
    assert set(runs["method"]) == {"lam_0", "ESZSL", "toy"}
    comparison = pd.read_csv(tmp_path / "res" / "fabric_method_comparison.csv")
    assert comparison["method"].tolist() == ["embedding_lam_0", "eszsl", "toy"]
    assert (comparison["study"] == "fabric-gelsight-Flat").all()
    assert (comparison["reference"] == "embedding_lam_0").all()  # 0.1 not run: the first lambda
    # the comparison runs on the zero-shot protocol of the split (the headline)
    headline = toy[toy["zero_shot"].astype(bool)]
    assert (comparison.set_index("method").loc["toy", "accuracy"]
            == pytest.approx(headline["accuracy"].iloc[0], abs=1e-5))
    manifest = json.loads((tmp_path / "res" / "manifest.json").read_text())  # the run's one manifest
    assert manifest["config"]["fabric"]["methods"] == [{"name": "toy"}]
    assert not (tmp_path / "res" / "fabric_manifest.json").exists()


def test_unknown_methods_and_parameters_are_refused_at_load_time(toy_method, tmp_path):
    path = _write(tmp_path, 'study = "fabric"\n[methods]\ncompare = ["toy", "nope", {name = "toy", depth = 2}]\n')
    with pytest.raises(ConfigError) as info:
        load_experiment(path)
    lines = str(info.value).splitlines()
    assert f"{path}: methods.compare[1].name: unknown method 'nope'; known: " in "\n".join(lines)
    assert any(line.strip().startswith(f"{path}: methods.compare[2]: ") and "'depth'" in line for line in lines)
    unregister_method("toy")
    with pytest.raises(ConfigError, match=r"compare\[0\].name: unknown method 'toy'"):
        load_experiment(path)


def test_input_shape_and_seed_come_from_the_registry(toy_method):
    from tzsl.models import get_method
    from tzsl.studies.comparison.method_runs import method_input, study_estimator, takes_seed

    X = np.arange(24.0).reshape(4, 2, 3)
    assert get_method("dap-avg").input_ndim == 3 and get_method("toy").input_ndim == 2
    assert method_input({"name": "dap-avg"}, X).shape == (4, 2, 3)
    assert method_input({"name": "dap-avg"}, X[:, 0]).shape == (4, 1, 3)  # one sensor
    np.testing.assert_array_equal(method_input({"name": "toy"}, X), X.reshape(4, 6))
    assert takes_seed({"name": "embedding"}) and takes_seed({"name": "eszsl"})  # eszsl: its calibrator's folds
    assert study_estimator({"name": "eszsl"}, 7).random_state == 7
    assert not takes_seed({"name": "embedding", "random_state": 3})
    calibrated = study_estimator({"name": "embedding"}, 7)  # the method inside its calibrator, both seeded
    assert calibrated.estimator.attribute_model.random_state == 7 and calibrated.random_state == 7
    assert study_estimator({"name": "embedding", "random_state": 3}, 7).estimator.attribute_model.random_state == 3
    with pytest.raises(ConfigError, match="input_ndim"):
        register_method("bad", family="embedding", paper="-", attribute_model=NearestMeanAttributes,
                        decision_rule=NearestAttributeRule, input_ndim=4)


# --------------------------------------------------------------------------- a failing (split, method)


class FailsOnSecondFit(NearestMeanAttributes):
    """The toy method, raising on its second fit of the run (the second split)."""

    fits = 0

    def fit(self, X, Y, groups=None):
        type(self).fits += 1
        if type(self).fits == 2:
            raise ValueError("simulated failure on the second split\nsecond line must not be shown")
        return super().fit(X, Y, groups)


@pytest.fixture
def failing_method(monkeypatch, tmp_path):
    FailsOnSecondFit.fits = 0
    # counts its own fits: an empty fit store, so no fit is read back from another test's run
    monkeypatch.setenv("TZSL_CACHE_DIR", str(tmp_path / "own-cache"))
    register_method("flaky", family="embedding", paper="test only", attribute_model=FailsOnSecondFit,
                    decision_rule=NearestAttributeRule, calibratable=False)  # one fit per split, none per fold
    yield "flaky"
    unregister_method("flaky")


def test_a_failing_split_method_is_recorded_and_the_run_exits_1_at_the_end(toy_method, failing_method, tmp_path):
    from click.testing import CliRunner

    from tzsl.cli import cli
    _plain_dataset(tmp_path / "toyset")
    text = SMALL_PHAC2.format(dataset='plain = "toyset"', n_splits=3, n_test=4).replace(
        'compare = ["toy", {name = "toy", temperature = 0.5}]', 'compare = ["toy", "flaky"]')
    path = _write(tmp_path, text)
    result = CliRunner().invoke(cli, ["run", str(path), "--out", str(tmp_path / "res")])
    assert result.exit_code == 1, result.output
    lines = [line for line in result.stderr.strip().splitlines() if not line.startswith("tzsl: warning: ")]
    assert lines[0].startswith("tzsl: error: 1 fit(s) failed; the other results are in ")
    assert len(lines) == 2 and "methods_per_split" in lines[1] and "flaky" in lines[1]
    assert "ValueError: simulated failure on the second split" in lines[1] and "second line" not in result.stderr
    assert "Traceback" not in result.output + result.stderr
    per_split = pd.read_csv(tmp_path / "res" / "methods_per_split.csv").set_index("split")
    splits = [s for s in per_split.index if s not in ("mean", "std")]
    assert len(splits) == 3  # the rest completed
    assert per_split.loc[splits, "flaky"].isna().tolist() == [False, True, False]
    assert per_split.loc[splits, "toy"].notna().all()
    assert per_split.loc[splits[1], "error"].startswith("flaky: ValueError: simulated failure")
    assert per_split.loc[splits, "error"].isna().tolist() == [True, False, True]
    table = pd.read_csv(tmp_path / "res" / "method_comparison.csv").set_index("method")
    assert table.loc["flaky", "n_splits"] == 2 and table.loc["toy", "n_splits"] == 3
    assert np.isfinite(table.loc["flaky", "difference"])  # paired on the 2 splits it completed
    manifest = json.loads((tmp_path / "res" / "manifest.json").read_text())
    assert len(manifest["failures"]) == 1 and "flaky" in manifest["failures"][0]


def test_python_run_returns_the_tables_of_a_partial_run_with_a_warning(toy_method, failing_method, tmp_path):
    from tzsl.studies.engine import run

    _plain_dataset(tmp_path / "toyset")
    text = SMALL_PHAC2.format(dataset='plain = "toyset"', n_splits=2, n_test=4).replace(
        'compare = ["toy", {name = "toy", temperature = 0.5}]', 'compare = ["flaky"]')
    with pytest.warns(RuntimeWarning, match=r"1 fit\(s\) failed"):
        table = run(_write(tmp_path, text), table="methods_per_split", out=tmp_path / "res")
    assert table["flaky"].isna().sum() >= 1 and table.attrs["results_dir"] == str(tmp_path / "res")


def test_a_failing_dap_split_is_recorded_and_the_run_exits_1(tmp_path, monkeypatch):
    import tzsl.studies.zero_shot.study as dap
    from tzsl.exceptions import PartialRunError

    real = dap.fit_split

    def fails_on_split_1(features, split, config, index, multilabel=False):
        if index == 1:
            raise RuntimeError("simulated solver failure\nmore")
        return real(features, split, config, index, multilabel=multilabel)

    monkeypatch.setattr(dap, "fit_split", fails_on_split_1)
    _plain_dataset(tmp_path / "toyset")
    text = SMALL_PHAC2.format(dataset='plain = "toyset"', n_splits=3, n_test=4).replace(
        'compare = ["toy", {name = "toy", temperature = 0.5}]', "")
    with pytest.raises(PartialRunError) as info:
        run_experiment(_write(tmp_path, text), out=tmp_path / "res")
    assert info.value.failures == ["failed_splits: split=2, method=dap: RuntimeError: simulated solver failure"]
    failed = pd.read_csv(tmp_path / "res" / "failed_splits.csv")
    assert failed.to_dict("records") == [{"split": 2, "method": "dap",
                                          "error": "RuntimeError: simulated solver failure"}]
    table1 = pd.read_csv(tmp_path / "res" / "table1_fusion.csv")
    assert table1["split"].astype(str).tolist() == ["1", "3", "mean", "std", "control"]  # the other splits completed
    def always_fails(*args, **kwargs):
        raise RuntimeError("simulated")

    monkeypatch.setattr(dap, "fit_split", always_fails)
    with pytest.raises(RuntimeError, match="simulated"):  # every split failing ends the run with the error
        run_experiment(_write(tmp_path, text.replace("n_splits = 3", "n_splits = 1")), out=tmp_path / "res2")


@pytest.mark.slow  # about 15 s: one simulated data set, one hand model
def test_toy_method_runs_in_the_simulated_hand_study(toy_method, tmp_path):
    path = _write(tmp_path, """
study = "hand"
[dataset]
builtin = "hand-simulated"
[simulation]
n_grasps_per_object = 12
[methods]
max_T = 2
max_k = 2
sequence_length = 4
n_sequences = 4
compare = ["toy", "eszsl"]
[splits]
seeds = [0]
[zero_shot]
enabled = false
[compute]
progress = false
""")
    run_experiment(path, out=tmp_path / "res")
    table = pd.read_csv(tmp_path / "res" / "hand_method_comparison.csv").set_index("method")
    assert list(table.index) == ["hand-dap_fusion_maxdap", "hand-dap_fusion_avgdap", "ldap", "toy", "eszsl"]
    assert (table["data"] == "simulated").all() and table["note"].str.startswith("SIMULATED").all()
    assert (table["reference"] == "ldap").all() and np.isnan(table.loc["ldap", "difference"])
    assert table.loc["ldap", "paper_accuracy"] == pytest.approx(0.5963)
    assert table["n_trials"].nunique() == 1  # every method on the same test grasps
    table5 = pd.read_csv(tmp_path / "res" / "hand_table5.csv")
    ldap = table5[(table5["seed"] == "0") & (table5["method"] == "LDAP")]["all"].iloc[0]
    assert table.loc["ldap", "accuracy"] == pytest.approx(float(ldap), abs=1e-5)


def test_methods_of_other_inputs_are_refused_in_feature_studies(tmp_path):
    path = _write(tmp_path, 'study = "fabric"\n[methods]\ncompare = ["ldap", "cnn-lstm"]\n')
    with pytest.raises(ConfigError) as info:
        load_experiment(path)
    text = str(info.value)
    assert "method 'ldap' takes grasps" in text and "method 'cnn-lstm' takes frames" in text
