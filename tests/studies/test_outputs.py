import json

import pandas as pd
import pytest

from tzsl._io import atomic_write, file_sha256
from tzsl.exceptions import ConfigError
from tzsl.studies.outputs.results_folder import ResultsDir, package_versions


def test_atomic_write_leaves_old_file_when_writer_fails(tmp_path):
    target = tmp_path / "table.csv"
    target.write_text("old\n")

    def broken(p):
        p.write_text("half")
        raise RuntimeError("interrupted")

    with pytest.raises(RuntimeError):
        atomic_write(target, broken)
    assert target.read_text() == "old\n"
    assert [p.name for p in tmp_path.iterdir()] == ["table.csv"]


def test_results_dir_refuses_overwrite_without_force(tmp_path):
    table = pd.DataFrame({"a": [1, 2]})
    ResultsDir(tmp_path).write_csv("t.csv", table)
    with pytest.raises(ConfigError, match="--force"):
        ResultsDir(tmp_path).write_csv("t.csv", table)
    ResultsDir(tmp_path, force=True).write_csv("t.csv", pd.DataFrame({"a": [3]}))
    assert pd.read_csv(tmp_path / "t.csv")["a"].tolist() == [3]


def test_manifest_records_outputs_data_and_versions(tmp_path):
    data = tmp_path / "data.bin"
    data.write_bytes(b"abc")
    out = ResultsDir(tmp_path / "res")
    out.write_csv("t.csv", pd.DataFrame({"a": [1]}))
    out.write_manifest({"seed": 3}, data_files=[data])
    manifest = json.loads((tmp_path / "res" / "manifest.json").read_text())
    assert manifest["config"] == {"seed": 3}
    assert manifest["data_files"][str(data)] == file_sha256(data)
    assert set(manifest["outputs"]) == {"t.csv"}
    assert manifest["packages"]["numpy"] == package_versions(["numpy"])["numpy"]


def test_csv_numbers_have_one_format_and_counts_stay_integer(tmp_path):
    from tzsl.studies.outputs.results_folder import csv_ready

    table = pd.DataFrame({
        "split": ["1", "2", "mean"],
        "accuracy": [0.1 + 0.32, 0.27999999999999997, 0.35],
        "n_objects": [10.0, 12.0, float("nan")],  # a count that became float through a NaN
        "gamma": [1e-5, 0.01, 0.001],
        "flag": [True, False, True],
    })
    path = ResultsDir(tmp_path).write_csv("t.csv", table)
    lines = path.read_text().splitlines()
    assert lines[0] == "split,accuracy,n_objects,gamma,flag"
    assert lines[1:] == ["1,0.42,10,1e-05,True", "2,0.28,12,0.01,False", "mean,0.35,,0.001,True"]
    back = pd.read_csv(path)
    assert back["accuracy"].tolist() == [0.42, 0.28, 0.35]
    assert str(csv_ready(table)["n_objects"].dtype) == "Int64"
    assert table["n_objects"].dtype == float  # the caller's table is not changed


def test_staged_results_move_into_place_on_commit(tmp_path):
    from tzsl.studies.outputs.results_folder import STAGING_FOLDER

    out = ResultsDir(tmp_path / "res", staging=True)
    out.write_csv("a.csv", pd.DataFrame({"x": [1]}))
    out.write_manifest({"k": 1})
    assert not (tmp_path / "res" / "a.csv").exists() and (tmp_path / "res" / STAGING_FOLDER / "a.csv").exists()
    out.commit()
    assert sorted(p.name for p in (tmp_path / "res").iterdir()) == ["a.csv", "manifest.json"]
    assert (out.root == tmp_path / "res"
            and out.written == [tmp_path / "res" / "a.csv", tmp_path / "res" / "manifest.json"])
    manifest = json.loads((tmp_path / "res" / "manifest.json").read_text())
    assert manifest["outputs"]["a.csv"] == file_sha256(tmp_path / "res" / "a.csv")
    again = ResultsDir(tmp_path / "res", staging=True)
    with pytest.raises(ConfigError, match=r"res/a.csv already exists; use --force"):
        again.write_csv("a.csv", pd.DataFrame({"x": [2]}))


