"""``make bench``'s predict part: the machinery on the smallest run (one method, one repeat, a few grasps), not a
timing."""

from __future__ import annotations

import pandas as pd
import pytest

from tzsl.benchmarks._common import MEASURE_COLUMNS
from tzsl.benchmarks.bench_predict import run_predict


def test_predict_part_measures_every_stage_and_what_a_cold_process_imported():
    table = pd.DataFrame(run_predict(methods=["eszsl"], repeats=1, n_grasps=3, echo=lambda _line: None))
    assert tuple(table.columns) == MEASURE_COLUMNS
    assert table["simulated"].all() and set(table["part"]) == {"predict"}
    assert list(zip(table.study, table.stage, table.run, table.quantity, strict=True)) == [
        ("-", "help", "cold", "wall"), ("-", "help", "cold", "cpu"),
        ("eszsl", "predict", "cold", "wall"), ("eszsl", "predict", "cold", "cpu"),
        ("eszsl", "load", "api", "wall"), ("eszsl", "rank", "api", "per_grasp"), ("eszsl", "add", "api", "per_grasp")]
    rows = table.set_index(["stage", "quantity"])
    assert rows.at[("add", "per_grasp"), "n"] == 3 and rows.at[("add", "per_grasp"), "unit"] == "ms"
    # the linear bundle's cold predict imports neither torch nor scikit-learn (the probe found none)
    assert rows.at[("predict", "wall"), "note"] == "npz bundle; imports: neither torch nor scikit-learn"
    with pytest.raises(ValueError, match="unknown method"):
        run_predict(methods=["svm-forest"])
