"""The report of a generic study speaks of its dataset; the papers' report keeps the papers' headings.

Small hand-made results folders (no study runs): a manifest naming the study, the method comparison,
the sensor-fusion table and a plain dataset folder whose checksums the manifest records.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from tzsl._io import file_sha256
from tzsl.datasets import write_plain_dataset
from tzsl.reporting.report import render_report
from tzsl.reporting.sections import SECTIONS, fill, table_facts
from tzsl.reporting.summary import headline
from tzsl.reporting.tables import KEY_MAX_COLUMNS, table_view
from tzsl.studies.comparison.method_runs import COMPARISON_COLUMNS


def _text(page: str) -> str:
    body = page[page.index("<body>"):page.index('<section id="provenance">')]
    return " ".join(re.sub(r"<[^>]+>", " ", body).split())


def _fusion(n_test: list[int], chance: float = 0.25) -> pd.DataFrame:
    rows = [{"split": str(i + 1), "n_test_objects": n, "chance": 1 / n, "maxdap": 0.5, "avgdap": 0.55}
            for i, n in enumerate(n_test)]
    rows += [{"split": "mean", "n_test_objects": float(np.mean(n_test)), "chance": chance, "maxdap": 0.5,
              "maxdap_ci95_low": 0.3, "maxdap_ci95_high": 0.7, "avgdap": 0.55, "avgdap_ci95_low": 0.35,
              "avgdap_ci95_high": 0.75},
             {"split": "control", "chance": chance, "maxdap": 0.25, "avgdap": 0.24}]
    return pd.DataFrame(rows)


def _comparison(accuracies: dict[str, tuple[float, float, float]], chance: float = 0.25) -> pd.DataFrame:
    """A method comparison with every column a study writes (:data:`COMPARISON_COLUMNS`)."""
    rows = []
    for method, (acc, low, high) in accuracies.items():
        row = dict.fromkeys(COMPARISON_COLUMNS, np.nan)
        row.update(study="zero-shot", data="my-lab", purpose="confirm", split_kind="random", method=method,
                   accuracy=acc, ci95_low=low, ci95_high=high, chance=chance, reference="dap-avg",
                   difference=acc - 0.5, difference_ci95_low=acc - 0.6, difference_ci95_high=acc - 0.4,
                   ece=0.1, brier=0.6, n_splits=4, n_trials=80, note="")
        rows.append(row)
    return pd.DataFrame(rows)


@pytest.fixture
def lab(tmp_path) -> Path:
    """The results folder of a generic study of a 6-class plain dataset, with its manifest."""
    classes = pd.DataFrame([[1, 0, 1], [0, 1, 1], [1, 1, 0], [0, 0, 1], [1, 0, 0], [0, 1, 0]],
                           index=pd.Index([f"c{i}" for i in range(6)], name="class"), columns=["hard", "soft", "cold"])
    trials = pd.DataFrame({"trial_id": [f"t{i}" for i in range(18)], "class": np.repeat(classes.index, 3)})
    dataset = write_plain_dataset(tmp_path / "my_lab", classes, trials, sensors=["left", "right"],
                                  X=np.random.default_rng(0).normal(size=(18, 2, 3)), feature_names=["f0", "f1", "f2"],
                                  settings={"name": "my-lab"})
    root = tmp_path / "results"
    root.mkdir()
    _fusion([4, 4, 4, 4]).to_csv(root / "table1_fusion.csv", index=False)
    _comparison({"dap-avg": (0.5, 0.3, 0.7), "eszsl": (0.6, 0.4, 0.8), "sae": (0.3, 0.1, 0.5)}).to_csv(
        root / "method_comparison.csv", index=False)
    files = {str(p): file_sha256(p) for p in sorted(dataset.iterdir()) if p.is_file()}
    record = {"study": "zero-shot", "study_kind": "zero-shot", "dataset": "my-lab",
              "labels": {"study": "zero-shot", "data": "my-lab", "paper": False},
              "settings": {"dataset": {"plain": str(dataset)}, "splits": {"n_test": 4, "min_train_negatives": 2}},
              "relaxations": [{"setting": "svm.cv", "asked": 5, "used": 3,
                               "why": "a split has only 3 training objects"}]}
    (root / "manifest.json").write_text(json.dumps({"config": record, "data_files": files,
                                                    "description": "our gripper, our words"}))
    return root


def test_generic_report_opens_with_the_dataset_card_and_summary(lab):
    page = render_report(lab)
    text = _text(page)
    assert "<title>my-lab: zero-shot study</title>" in page and "our gripper, our words" in text
    assert text.index("Dataset: my-lab") < text.index("Summary") < text.index("Contents")
    assert "6 (6 with trials, 6 distinct attribute rows)" in text and "2 (left, right)" in text
    assert "18 (per class: min 3, median 3, max 3)" in text and "3 feature columns per sensor" in text
    assert ("On random splits the most accurate method is eszsl: accuracy 0.600 (95% interval 0.400\u20130.800), "
            "against chance 0.250") in text
    assert "2 of 3 methods have an interval above chance (dap-avg, eszsl)." in text
    assert "svm.cv: asked 5, used 3 (a split has only 3 training objects)" in text
    # named for what they show; the counts come from the table
    assert ("Sensor fusion on random unseen-class splits" in text
            and "(4 random splits of 4 unseen classes each)" in text)
    for paper in ("DAP paper", "PHAC-2", "Deviations from the paper", "[paper]"):
        assert paper not in text


def test_the_card_is_left_out_when_the_dataset_changed_since_the_run(lab, tmp_path):
    classes = tmp_path / "my_lab" / "classes.csv"
    classes.write_text(classes.read_text().replace("c5,0,1,0", "c5,1,1,0"))
    text = _text(render_report(lab))
    assert f"card not shown: {classes} has changed since the run" in text
    assert "distinct attribute rows" not in text and "Summary" in text


def test_no_interval_above_chance_is_said(lab):
    _comparison({"dap-avg": (0.3, 0.1, 0.5), "eszsl": (0.35, 0.2, 0.5)}).to_csv(lab / "method_comparison.csv",
                                                                                index=False)
    lines = headline({"method_comparison": pd.read_csv(lab / "method_comparison.csv")})
    assert len(lines) == 1 and "No method's interval clears chance (2 compared)" in lines[0]
    # without a comparison, the fusion table's mean row ranks MAXDAP and AVGDAP
    only_fusion = headline({"table1_fusion": _fusion([4, 4]).assign(majority=0.3)})
    assert only_fusion[0].startswith("On random splits the most accurate method is AVGDAP: accuracy 0.550")
    assert "trivial baseline (always the most frequent test class) 0.300" in only_fusion[0]


def test_the_papers_report_keeps_the_paper_headings_and_quotes_counts_from_its_tables(tmp_path):
    root = tmp_path / "results"
    root.mkdir()
    _fusion([10, 10, 9]).to_csv(root / "table1_fusion.csv", index=False)
    (root / "manifest.json").write_text(json.dumps({"config": {"studies": {
        "phac2-dap": {"study": "phac2-dap", "labels": {"paper": True}, "svm_params": {"cv": 5}}}},
        "reproduce_studies": ["phac2-dap"]}))
    text = _text(render_report(root))
    assert "DAP paper, Table 1: sensor fusion" in text and "Deviations from the paper" in text
    assert "random object splits (9\u201310 test objects each)" in text
    assert "Dataset:" not in text and "Summary" not in text


def test_fill_leaves_out_what_the_tables_do_not_hold():
    facts = table_facts([_fusion([3, 5, 4])])
    assert facts == {"n_splits": "3", "n_test_objects": "3\u20135"}
    assert fill("On {dataset} ({n_test_objects} each) ({n_objects} objects).", {"dataset": "x", **facts}) == \
        "On x (3\u20135 each)."
    assert fill("{n_splits} splits here", {}) == "Splits here"
    for section in SECTIONS:  # no text quotes a count that is not a placeholder
        for text in filter(None, (section.what, section.paper_what)):
            assert not re.search(r"\b(?:1[0-9]|2[0-9]|five|ten)\b (?:test|splits|objects|fixed)", text, re.I), text


def test_a_wide_table_shows_key_columns_and_says_its_one_valued_columns_once():
    table = _comparison({"dap-avg": (0.5, 0.3, 0.7), "eszsl": (0.6, 0.4, 0.8)})
    table.loc[1, "note"] = "same splits"
    view = table_view(table)
    assert view["n_columns"] > KEY_MAX_COLUMNS and not view["transposed"]
    key = view["key"]
    assert key["header"] == ["method", "accuracy (95% CI)", "chance", "difference (95% CI)", "note", "ece (95% CI)",
                             "brier (95% CI)"]
    assert ("study", "zero-shot") in key["constants"] and ("reference", "dap-avg") in key["constants"]
    assert key["rows"][1][:2] == ["eszsl", "0.600 (0.400\u20130.800)"]
    assert not any(h.startswith("paper") for h in view["header"])  # no paper number: no paper column
    # a narrow table has none
    assert table_view(table[["method", "accuracy", "chance"]])["key"] is None
