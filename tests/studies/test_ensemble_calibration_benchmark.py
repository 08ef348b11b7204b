"""experiments/benchmarks/calibration_refit.py (issue 33): the script loads (its study settings import once
broke it), its ensemble mode's summary compares pinned with search on the same trials, and the summary makes
the benchmark README's generated block. It measures nothing here."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from tests.benchmark_scripts import benchmark_script
from tzsl.reporting.benchmark_blocks import MissingResults, ensemble_calibration_block


@pytest.fixture(scope="module")
def bench():
    with benchmark_script("calibration_refit.py") as module:
        yield module


def _trials(bench, n_splits=2, n_trials=12, seed=0):
    """Trial rows of both refits on the same trials (search's posteriors sharper: another temperature)."""
    rng = np.random.default_rng(seed)
    rows = []
    for split in range(n_splits):
        y = rng.integers(0, 3, n_trials)
        logits = rng.normal(size=(n_trials, 3)) + 2.0 * np.eye(3)[y]
        for refit, temperature in (("pinned", 1.0), ("search", 0.2)):
            z = logits / temperature
            proba = np.exp(z - z.max(axis=1, keepdims=True))
            proba /= proba.sum(axis=1, keepdims=True)
            rows += bench.trial_rows("phac2", split, refit, bench.ENSEMBLE, proba, y, temperature, 1.0 if refit ==
                                     "pinned" else 3.0)
    return pd.DataFrame(rows)


def test_the_summary_pairs_pinned_with_search_and_makes_the_block(bench, tmp_path):
    with pytest.raises(MissingResults, match="calibration_refit.py --method ensemble"):
        ensemble_calibration_block(tmp_path)
    margin, high = bench.RULE_MAX_ECE_DIFFERENCE, None
    for purpose, seed in (("confirm", 1), ("select", 0)):
        table, summary = bench.summarise(_trials(bench, seed=seed), "phac2", 2)
        assert len(summary) == 1 and summary.loc[0, "n_trials"] == 24
        assert summary.loc[0, "accuracy_difference"] == 0  # a temperature keeps the ranking
        r = summary.loc[0]
        assert r["ece_difference"] == pytest.approx(r["pinned_ece"] - r["search_ece"])  # paired on the same trials
        assert r["ece_difference_ci95_low"] <= r["ece_difference"] <= r["ece_difference_ci95_high"]
        assert r["search_ece"] != r["pinned_ece"]
        assert summary.loc[0, "pinned_cpu_s"] == 2.0 and summary.loc[0, "search_cpu_s"] == 6.0
        bench.write_results(table, summary, tmp_path, label="phac2", method=bench.ENSEMBLE, purpose=purpose,
                            seed=seed)
        assert (tmp_path / f"calibration_refit_summary_phac2_ensemble_{purpose}_seed{seed}.csv").is_file()
        high = summary.loc[0, "ece_difference_ci95_high"] if purpose == "select" else high
    block = ensemble_calibration_block(tmp_path)
    lines = [line for line in block.splitlines() if line.startswith("| select") or line.startswith("| confirm")]
    assert [line.split("|")[1].strip() for line in lines] == ["select", "confirm"]  # selection first
    assert all("| 2.0 | 6.0 |" in line for line in lines)
    # the verdict is the rule's, read from the selection row: CPU 2 of 6 s holds; the ECE margin decides
    verdict = "pinned by default" if high <= margin else "keep searching"
    assert f"{100 * bench.RULE_MIN_CPU_SAVING:.0f}% (holds)" in block and verdict in block


@pytest.mark.parametrize("margin", [-1.0, 1.0])
def test_the_block_states_the_rule_s_verdict_both_ways(bench, tmp_path, margin):
    table, summary = bench.summarise(_trials(bench), "phac2", 2)
    bench.write_results(table, summary, tmp_path, label="phac2", method=bench.ENSEMBLE, purpose="select", seed=0,
                        max_ece_difference=margin)
    block = ensemble_calibration_block(tmp_path)
    assert ("the members are pinned by default." in block) == (margin > 0)
    assert ("the members keep searching." in block) == (margin < 0)
