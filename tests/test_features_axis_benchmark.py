"""experiments/benchmarks/features_axis.py's summary and rule on SIMULATED per-trial rows (it measures nothing here),
and the ``features-axis-benchmark`` block rendered from hand-made summaries."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from tests.benchmark_scripts import benchmark_script
from tzsl.reporting import readme_results
from tzsl.reporting.benchmark_blocks import MissingResults
from tzsl.reporting.feature_blocks import features_axis_block


@pytest.fixture(scope="module")
def bench():
    with benchmark_script("features_axis.py") as module:
        yield module


def simulated_trials(bench, better: str, n_splits: int = 6, per_split: int = 20, seed: int = 0) -> pd.DataFrame:
    """Per-trial rows as ``run_dataset`` writes them; ``better`` is right on every trial, the others on half."""
    rng = np.random.default_rng(seed)
    rows = []
    for dataset in ("phac2-hold", "biotac-slide"):
        for feature_set in bench.FEATURE_SETS:
            for split in range(n_splits):
                correct = np.ones(per_split, int) if feature_set == better else rng.integers(0, 2, per_split)
                rows.append(pd.DataFrame({
                    "dataset": dataset, "feature_set": feature_set, "split": split, "trial": np.arange(per_split),
                    "object": [f"o{(split + t) % 5}" for t in range(per_split)], "correct": correct,
                    "fit_cpu_s": 1.0, "features_cpu_s": 2.0, "n_features": 8, "n_sensors": 2, "n_test": 2,
                    "chance": 0.5}))
    return pd.concat(rows, ignore_index=True)


def test_summary_and_rule(bench):
    summary = bench.summarise(simulated_trials(bench, "rocket"), purpose="select", seed=0)
    assert len(summary) == 2 * len(bench.FEATURE_SETS)
    ref = summary[summary["feature_set"] == bench.REFERENCE]
    assert ref["difference"].isna().all() and not ref["gain"].any()
    rocket = summary[summary["feature_set"] == "rocket"]
    assert rocket["gain"].all() and (rocket["difference_ci95_low"] > 0).all()
    assert (summary["n_features"] == 16).all() and (summary["fit_cpu_s"] == 6.0).all()
    assert bench.verdict(summary) == "rocket"
    assert bench.verdict(bench.summarise(simulated_trials(bench, "statistics"), purpose="select", seed=0)) is None


def test_block_renders_from_summaries_and_states_the_verdict(bench, tmp_path):
    for purpose, seed, better in (("select", 0, "statistics"), ("confirm", 1, "rocket")):
        table = simulated_trials(bench, better, seed=seed)
        bench.summarise(table, purpose=purpose, seed=seed).to_csv(
            tmp_path / f"features_axis_summary_both_{purpose}_seed{seed}.csv", index=False)
    text = features_axis_block(tmp_path)
    lines = [line for line in text.splitlines() if line.startswith("| select") or line.startswith("| confirm")]
    assert len(lines) == 2 * 2 * len(bench.FEATURE_SETS)
    assert lines[0].startswith("| select | 0 | phac2-hold | 6 (120) | 0.500 | `statistics` | 16 |")
    assert f"generic default method (`{bench.DEFAULT_METHOD}`)" in text
    assert "`rocket`: does not hold" in text and "the per-channel statistics stay the default" in text
    assert readme_results.BLOCKS["features-axis-benchmark"] is features_axis_block
    with pytest.raises(MissingResults, match="features_axis.py"):
        features_axis_block(tmp_path / "nothing")
