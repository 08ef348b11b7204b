"""The trials table may be Parquet (trials.parquet) and reads exactly as the same CSV; signals read in threads."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from tzsl.datasets import read_plain_dataset, validate_dataset, write_plain_dataset
from tzsl.features import load_plain_dataset

pytest.importorskip("pyarrow")


def _classes() -> pd.DataFrame:
    return pd.DataFrame({"hard": [1, 0, 1], "soft": [0, 1, 1]}, index=pd.Index(["cube", "ball", "disc"], name="class"))


def _to_parquet(folder):
    pd.read_csv(folder / "trials.csv", dtype=str, keep_default_na=False).pipe(
        lambda t: t.astype({c: float for c in t.columns if c.startswith("f_")})).to_parquet(folder / "trials.parquet")
    (folder / "trials.csv").unlink()


def test_parquet_trials_equal_csv(tmp_path):
    rng = np.random.default_rng(0)
    trials = pd.DataFrame({"trial_id": ["t1", "t2", "t3", "t4"], "class": ["cube", "ball", "disc", "cube"]})
    X = rng.normal(size=(4, 2, 3)) / 3.0
    csv = write_plain_dataset(tmp_path / "csv", _classes(), trials, sensors=("l", "r"), X=X,
                              feature_names=("f_a", "f_b", "f_c"))
    pq = write_plain_dataset(tmp_path / "pq", _classes(), trials, sensors=("l", "r"), X=X,
                             feature_names=("f_a", "f_b", "f_c"))
    _to_parquet(pq)
    assert validate_dataset(pq) == []
    a, b = read_plain_dataset(csv), read_plain_dataset(pq)
    np.testing.assert_array_equal(a.X, b.X)  # exact, bit for bit
    pd.testing.assert_frame_equal(a.trials, b.trials)


def test_parquet_problems_name_the_parquet_file(tmp_path):
    trials = pd.DataFrame({"trial_id": ["t1", "t2"], "class": ["cube", "cone"]})
    folder = write_plain_dataset(tmp_path / "pq", _classes(), trials, X=np.ones((2, 1, 1)), feature_names=("f_a",))
    _to_parquet(folder)
    problems = validate_dataset(folder)
    assert [(p.file, p.line) for p in problems] == [("trials.parquet", 3)]
    (folder / "trials.parquet").write_bytes(b"PAR1 broken")
    assert "not a readable Parquet file" in validate_dataset(folder)[0].message


def test_signals_read_in_threads_equal_serial(tmp_path):
    rng = np.random.default_rng(1)
    trials = pd.DataFrame({"trial_id": [f"t{i}" for i in range(12)], "class": ["cube", "ball", "disc"] * 4})
    signals = [[rng.normal(size=(5, 2))] for _ in range(12)]
    folder = write_plain_dataset(tmp_path / "sig", _classes(), trials, signals=signals, channels=("p", "q"))
    data = read_plain_dataset(folder)
    serial = data.read_signals(range(12), 0, n_threads=1)
    threaded = data.read_signals(range(12), 0, n_threads=4)
    for a, b, s in zip(serial, threaded, signals, strict=True):
        np.testing.assert_array_equal(a, b)
        np.testing.assert_array_equal(a, s[0])
    assert load_plain_dataset(folder).X.shape == (12, 1, 8)


def test_a_parquet_table_without_columns_is_one_line(tmp_path):
    """Zero columns gave read_rows ``([], [])`` and scan_classes an IndexError on ``header[0]`` (a traceback)."""
    import pyarrow as pa
    import pyarrow.parquet as pq
    from click.testing import CliRunner

    from tests.datasets.lab_recordings import series_lab
    from tzsl.cli import EXIT_TZSL_ERROR, cli
    from tzsl.datasets import convert_lab_dataset
    from tzsl.exceptions import DataFileError

    mapping = series_lab(tmp_path / "lab")
    pq.write_table(pa.table({}), tmp_path / "lab" / "classes.parquet")
    mapping.write_text(mapping.read_text().replace("classes.csv", "classes.parquet"))
    message = r"classes.parquet:1: table has no columns; expected a header naming its columns$"
    with pytest.raises(DataFileError, match=message):
        convert_lab_dataset("series", mapping, tmp_path / "out", progress=False)
    result = CliRunner().invoke(cli, ["convert", "--from", "series", "--mapping", str(mapping),
                                      "--out", str(tmp_path / "out"), "--no-progress"])
    lines = result.stderr.strip().splitlines()
    assert result.exit_code == EXIT_TZSL_ERROR, (result.output, result.exception)
    assert len(lines) == 1 and "classes.parquet:1: table has no columns" in lines[0], result.stderr
    # the same for a dataset's trials.parquet
    trials = pd.DataFrame({"trial_id": ["t1", "t2"], "class": ["cube", "ball"]})
    folder = write_plain_dataset(tmp_path / "pq", _classes(), trials, X=np.ones((2, 1, 1)), feature_names=("f_a",))
    (folder / "trials.csv").unlink()
    pq.write_table(pa.table({}), folder / "trials.parquet")
    assert [(p.file, p.line, p.message) for p in validate_dataset(folder)] == [
        ("trials.parquet", 1, "table has no columns; expected a header naming its columns")]


def test_a_parquet_column_without_a_name_is_refused_as_in_csv(tmp_path):
    """A Parquet column named "" was taken for no column at all; it gets the CSV reader's problems."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    trials = pd.DataFrame({"trial_id": ["t1", "t2"], "class": ["cube", "ball"]})
    problems = {}
    for kind in ("csv", "parquet"):
        folder = write_plain_dataset(tmp_path / kind, _classes(), trials, X=np.ones((2, 1, 1)), feature_names=("f_a",))
        if kind == "csv":
            (folder / "trials.csv").write_text("trial_id,class,\nt1,cube,1.0\nt2,ball,2.0\n")
        else:
            pq.write_table(pa.Table.from_arrays([pa.array(["t1", "t2"]), pa.array(["cube", "ball"]),
                                                 pa.array([1.0, 2.0])], names=["trial_id", "class", ""]),
                           folder / "trials.parquet")
            (folder / "trials.csv").unlink()
        problems[kind] = [(p.line, p.message) for p in validate_dataset(folder)]
    assert problems["parquet"] == problems["csv"]
    assert problems["parquet"][0] == (1, "header column(s) [3] have no name")