def test_a_crashed_run_does_not_block_the_rerun(tmp_path, monkeypatch):
    """A run killed before it completes leaves only the staging folder; the rerun (no --force) succeeds."""
    import numpy as np

    from tzsl.datasets import FeatureSet, feature_set_to_plain
    from tzsl.studies.engine import run_experiment
    from tzsl.studies.outputs.results_folder import STAGING_FOLDER

    rng = np.random.default_rng(0)
    n, trials, m = 12, 3, 4
    A = ((np.arange(1, n + 1)[:, None] >> np.arange(m)) & 1).astype(int)
    names = [f"o{i:02d}" for i in range(n)]
    X = np.repeat(A[:, None, :].astype(float) @ rng.normal(size=(1, m, 3)), trials, axis=0)
    X = X + 0.3 * rng.normal(size=X.shape)
    table = pd.DataFrame({"trial_id": [f"{o}_{t}" for o in names for t in range(trials)],
                          "object_id": np.repeat(np.arange(n), trials), "object_name": np.repeat(names, trials),
                          "trial_index": np.tile(np.arange(1, trials + 1), n)})
    attrs = pd.DataFrame(A, index=pd.Index(names, name="object_name"), columns=[f"a{j}" for j in range(m)])
    feature_set_to_plain(FeatureSet(X=X, trials=table, sensors=("s",), feature_names=("f0", "f1", "f2"),
                                    attributes=attrs, dataset="simulated"), tmp_path / "toyset")
    exp = tmp_path / "exp.toml"
    exp.write_text('study = "phac2-dap"\n[dataset]\nplain = "toyset"\n[methods]\nfusions = ["avg"]\n'
                   'priors = ["uni"]\n[splits]\nkinds = ["random"]\nn_splits = 1\nn_test = 4\n'
                   '[svm]\ncv = 3\nundersampling = "none"\nn_C = 1\nn_gamma = 1\nn_draws = 1\n'
                   '[compute]\ncache = false\nprogress = false\n', encoding="utf-8")
    out = tmp_path / "res"

    def crash(self, *args, **kwargs):
        raise KeyboardInterrupt  # the run dies after its tables, before the manifest

    with monkeypatch.context() as patch:
        patch.setattr(ResultsDir, "write_manifest", crash)
        with pytest.raises(KeyboardInterrupt):
            run_experiment(exp, out=out)
    assert [p.name for p in out.iterdir()] == [STAGING_FOLDER]  # nothing in place, the tables staged
    assert (out / STAGING_FOLDER / "table1_fusion.csv").exists()
    results, _ = run_experiment(exp, out=out)  # no --force needed
    names = sorted(p.name for p in out.iterdir())
    assert STAGING_FOLDER not in names and "table1_fusion.csv" in names and "manifest.json" in names
    manifest = json.loads((out / "manifest.json").read_text())
    assert set(manifest["outputs"]) == set(names) - {"manifest.json"}
    with pytest.raises(ConfigError, match="already exists; use --force"):  # a completed run is protected
        run_experiment(exp, out=out)


def test_staging_lock_refuses_a_live_writer_and_takes_over_a_dead_one(tmp_path):
    import subprocess
    import sys

    from tzsl.studies.outputs.results_folder import STAGING_FOLDER, STAGING_LOCK

    staging = tmp_path / "res" / STAGING_FOLDER
    staging.mkdir(parents=True)
    live = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(30)"])
    try:
        (staging / STAGING_LOCK).write_text(str(live.pid))
        with pytest.raises(ConfigError, match=rf"another tzsl run \(process {live.pid}\) is writing"):
            ResultsDir(tmp_path / "res", staging=True).write_csv("a.csv", pd.DataFrame({"x": [1]}))
    finally:
        live.kill()
        live.wait()
    (staging / STAGING_LOCK).write_text(str(live.pid))  # now a dead process: a crashed run's lock
    out = ResultsDir(tmp_path / "res", staging=True)
    out.write_csv("a.csv", pd.DataFrame({"x": [1]}))
    out.commit()
    assert sorted(p.name for p in (tmp_path / "res").iterdir()) == ["a.csv"]


def test_commit_refuses_a_file_that_appeared_meanwhile(tmp_path):
    from tzsl.studies.outputs.results_folder import STAGING_FOLDER

    out = ResultsDir(tmp_path / "res", staging=True)
    out.write_csv("a.csv", pd.DataFrame({"x": [1]}))
    (tmp_path / "res" / "a.csv").write_text("another run's table\n")
    with pytest.raises(ConfigError, match="a.csv appeared while this run was writing"):
        out.commit()
    assert (tmp_path / "res" / "a.csv").read_text() == "another run's table\n"
    assert (tmp_path / "res" / STAGING_FOLDER / "a.csv").exists()


def test_manifest_names_the_commit_read_when_the_folder_opened(tmp_path, monkeypatch):
    """The commit of the code that ran, read before the run: a checkout moving on meanwhile changes nothing."""
    import json
    import re

    from tzsl.studies.outputs import results_folder

    commit = results_folder.source_commit()  # this checkout: a short sha (maybe -dirty), or None outside git
    assert commit is None or re.fullmatch(r"[0-9a-f]{12}(-dirty)?", commit), commit
    monkeypatch.setattr(results_folder, "source_commit", lambda: "0123abcd4567")
    results = results_folder.ResultsDir(tmp_path)
    monkeypatch.setattr(results_folder, "source_commit", lambda: "89abcdef0123")
    results.write_manifest({})
    assert json.loads((tmp_path / "manifest.json").read_text())["commit"] == "0123abcd4567"
