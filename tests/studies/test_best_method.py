"""The best method with its evidence (issue 23 item 5): picked on selection, reported on confirmation.

Tables here are hand-made method comparisons (no study is run): they test the reading, not a method.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from tzsl.reporting.best_method import best_rows, confirm_choice, findings, split_kinds
from tzsl.reporting.report import render_report


def _comparison(purpose: str, rows: dict[str, tuple[float, float]], study: str = "phac2",
                kind: str | None = None) -> pd.DataFrame:
    """A comparison: method -> (accuracy, paired difference to dap-avg); intervals +-0.05 / +-0.03."""
    out = []
    for method, (acc, diff) in rows.items():
        ref = method == "dap-avg"
        out.append({"study": study, "data": "real", "purpose": purpose, "method": method, "accuracy": acc,
                    "ci95_low": acc - 0.05, "ci95_high": acc + 0.05, "reference": "dap-avg", "n_splits": 20,
                    "difference": np.nan if ref else diff,
                    "difference_ci95_low": np.nan if ref else diff - 0.03,
                    "difference_ci95_high": np.nan if ref else diff + 0.03})
    table = pd.DataFrame(out)
    if kind is not None:
        table["kind"] = kind
    return table


def test_split_kinds_from_the_column_or_the_study_label():
    table = pd.DataFrame({"study": ["phac2", "zero-shot", "phac2-challenging", "fabric-depth"]})
    assert list(split_kinds(table)) == ["random", "random", "challenging", "fabric-depth"]
    assert list(split_kinds(table.assign(kind="challenging"))) == ["challenging"] * 4


def test_best_is_the_most_accurate_and_beating_needs_an_interval_above_zero():
    table = _comparison("confirm", {"dap-avg": (0.30, 0), "sae": (0.36, 0.06), "eszsl": (0.32, 0.02)})
    best = best_rows(table).iloc[0]
    assert best["method"] == "sae" and best["beats_reference"] and best["any_beats_reference"]
    close = _comparison("confirm", {"dap-avg": (0.30, 0), "sae": (0.32, 0.02)})
    best = best_rows(close).iloc[0]
    assert best["method"] == "sae" and not best["beats_reference"] and not best["any_beats_reference"]


def test_the_choice_is_made_on_selection_and_reported_from_confirmation():
    """The confirmation numbers are the chosen method's there, even when another method wins there."""
    select = pd.concat([_comparison("select", {"dap-avg": (0.30, 0), "ensemble": (0.40, 0.10), "sae": (0.38, 0.08)},
                                    kind="random"),
                        _comparison("select", {"dap-avg": (0.20, 0), "sae": (0.22, 0.02)}, kind="challenging")])
    confirm = pd.concat([_comparison("confirm", {"dap-avg": (0.31, 0), "ensemble": (0.33, 0.02), "sae": (0.36, 0.05)},
                                     kind="random"),
                         _comparison("confirm", {"dap-avg": (0.21, 0), "sae": (0.19, -0.02)}, kind="challenging")])
    chosen = confirm_choice(select, confirm).set_index("kind")
    assert chosen.loc["random", "chosen"] == "ensemble"  # picked on selection, not sae (confirmation's best)
    assert chosen.loc["random", "accuracy"] == pytest.approx(0.33)
    assert chosen.loc["random", "selection_accuracy"] == pytest.approx(0.40)
    assert not chosen.loc["random", "beats_reference"]  # +0.02 [-0.01, +0.05]: not a new default
    assert chosen.loc["challenging", "chosen"] == "sae" and not chosen.loc["challenging", "beats_reference"]


def test_findings_name_the_best_and_say_when_nothing_beats_the_reference(tmp_path):
    path = tmp_path / "method_comparison.csv"
    _comparison("confirm", {"dap-avg": (0.30, 0), "sae": (0.32, 0.02)}).to_csv(path, index=False)
    lines = findings([path])
    assert any("most accurate method is sae" in line and "+0.020 [-0.010, +0.050]" in line
               and "No method beats dap-avg with an interval excluding 0" in line for line in lines)
    assert any("no rows on challenging splits" in line for line in lines)


def test_the_report_states_the_best_method_of_the_runs_own_comparison(tmp_path):
    table = pd.concat([_comparison("confirm", {"dap-avg": (0.30, 0), "sae": (0.40, 0.10)}, kind="random"),
                       _comparison("confirm", {"dap-avg": (0.25, 0), "eszsl": (0.24, -0.01)}, kind="challenging")])
    table.to_csv(tmp_path / "method_comparison.csv", index=False)
    page = render_report(tmp_path)
    assert "phac2, random splits, confirm splits: the most accurate method is sae" in page
    assert "(interval excludes 0)" in page
    assert "phac2, challenging splits, confirm splits: the most accurate method is the reference dap-avg" in page


def test_the_benchmark_block_shows_the_choice_and_the_verdict(tmp_path):
    """experiments/benchmarks/README.md's generated block, from the benchmark's decision CSV."""
    from tzsl.reporting.benchmark_blocks import BEST_METHOD_FILE, MissingResults, best_method_block
    from tzsl.reporting.readme_results import update_file

    with pytest.raises(MissingResults, match="phac2_best_method.py"):  # no CSV: no block
        best_method_block(tmp_path)
    select = _comparison("select", {"dap-avg": (0.30, 0), "sae": (0.40, 0.10)}, kind="random")
    confirm = _comparison("confirm", {"dap-avg": (0.30, 0), "sae": (0.33, 0.03)}, kind="random")
    decision = confirm_choice(select, confirm)
    decision.insert(0, "seed", 7)
    decision.to_csv(tmp_path / BEST_METHOD_FILE, index=False)
    block = best_method_block(tmp_path)
    assert "| random | `sae` (20) | 0.400 | 0.330 [0.280, 0.380] (20) | +0.030 [+0.000, +0.060] vs `dap-avg` | no |" \
        in block
    assert "stays the reference" in block and "(seed 7)" in block
    readme = tmp_path / "README.md"
    readme.write_text("# b\n<!-- results:begin phac2-best-method -->\nold\n<!-- results:end phac2-best-method -->\n")
    assert update_file(readme, tmp_path) and not update_file(readme, tmp_path, check=True)
    assert "+0.030" in readme.read_text()


def test_the_shipped_benchmark_readme_has_the_block():
    readme = Path(__file__).resolve().parents[2] / "experiments" / "benchmarks" / "README.md"
    assert "results:begin phac2-best-method" in readme.read_text()


def test_the_split_kind_of_a_method_comparison_is_its_own_column_not_the_study_label():
    """A zero-shot study on a split file (or challenging splits) is not called random on the terminal."""
    table = pd.DataFrame({"study": "zero-shot", "split_kind": ["file", "challenging", "random"], "method": "dap",
                          "accuracy": 0.5})
    assert split_kinds(table).tolist() == ["file", "challenging", "random"]
    assert split_kinds(table.drop(columns="split_kind")).tolist() == ["random"] * 3
