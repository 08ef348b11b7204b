"""The generated block of the fabric paper's pipeline on PhysiCLeAR, from small results folders."""

from __future__ import annotations

import pandas as pd
import pytest

from tzsl.reporting.benchmark_blocks import MissingResults
from tzsl.reporting.physiclear_block import PHYSICLEAR_SPLITS, physiclear_block, zero_shot_rows

#: Per-class accuracy of each method on the validation (3 objects) and test (4 objects) split.
ACCURACY = {"dap-avg-logistic-c1": ([1, 0, 0], [1, 1, 0, 0]), "embedding_lam_0": ([1, 0, 0], [0, 0, 0, 0]),
            "embedding_lam_1": ([1, 1, 0], [1, 0, 0, 0]), "embedding_lam_inf": ([1, 1, 0], [1, 1, 1, 1])}


def _zero_shot(folder):
    folder.mkdir(parents=True)
    rows = [{"method": m, "split": split, "class": f"{split}-{k}", "accuracy": a}
            for m, per_split in ACCURACY.items() for split, accs in zip(PHYSICLEAR_SPLITS, per_split, strict=True)
            for k, a in enumerate(accs)]
    pd.DataFrame(rows).to_csv(folder / "class_accuracy.csv", index=False)
    per_split = pd.DataFrame([{"split": s, **{m: 0.5 + i / 10 for m in ACCURACY}}
                              for i, s in enumerate(PHYSICLEAR_SPLITS)])
    per_split.to_csv(folder / "methods_per_split.csv", index=False)


def _deep(folder):
    folder.mkdir(parents=True)
    rows = [{"protocol": p, "method": m, "zero_shot": True, "accuracy": 0.4, "per_class_mean_accuracy": v,
             "per_class_mean_accuracy_ci95_low": v - 0.1, "per_class_mean_accuracy_ci95_high": v + 0.1,
             "chance": 0.25, "chosen_on_validation": p == "validation" and m == "lam_1"}
            for p, scores in (("validation", {"lam_0": 0.3, "lam_1": 0.6}), ("test", {"lam_0": 0.2, "lam_1": 0.5}))
            for m, v in scores.items()]
    pd.DataFrame(rows).to_csv(folder / "fabric_deep_table.csv", index=False)


def test_each_model_has_its_validation_and_test_score_with_intervals_and_the_chosen_lambdas(tmp_path):
    _zero_shot(tmp_path / "zero-shot")
    rows = zero_shot_rows(tmp_path / "zero-shot").set_index("method")
    assert rows.loc["embedding_lam_inf", "test"] == 1.0 and rows.loc["dap-avg-logistic-c1", "test"] == 0.5
    assert rows.loc["dap-avg-logistic-c1", "test_low"] <= 0.5 <= rows.loc["dap-avg-logistic-c1", "test_high"]
    assert rows["test_chance"].eq(0.25).all() and rows["validation_chance"].eq(1 / 3).all()
    assert rows.loc["embedding_lam_1", "test_trial"] == pytest.approx(0.6)  # the test split's trial accuracy
    with pytest.raises(MissingResults, match="physiclear-deep"):
        physiclear_block(tmp_path)
    _deep(tmp_path / "deep")
    lines = physiclear_block(tmp_path).splitlines()
    rows_of = {line.split("|")[2].strip(): line for line in lines if line.startswith("| key-frame")}
    # lambda 1 and inf tie on validation (2 of 3): the first in the grid is chosen, never by the test column
    assert rows_of["`embedding_lam_1` ✓"].count("0.250") == 2 and "`embedding_lam_inf`" in rows_of
    assert "| 1.000 [1.000, 1.000] |" in rows_of["`embedding_lam_inf`"]
    assert "`lam_1` ✓" in rows_of and "0.500 [0.400, 0.600]" in rows_of["`lam_1` ✓"]
    assert len(rows_of) == len(ACCURACY) + 2
