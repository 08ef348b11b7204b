"""``tzsl evaluate-fabric`` end to end on the real fabric depth images."""

from __future__ import annotations

import pandas as pd
import pytest
from click.testing import CliRunner

from tzsl.cli import EXIT_TZSL_ERROR, cli


def _run(*args: str):
    return CliRunner().invoke(cli, list(args))


@pytest.mark.slow
def test_evaluate_fabric_prints_table_and_refuses_overwrite(data_dir, tmp_path):
    out = tmp_path / "results"
    args = ["evaluate-fabric", "--out", str(out), "--n-seeds", "1", "--config", "1", "--data-dir", str(data_dir),
            "--no-progress", "--n-jobs", "2"]
    result = _run(*args)
    assert result.exit_code == 0, result.output
    lines = result.output.splitlines()
    header = next(line for line in lines if line.startswith("condition"))
    for col in ("lam=0", "lam=0.1", "lam=1", "lam=10", "lam=inf", "ESZSL"):
        assert col in header
    assert "protocol" in header
    rows = [line for line in lines if line.startswith("depth-")]
    assert [r.split()[:3] for r in rows] == [[c, "1", p] for c in ("depth-sequence", "depth-image")
                                             for p in ("paper", "zero-shot-drop")]
    paper = [r for r in rows if " paper " in r]
    assert all("[75.45]" in r and "[68.21]" in r for r in paper)  # the paper's Average row beside its split only
    assert not any("[" in r for r in rows if "zero-shot-drop" in r)
    table = pd.read_csv(out / "fabric_table1.csv")
    assert table["config"].tolist() == [1, 1, 1, 1]
    assert table[["lam_0", "lam_0.1", "lam_1", "lam_10", "lam_inf", "ESZSL"]].stack().between(0, 1).all()

    before = (out / "fabric_table1.csv").read_bytes()
    again = _run(*args)
    assert again.exit_code == EXIT_TZSL_ERROR
    assert "already exists; use --force" in again.output
    assert again.output.count("\n") == 1  # one line, no traceback
    assert (out / "fabric_table1.csv").read_bytes() == before


def test_evaluate_fabric_option_errors(tmp_path, data_dir):
    bad_model = _run("evaluate-fabric", "--model", "quantum", "--out", str(tmp_path))
    assert bad_model.exit_code == 2 and "Invalid value for '--model'" in bad_model.output
    bad_config = _run("evaluate-fabric", "--config", "3", "--out", str(tmp_path))
    assert bad_config.exit_code == 2
    missing = _run("evaluate-fabric", "--out", str(tmp_path / "o"), "--data-dir", str(data_dir),
                   "--gelsight-root", str(tmp_path / "nowhere"), "--no-progress")
    assert missing.exit_code == EXIT_TZSL_ERROR
    assert "dataset.gelsight_root: folder" in missing.output and "nowhere not found" in missing.output
    assert not (tmp_path / "o" / "fabric_table1.csv").exists()
