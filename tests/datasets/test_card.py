"""The dataset card of ``tzsl validate`` (issue 20, item 5)."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
from click.testing import CliRunner

from tzsl.cli import cli
from tzsl.datasets import card_lines, dataset_card, write_plain_dataset

CLASSES = pd.DataFrame({"hard": [1, 1, 0, 0, 1], "soft": [0, 0, 1, 1, 0], "rare": [0, 0, 0, 0, 1]},
                       index=pd.Index(["a", "b", "c", "d", "e"], name="class"))


def test_card_counts_what_a_study_depends_on():
    trials = ["a"] * 3 + ["b"] * 5 + ["c"] * 4 + ["d"] * 4 + ["e"] * 2
    card = dataset_card(CLASSES, trials, n_test=3, min_train_positives=2, min_train_negatives=2)
    assert card["n_classes"] == 5 and card["n_classes_with_trials"] == 5
    assert card["trials_per_class"] == [2, 4.0, 5]
    assert card["positives"] == {"hard": 3, "soft": 2, "rare": 1}
    assert card["identical_rows"] == [["a", "b"], ["c", "d"]]  # no attribute model can tell them apart
    assert card["too_rare"] == ["rare"] and card["n_distinct_rows"] == 3
    assert card["n_test"] == 3 and card["chance"] == 1 / 3
    text = "\n".join(card_lines(card))
    assert "a = b; c = d" in text and "too rare to learn:    rare" in text and "chance 0.333" in text


def test_validate_ends_with_the_card_and_prints_it_as_json(tmp_path):
    rng = np.random.default_rng(0)
    classes = pd.DataFrame((rng.random((12, 4)) < 0.5).astype(int), columns=list("wxyz"),
                           index=pd.Index([f"k{i}" for i in range(12)], name="class"))
    classes.iloc[1] = classes.iloc[0]  # merged rows
    names = np.repeat(classes.index.to_numpy(), 3)
    folder = write_plain_dataset(tmp_path / "ds", classes, pd.DataFrame({"trial_id": [f"t{i}" for i in range(36)],
                                                                          "class": names}),
                                 sensors=["s"], X=rng.normal(size=(36, 1, 2)), feature_names=["f0", "f1"],
                                 settings={"classes": {"allow_identical_rows": True}})
    result = CliRunner().invoke(cli, ["validate", str(folder)])
    assert result.exit_code == 0, result.output
    lines = result.output.splitlines()
    assert lines[-1] == f"{folder}: valid" and "dataset card:" in lines
    assert any(line.startswith("  identical rows:       k0 = k1") for line in lines)
    card = json.loads(CliRunner().invoke(cli, ["validate", str(folder), "--json"]).output)
    assert card["valid"] and card["identical_rows"][0] == ["k0", "k1"] and card["trials_per_class"] == [3, 3.0, 3]
    assert 0 < card["chance"] <= 1 and card["chance"] == 1 / card["n_test"]
