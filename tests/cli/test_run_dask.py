"""``tzsl run FILE --backend dask --scheduler ADDRESS`` on a real (local) Dask cluster = a local run, byte for byte."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from tests.csv_compare import csv_bytes
from tzsl.cli import cli
from tzsl.datasets import write_synthetic_dataset

distributed = pytest.importorskip("distributed")

TOML = """
study = "phac2-dap"
[dataset]
plain = "syn"
[splits]
kinds = ["random"]
n_splits = 1
n_test = 4
[svm]
cv = 2
n_C = 2
n_gamma = 1
n_draws = 1
[compute]
cache = false
progress = false
[output]
folder = "unused"
"""


@pytest.mark.slow
@pytest.mark.parametrize("solver_size", [240, 4800])  # SIMULATED; 3200 training trials > 3000: approximate
def test_run_on_a_dask_scheduler_equals_the_local_run(tmp_path, solver_size, monkeypatch):
    from tzsl.models.detectors import _attribute_bank

    monkeypatch.setattr(_attribute_bank, "PARALLEL_PREDICT_TRIALS", 1000)  # the 4800-trial run predicts on the workers
    write_synthetic_dataset(tmp_path / "syn", solver_size, n_classes=12, n_attributes=6, n_features=4,
                            table_format="parquet")
    toml = tmp_path / "exp.toml"
    toml.write_text(TOML)
    runner = CliRunner()
    local = runner.invoke(cli, ["run", str(toml), "--out", str(tmp_path / "local"), "--n-jobs", "2"])
    assert local.exit_code == 0, local.output
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False, protocol="tcp",
                                  dashboard_address=None) as cluster:
        remote = runner.invoke(cli, ["run", str(toml), "--out", str(tmp_path / "dask"), "--backend", "dask",
                                     "--scheduler", cluster.scheduler_address])
    assert remote.exit_code == 0, remote.output
    tables = sorted(p.name for p in (tmp_path / "local").glob("*.csv"))
    assert "table1_fusion.csv" in tables
    for name in tables:
        assert csv_bytes(tmp_path / "dask" / name) == csv_bytes(tmp_path / "local" / name), name
    manifest = json.loads(Path(tmp_path / "dask" / "manifest.json").read_text())
    assert manifest["config"]["settings"]["compute"]["scheduler"] == cluster.scheduler_address
    solver = manifest["config"]["attribute_solver"][0]["solver"]
    assert solver == ("exact" if solver_size < 1000 else "approximate")
