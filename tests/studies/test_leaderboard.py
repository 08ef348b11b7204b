"""The benchmark folder's leaderboard block (docs) and its page of the HTML report."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from tzsl.models.choices import DEFAULT_METHOD
from tzsl.reporting.benchmark_blocks import MissingResults
from tzsl.reporting.leaderboard import leaderboard_block
from tzsl.reporting.readme_results import BLOCKS
from tzsl.reporting.report import render_report
from tzsl.studies.benchmark.summary import summarise
from tzsl.studies.outputs.results_folder import ResultsDir

METHODS = (DEFAULT_METHOD, "eszsl", "sae")


def _folder(tmp_path, max_splits=None):
    rng = np.random.default_rng(1)
    rows = [{"dataset": d, "method": m, "split": f"{k:02d}", "per_class_accuracy": float(rng.uniform(0.3, 0.8)),
             "trial_accuracy": 0.5, "chance": 1 / n_test}
            for d, n_test in (("alpha", 2), ("beta", 5)) for m in METHODS for k in range(6)]
    scores = pd.DataFrame(rows)
    gzsl = scores[scores["method"] == "eszsl"][["dataset", "method", "split"]].assign(seen=0.5, unseen=0.4,
                                                                                      harmonic=0.44)
    results = ResultsDir(tmp_path / "bench")
    summary = summarise(scores, gzsl, results)
    results.write_manifest({"study": "benchmark", "purpose": "confirm", "splits_version": "v1",
                            "max_splits": max_splits})
    return tmp_path / "bench", scores, summary


def test_the_leaderboard_reads_the_benchmark_tables(tmp_path):
    folder, scores, summary = _folder(tmp_path)
    text = BLOCKS["leaderboard"](folder)
    assert text == leaderboard_block(folder)
    table = [line for line in text.splitlines() if line.startswith("| `")]
    assert len(table) == len(METHODS) + len(METHODS) - 1  # the ranks table, then every method but the reference
    mean = scores[(scores["dataset"] == "alpha") & (scores["method"] == "eszsl")]["per_class_accuracy"].mean()
    row = next(line for line in table if line.startswith("| `eszsl` |"))
    assert f"{mean:.3f} [" in row
    assert "| chance | 0.500 | 0.200 |" in text
    assert "Friedman test over 2 datasets and 3 methods" in text
    assert f"Each method minus `{DEFAULT_METHOD}`" in text


def test_a_quick_look_is_not_a_leaderboard(tmp_path):
    folder, _, _ = _folder(tmp_path, max_splits=2)
    with pytest.raises(MissingResults, match="quick look"):
        leaderboard_block(folder)
    (folder / "ranks.csv").unlink()
    with pytest.raises(MissingResults, match="no ranks.csv"):
        leaderboard_block(folder)


def test_the_report_opens_with_the_benchmark(tmp_path):
    folder, _, _ = _folder(tmp_path)
    page = render_report(folder)
    assert "The benchmark: every method on every dataset" in page
    assert page.count("data:image/png;base64") >= 2  # the critical-difference diagram and the forest plot


def test_the_leaderboard_shows_the_defaults_chosen_across_datasets(tmp_path):
    from tzsl.studies.benchmark.command import write_defaults

    folder, scores, summary = _folder(tmp_path)
    write_defaults(scores, scores, ResultsDir(folder, force=True))
    text = leaderboard_block(folder)
    lodo = [line for line in text.splitlines() if line.startswith(("| alpha (6) |", "| beta (6) |"))]
    assert len(lodo) == 4  # each dataset left out (its 6 complete splits), for the default and for the detector
    assert all(line.count("`") >= 4 for line in lodo)  # the choice made on the other dataset, the hindsight best
    assert "Mean regret of the default chosen with each dataset left out:" in text
    assert "(the goal: at most 0.02)" in text
    assert "The least mean regret any one method reaches on these splits, picked in hindsight:" in text
    ranks = summary["ranks"].set_index("method")["mean_rank"]
    chosen = ranks.idxmin()  # the rule on both datasets: the best mean rank (the scores are both splits' purposes here)
    assert f"Chosen on every dataset's selection splits: default `{chosen}`" in text
    assert "critical-difference diagram" in text
    # the standing rule: the choice replaces the shipped default only if its pooled difference is above 0
    if chosen == DEFAULT_METHOD:
        assert "It is the shipped default." in text
    else:
        meta = pd.read_csv(folder / "meta_analysis.csv").set_index(["method_a", "method_b"])
        above = meta.loc[(chosen, DEFAULT_METHOD), "ci95_low"] > 0
        assert ("the shipped default should become it" if above else "the shipped default stays") in text
