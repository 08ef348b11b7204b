"""Headline evidence of the PHAC-2 study (issue 23 item 3): DAP fusion x prior with paired differences,
the method comparison on random and challenging splits, and the seed-refit spread beside the split spread.

The features are SYNTHETIC (attribute rows linearly encoded plus noise): the tests check the
tables' logic, they measure nothing.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from tzsl.studies.comparison.method_runs import COMPARISON_COLUMNS, combine_comparisons
from tzsl.studies.config import dap_label
from tzsl.studies.outputs.results_folder import PrefixedResults, ResultsDir
from tzsl.studies.papers.run_labels import StudyLabels
from tzsl.studies.zero_shot.spread import (
    FUSION_PRIOR_TABLE,
    REFIT_TABLE,
    add_refit_spread,
    model_seed,
)
from tzsl.studies.zero_shot.study import fit_split, make_splits, run_zero_shot_tables

sys.path.insert(0, str(Path(__file__).parent))
from test_phac2_dap import _config, synthetic_features

REPO = Path(__file__).resolve().parents[2]
METHODS = [{"name": "eszsl"}, {"name": "devise", "n_epochs": 5}]  # deterministic, seeded


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    """One tiny study on both split kinds, methods compared on both, one refit seed on one split each."""
    features = synthetic_features(n_objects=30, n_attributes=6)
    out = ResultsDir(tmp_path_factory.mktemp("spread"))
    config = _config(n_splits=3, n_test=6, compare_on=("random", "challenging"), refit_seeds=1, refit_splits=1,
                     challenging_min_train_positives=2, kinds=("random", "challenging"), compare=METHODS)
    tables = run_zero_shot_tables(features, out, config, labels=StudyLabels(study="zero-shot", data="synthetic"))
    return features, config, out, tables


def test_model_seed_keeps_the_study_seed_and_gives_refits_their_own():
    assert model_seed(0, 3) == int(np.random.SeedSequence([0, 3]).generate_state(1)[0])  # the fit store's keys
    seeds = {model_seed(0, i, k) for i in range(5) for k in range(3)}
    assert len(seeds) == 15


def test_comparison_has_both_split_kinds_with_split_and_refit_spread(study):
    _, _, out, tables = study
    comparison = tables["method_comparison"]
    assert list(comparison.columns) == [c for c in COMPARISON_COLUMNS if c != "paper_accuracy"]  # not the paper's
    assert list(dict.fromkeys(comparison["split_kind"])) == ["random", "challenging"]
    per_split = tables["methods_per_split"]
    for kind, sub in comparison.groupby("split_kind"):
        rows = per_split[(per_split["split_kind"] == kind) & ~per_split["split"].isin(["mean", "std"])]
        eszsl = sub.set_index("method").loc["eszsl"]
        assert eszsl["n_splits"] == len(rows)
        assert eszsl["sd_over_splits"] == pytest.approx(rows["eszsl"].std(ddof=1))
        # ESZSL takes no seed: refitting "with another seed" is the same fit
        assert eszsl["sd_over_refit_seeds"] == 0
        assert np.isfinite(sub.set_index("method").loc[["dap-avg", "devise_n_epochs_5"], "sd_over_refit_seeds"]).all()
    assert (out.root / "method_comparison.csv").exists() and (out.root / "reliability.png").exists()


def test_fusion_prior_table_pairs_every_variant_with_dap_avg(study):
    _, _, _, tables = study
    table = tables[FUSION_PRIOR_TABLE]
    for _kind, sub in table.groupby("split_kind", sort=False):
        assert len(sub) == 6 and sub["method"].iloc[0] == "dap-avg" and pd.isna(sub["difference"].iloc[0])
        reference = sub["accuracy"].iloc[0]
        others = sub.iloc[1:]
        assert np.allclose(others["difference"], others["accuracy"] - reference)
        assert (others["difference_ci95_low"] <= others["difference"] + 1e-12).all()
        assert (others["difference"] <= others["difference_ci95_high"] + 1e-12).all()
        assert (set(zip(sub["fusion"], sub["prior"], strict=True))
                == {(f, p) for f in ("avg", "max") for p in ("uni", "test", "train")})
    random = table[table["split_kind"] == "random"].set_index("method")
    t1 = tables["table1_fusion"].set_index("split")
    assert random.loc["dap-max", "accuracy"] == pytest.approx(t1.loc["mean", "maxdap"])
    assert random.loc["dap-avg", "sd_over_splits"] == pytest.approx(t1.loc["std", "avgdap"])
    t2 = tables["table2_priors"].set_index("split")
    assert random.loc[dap_label("avg", prior="train"), "accuracy"] == pytest.approx(t2.loc["mean", "train"])


def test_refits_keep_the_split_and_change_the_model_seed(study):
    features, config, _, tables = study
    refits = tables[REFIT_TABLE]
    assert set(refits["refit"]) == {0, 1} and set(refits["split_kind"]) == {"random", "challenging"}
    assert (refits["error"] == "").all()
    assert refits.groupby(["split_kind", "refit"])["split"].nunique().eq(1).all()  # refit_splits = 1
    own = refits[(refits["refit"] == 0) & (refits["split_kind"] == "random") & (refits["method"] == "dap-avg")]
    assert own["accuracy"].item() == pytest.approx(tables["table1_fusion"]["avgdap"].iloc[0])
    dap = refits[refits["method"] == "dap-avg"]
    assert dap.groupby("split_kind")["model_seed"].nunique().eq(2).all()
    # the refit is another fit of the same split: other posteriors, same test objects
    split = make_splits(features, "random", config)[0][0]
    first, again = fit_split(features, split, config, 0), fit_split(features, split, config, 0, refit=1)
    assert np.array_equal(first.y, again.y) and not np.allclose(first.P, again.P)


def test_refit_spread_is_the_pooled_within_split_sd():
    refits = pd.DataFrame({"split_kind": "random", "split": ["1", "1", "1", "2", "2", "2"], "method": "m",
                           "refit": [0, 1, 2] * 2, "accuracy": [0.2, 0.4, 0.3, 0.5, 0.5, 0.5]})
    table = pd.DataFrame({"split_kind": ["random", "challenging"], "method": ["m", "m"],
                          "sd_over_refit_seeds": [np.nan, np.nan], "x": [1, 2]})
    out = add_refit_spread(table, refits)
    assert list(out.columns) == list(table.columns)
    assert out["sd_over_refit_seeds"].iloc[0] == pytest.approx(np.sqrt((0.01 + 0.0) / 2))
    assert pd.isna(out["sd_over_refit_seeds"].iloc[1])  # no refits of that kind


def test_combined_comparison_keeps_split_kinds_apart(study):
    _, _, _, tables = study
    combined = combine_comparisons([tables["method_comparison"]])
    for kind in ("random", "challenging"):
        sub = combined[combined["split_kind"] == kind]
        assert sub["method"].is_unique and {"sae", "dap-avg", "eszsl"} <= set(sub["method"])


def test_prefixed_results_write_every_file_under_the_prefix(tmp_path):
    out = PrefixedResults(ResultsDir(tmp_path), "headlines")
    out.write_csv("table1_fusion.csv", pd.DataFrame({"a": [1]}))
    assert (tmp_path / "headlines_table1_fusion.csv").exists() and out.force is False
    assert PrefixedResults(ResultsDir(tmp_path), "").name("x.csv") == "x.csv"


def test_headlines_preset_is_the_paper_study_with_more_splits(tmp_path):
    from tzsl.exceptions import ConfigError
    from tzsl.studies.config import load_experiment
    from tzsl.studies.zero_shot.runner import zero_shot_outputs

    paper, headlines = load_experiment("phac2-dap"), load_experiment("phac2-headlines")
    evidence = load_experiment("phac2-evidence")  # the headlines' neighbour in the folder of `tzsl evidence`
    assert headlines.config.splits.n_splits >= 50 and paper.config.splits.n_splits < headlines.config.splits.n_splits
    assert (headlines.config.splits.refit_seeds >= 1
            and set(headlines.config.methods.compare_on) == {"random", "challenging"})
    assert headlines.config.svm == paper.config.svm and headlines.config.splits.seed == paper.config.splits.seed
    assert not set(zero_shot_outputs(evidence.config)) & set(zero_shot_outputs(headlines.config)) - {"manifest.json"}
    paper = evidence  # a file with every key the checks below change
    bad = paper.text.replace('[output]', '[output]\nprefix = "Bad Prefix"')
    with pytest.raises(ConfigError, match="prefix"):
        load_experiment(_write(tmp_path / "bad.toml", bad))
    only_random = paper.text.replace('kinds = ["random", "challenging"]', 'kinds = ["random"]')
    only_random = only_random.replace('compare_on = ["random", "challenging"]', 'compare_on = ["challenging"]')
    with pytest.raises(ConfigError, match="compare_on"):
        load_experiment(_write(tmp_path / "random.toml", only_random))


def _write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path
