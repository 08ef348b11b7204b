import json

import pandas as pd
import pytest

from tzsl._io import atomic_write, file_sha256
from tzsl.exceptions import ConfigError
from tzsl.experiments._outputs import ResultsDir, package_versions


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
    from tzsl.experiments._outputs import csv_ready

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
