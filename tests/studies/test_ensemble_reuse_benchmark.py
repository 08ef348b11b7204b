"""experiments/benchmarks/ensemble_reuse.py (issue 43 item 4): the script loads, its two ensembles are the ones it
names (today's members with today's seeds; the reusing ones with the ensemble's), its summary pairs them on the same
trials, and the summary makes the benchmark README's generated block with the rule's verdict. It measures nothing."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from tests.benchmark_scripts import benchmark_script
from tzsl.reporting.benchmark_blocks import MissingResults, ensemble_reuse_block


@pytest.fixture(scope="module")
def bench():
    with benchmark_script("ensemble_reuse.py") as module:
        yield module


def test_the_two_ensembles(bench):
    separate = bench.ensemble_spec("separate", 7)
    assert separate["pin_members"] is False
    assert [m["name"] for m in separate["methods"]] == ["dap-avg", "eszsl", "sae"]
    assert separate["methods"][0]["estimator"].get_params()["grid"] == "paper"
    assert separate["methods"][0]["estimator"].cv == 5
    # the seeds today's ensemble drew for its members: SeedSequence([seed, member]), shifted right once
    assert [m["random_state"] for m in separate["methods"]] == [
        int(np.random.SeedSequence([7, j]).generate_state(1)[0] >> 1) for j in range(3)]
    reusing = bench.ensemble_spec("reusing", 7)
    assert reusing["pin_members"] is True
    assert reusing["methods"] == [{"name": name, "random_state": 7} for name in ("dap-avg", "eszsl", "sae")]


def _trials(bench, shift: float, n_splits=3, n_trials=30, seed=0) -> pd.DataFrame:
    """Trial rows of both ensembles on the same trials; ``reusing``'s posteriors are ``separate``'s logits plus
    ``shift`` times noise (0: the same posteriors)."""
    rng = np.random.default_rng(seed)
    rows = []
    for split in range(n_splits):
        y = rng.integers(0, 4, n_trials)
        logits = rng.normal(size=(n_trials, 4)) + 1.5 * np.eye(4)[y]
        noise = rng.normal(size=logits.shape)
        for variant, z in (("separate", logits), ("reusing", logits + shift * noise)):
            proba = np.exp(z - z.max(axis=1, keepdims=True))
            proba /= proba.sum(axis=1, keepdims=True)
            part = pd.DataFrame(bench.trial_rows("phac2", split, variant, "ensemble", proba, y, 1.0,
                                                 9.0 if variant == "separate" else 1.0))
            rows.append(part.assign(chance=0.25, compared_cpu_s=20.0, fit_store_hit=0 if variant == "separate" else 12,
                                    fit_store_miss=150 if variant == "separate" else 5))
    return pd.concat(rows, ignore_index=True)


def test_the_summary_pairs_the_ensembles_and_makes_the_block(bench, tmp_path):
    with pytest.raises(MissingResults, match="ensemble_reuse.py"):
        ensemble_reuse_block(tmp_path)
    for purpose, seed in (("confirm", 1), ("select", 0)):
        table = _trials(bench, 0.0, seed=seed)
        summary = bench.summarise(table, purpose=purpose, seed=seed)
        r = summary.iloc[0]
        assert r["n_splits"] == 3 and r["n_trials"] == 90 and r["chance"] == 0.25
        # the same posteriors: no difference, and each inside the other's interval
        assert r["accuracy_difference"] == 0 and r["ece_difference"] == pytest.approx(0)
        assert r["reusing_accuracy"] == r["separate_accuracy"] and r["rule_holds"]
        assert r["separate_cpu_s"] == 27.0 and r["reusing_cpu_s"] == 3.0 and r["compared_cpu_s"] == 60.0
        assert r["reusing_fit_store_hit"] == 36 and r["separate_fit_store_miss"] == 450
        bench.write_results(table, summary, tmp_path / purpose, purpose=purpose, seed=seed)
    block = ensemble_reuse_block(tmp_path)
    lines = [line for line in block.splitlines() if line.startswith(("| select", "| confirm"))]
    assert [line.split("|")[1].strip() for line in lines] == ["select", "confirm"]  # selection first
    assert all("| 27.0 | 3.0 (60.0) | 0 / 450; 36 / 15 |" in line for line in lines)
    assert "(holds)" in block and "the ensemble's members are the compared methods' fits by default." in block


def test_the_block_states_the_rule_s_verdict_both_ways(bench, tmp_path):
    far = bench.summarise(_trials(bench, 3.0), purpose="select", seed=0)  # other posteriors: out of the intervals
    r = far.iloc[0]
    assert not r["rule_holds"]
    assert r["accuracy_within"] == (r["separate_accuracy_ci95_low"] <= r["reusing_accuracy"]
                                    <= r["separate_accuracy_ci95_high"])
    assert r["ece_difference_ci95_low"] <= r["ece_difference"] <= r["ece_difference_ci95_high"]
    bench.write_results(_trials(bench, 3.0), far, tmp_path, purpose="select", seed=0)
    block = ensemble_reuse_block(tmp_path)
    assert "the former members stay." in block and "(does not hold)" in block
