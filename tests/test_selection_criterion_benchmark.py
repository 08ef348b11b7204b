"""experiments/benchmarks/selection_criterion.py on a SIMULATED problem (it measures nothing here): its core runs,
its summary has the columns the README block reads, the rule's verdict follows the rule as written, and the
``selection-criterion-benchmark`` block renders from hand-made summaries."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from tests.benchmark_scripts import benchmark_script
from tzsl.reporting import readme_results
from tzsl.reporting.benchmark_blocks import MissingResults, selection_criterion_block

SUMMARY_COLUMNS = {"purpose", "seed", "method", "scoring", "n_splits", "n_fits", "accuracy", "ci95_low", "ci95_high",
                   "chance", "diff_vs_accuracy", "diff_ci95_low", "diff_ci95_high", "n_choice_flips",
                   "n_changed_predictions", "n_test_trials"}
RULE_COLUMNS = {"rule_a_holds", "rule_b_holds", "rule_holds", "rule_min_lower_bound"}


@pytest.fixture(scope="module")
def bench():
    with benchmark_script("selection_criterion.py") as module:
        yield module


def simulated_problem(n_classes=12, n_attributes=6, n_features=8, per_class=5, seed=0):
    """Trials of classes with binary attribute rows, features a noisy linear map of the rows (SIMULATED)."""
    rng = np.random.default_rng(seed)
    rows = rng.integers(0, 2, (n_classes, n_attributes))
    classes = np.array([f"object_{i:02d}" for i in range(n_classes)])
    table = pd.DataFrame(rows, index=classes, columns=[f"attribute_{j}" for j in range(n_attributes)])
    y = np.repeat(np.arange(n_classes), per_class)
    X = rows[y] @ rng.normal(size=(n_attributes, n_features)) + rng.normal(size=(y.size, n_features))
    order = rng.permutation(classes)
    split = SimpleNamespace(train_objects=tuple(order[3:]), test_objects=tuple(order[:3]),
                            kept_attributes=tuple(table.columns))
    return X, classes[y], table, [split]


def test_the_core_runs_every_method_and_scoring_and_summarises(bench, monkeypatch):
    monkeypatch.setattr(bench, "EMBEDDING_MAX_ITER", 30)  # a few seconds; nothing is measured here
    X, objects, table, splits = simulated_problem()
    fits, trials = bench.run(X, objects, table, splits, purpose="select", seed=3)
    assert len(fits) == len(bench.METHODS) * len(bench.SCORINGS)
    assert {"chosen", "chosen_perturbed", "choice_changed", "predictions_changed", "accuracy"} <= set(fits.columns)
    assert (fits["n_test"] == 15).all() and np.allclose(fits["chance"], 1 / 3)
    assert len(trials) == 15 * len(fits) and set(trials["correct"]) <= {0.0, 1.0}
    assert fits.loc[fits.method == "eszsl", "chosen"].str.match(r"gamma=.+,lam=.+").all()
    assert fits.loc[fits.method == "embedding", "chosen"].str.startswith("alpha=").all()
    for _, f in fits.iterrows():  # the per-fit accuracy is the mean of its trials
        t = trials[(trials.method == f.method) & (trials.scoring == f.scoring)]
        assert f.accuracy == pytest.approx(t.correct.mean())
    summary = bench.summarise(fits, trials)
    assert SUMMARY_COLUMNS | RULE_COLUMNS <= set(summary.columns) and len(summary) == len(fits)
    reference = summary[summary.scoring == "accuracy"]
    assert reference["diff_vs_accuracy"].isna().all()
    assert summary.loc[summary.scoring == "neg_log_loss", "diff_ci95_low"].notna().all()
    confirm = bench.summarise(fits.assign(purpose="confirm"), trials.assign(purpose="confirm"))
    assert not RULE_COLUMNS & set(confirm.columns)  # the rule is decided on selection splits only


def hand_made(bench, outcomes, purpose="select", n_splits=4, per_split=10):
    """Fits and trials of methods with given (accuracy-scoring correct share, neg_log_loss share, flips)."""
    fits, trials = [], []
    for method, (p_acc, p_nll, flips) in outcomes.items():
        for scoring, p in zip(bench.SCORINGS, (p_acc, p_nll), strict=True):
            for s in range(n_splits):
                correct = (np.arange(per_split) < round(p * per_split)).astype(float)
                trials.append(pd.DataFrame({"purpose": purpose, "seed": 0, "split": f"s{s}", "method": method,
                                            "scoring": scoring, "class": np.arange(per_split) % 5,
                                            "correct": correct}))
                fits.append({"purpose": purpose, "seed": 0, "split": f"s{s}", "method": method, "scoring": scoring,
                             "n_test": per_split, "chance": 0.2, "choice_changed": s < flips[scoring],
                             "predictions_changed": 2 * int(s < flips[scoring])})
    return pd.DataFrame(fits), pd.concat(trials, ignore_index=True)


OUTCOMES = {  # method: (accuracy by accuracy, by neg_log_loss, changed choices per scoring)
    "eszsl": (0.6, 0.3, {"accuracy": 1, "neg_log_loss": 0}),  # stable but loses accuracy: (b) fails
    "sae": (0.5, 0.5, {"accuracy": 2, "neg_log_loss": 0}),  # stable, same accuracy: the rule holds
    "embedding": (0.4, 0.5, {"accuracy": 0, "neg_log_loss": 0}),  # accuracy never flipped: (a) fails as written
}


def test_the_verdict_follows_the_rule_as_written(bench):
    fits, trials = hand_made(bench, OUTCOMES)
    summary = bench.summarise(fits, trials)
    verdict = summary[summary.scoring == "neg_log_loss"].set_index("method")
    assert verdict.loc["eszsl", "diff_ci95_high"] < bench.MIN_LOWER_BOUND
    assert verdict["rule_b_holds"].to_dict() == {"eszsl": False, "sae": True, "embedding": True}
    assert verdict["rule_a_holds"].to_dict() == {"eszsl": True, "sae": True, "embedding": False}
    assert verdict["rule_holds"].to_dict() == {"eszsl": False, "sae": True, "embedding": False}
    flips = summary.set_index(["method", "scoring"])["n_choice_flips"]
    assert flips[("sae", "accuracy")] == 2 and flips[("sae", "neg_log_loss")] == 0
    unstable = fits.assign(choice_changed=fits.choice_changed | ((fits.method == "sae") & (fits.split == "s3")))
    assert not bench.summarise(unstable, trials).set_index(["method", "scoring"]).loc[("sae", "neg_log_loss"),
                                                                                        "rule_holds"]


def test_the_block_renders_selection_with_the_verdict_then_confirmation(bench, tmp_path, monkeypatch):
    with pytest.raises(MissingResults, match="selection_criterion.py"):
        selection_criterion_block(tmp_path)
    for purpose, seed in (("confirm", 1), ("select", 0)):  # written in the wrong order on purpose
        summary = bench.summarise(*hand_made(bench, OUTCOMES, purpose=purpose))
        name = f"{bench.SUMMARY_PREFIX}{purpose}_seed{seed}.csv"
        bench.write_csv(summary.assign(seed=seed), tmp_path / purpose / name)
    block = selection_criterion_block(tmp_path)
    selection, rule = block.index("Selection splits (seed 0)"), block.index("The rule")
    assert selection < rule < block.index("Confirmation splits (seed 1)")
    assert "| `sae` | 4 | 0.200 | 0.500 [" in block and "| +0.000 [+0.000, +0.000] | 2 / 0 (4) | 4 / 0 (40) |" in block
    assert ("* `sae`: (a) holds (changed choices: accuracy 2, neg_log_loss 0), (b) holds (lower bound +0.000): "
            "neg_log_loss becomes its default.") in block
    assert "* `eszsl`: (a) holds (changed choices: accuracy 1, neg_log_loss 0), (b) does not hold" in block
    assert "* `embedding`: (a) does not hold (changed choices: accuracy 0, neg_log_loss 0), (b) holds" in block
    assert block.count("| `eszsl` |") == 2 and block.count("* `") == 3  # one verdict per method, selection only
    readme = tmp_path / "README.md"
    name = "selection-criterion-benchmark"
    readme.write_text(f"# b\n{readme_results.begin(name)}\nSTALE\n{readme_results.end(name)}\n")
    monkeypatch.setitem(readme_results.BLOCKS, name, selection_criterion_block)  # as registered for `make numbers`
    assert readme_results.update_file(readme, tmp_path)
    assert not readme_results.update_file(readme, tmp_path, check=True) and "STALE" not in readme.read_text()
