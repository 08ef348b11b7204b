"""``tzsl.run`` from Python: the engine's result as a DataFrame; ``import tzsl`` stays light."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

import tzsl
from tzsl.exceptions import ConfigError

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(Path(__file__).parent))
from test_reproduce import TINY_HAND  # noqa: E402


def test_import_tzsl_is_light():
    code = "import sys, tzsl; print(sorted(m for m in ('pandas', 'sklearn', 'pydantic') if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         env={"PYTHONPATH": str(REPO), "PATH": "/usr/bin:/bin"})
    assert out.stdout.strip() == "[]"


@pytest.mark.slow
def test_run_returns_the_main_table_as_written(tmp_path):
    path = tmp_path / "hand.toml"
    path.write_text(TINY_HAND)
    table = tzsl.run(path, out=tmp_path / "res", n_jobs=1)
    assert isinstance(table, pd.DataFrame)
    assert table.attrs["results_dir"] == str(tmp_path / "res") and "table5" in table.attrs["tables"]
    written = pd.read_csv(tmp_path / "res" / "hand_table5.csv")
    assert list(written.columns) == [str(c) for c in table.columns] and len(written) == len(table)
    with pytest.raises(ConfigError, match="already exists"):
        tzsl.run(path, out=tmp_path / "res")
    with pytest.raises(ConfigError, match="--seed does not apply to study 'hand'"):
        tzsl.run(path, out=tmp_path / "other", seed=1)
