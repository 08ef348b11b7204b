"""experiments/benchmarks/phac2_eszsl_public.py on SIMULATED features (it measures nothing here): it runs, and
its summary is what the benchmark README's generated block reads."""

from __future__ import annotations

import warnings

import pandas as pd

from tests.benchmark_scripts import benchmark_script
from tests.studies.test_phac2_dap import synthetic_features
from tzsl.reporting.benchmark_blocks import eszsl_public_block


def test_the_benchmark_runs_and_its_summary_makes_the_block(tmp_path):
    with benchmark_script("phac2_eszsl_public.py") as bench:
        features = synthetic_features(n_objects=30, n_attributes=6)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            trials = [bench.run(features, purpose, 0, 2) for purpose in ("select", "confirm")]
    table = bench.summarise(pd.concat(trials, ignore_index=True))
    assert set(table["purpose"]) == {"select", "confirm"} and (table["n_splits"] == 2).all()
    public = table[table["method"] == bench.REFERENCE]
    assert (public["diff_vs_public"] == 0).all() and table["accuracy"].between(0, 1).all()
    table.to_csv(tmp_path / "eszsl_public.csv", index=False)
    block = eszsl_public_block(tmp_path)
    assert block.count("| select |") == block.count("| confirm |") == len(table) // 2
