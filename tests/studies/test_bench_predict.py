"""``make bench-predict``: the machinery on the smallest run (one method, one repeat, a few grasps), not a timing."""

from __future__ import annotations

import pandas as pd
import pytest

from tzsl.benchmarks.bench_predict import BENCH_COLUMNS, GOAL_COLD_S, GOAL_GRASP_MS, main


def test_bench_writes_every_measure_and_what_a_cold_process_imported(tmp_path, capsys):
    out = tmp_path / "predict_bench.csv"
    main(["--methods", "eszsl", "--repeats", "1", "--grasps", "3", "--out", str(out)])
    table = pd.read_csv(out, dtype={"imports": str}).fillna({"imports": ""})
    assert tuple(table.columns) == BENCH_COLUMNS
    rows = table.set_index("measure")
    assert list(rows.index) == ["cold_help", "cold_predict", "api_load", "api_rank", "api_add"]
    assert rows.at["cold_predict", "payload"] == "npz" and rows.at["cold_predict", "goal"] == GOAL_COLD_S
    assert rows.at["api_add", "n"] == 3 and rows.at["api_add", "goal"] == GOAL_GRASP_MS
    # the linear bundle's cold predict imports neither torch nor scikit-learn (the probe found none)
    assert rows.at["cold_predict", "imports"] == ""
    assert "goal" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        main(["--methods", "eszsl", "--out", str(out)])  # exists, no --force
    with pytest.raises(ValueError, match="unknown method"):
        main(["--methods", "svm-forest", "--out", str(tmp_path / "other.csv")])
