"""``tzsl benchmark``: a lab's datasets run on the benchmark's methods, metrics and split recipe, end to end."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from sklearn.base import BaseEstimator

from tzsl.cli import cli
from tzsl.datasets import write_synthetic_dataset
from tzsl.features import load_features
from tzsl.models import NearestAttributeRule, register_method, unregister_method
from tzsl.studies.benchmark.runner import BENCHMARK_DETECTORS, DEFAULTS_DETECTORS, benchmark_methods
from tzsl.studies.benchmark.splits import n_test_of, standard_splits
from tzsl.studies.benchmark.summary import BENCHMARK_FILES, complete_splits, ranked_methods, summarise

METHODS = ("eszsl", "sae")
#: Standard splits per dataset the tests run (the benchmark's 20 would take minutes).
MAX_SPLITS = 2


@pytest.fixture(scope="module")
def labs(tmp_path_factory):
    """Two SIMULATED plain-file datasets (12 classes each), as two labs would bring them."""
    root = tmp_path_factory.mktemp("labs")
    for seed, name in enumerate(("lab_a", "lab_b")):
        write_synthetic_dataset(root / name, 48, n_classes=12, n_attributes=8, n_sensors=1, n_features=6,
                                noise=0.5, seed=seed)
    return root


def _benchmark(labs, out, *extra):
    args = ["benchmark", "--no-catalog", "--add", str(labs / "lab_a"), "--add", str(labs / "lab_b"),
            *(a for m in METHODS for a in ("--method", m)), "--max-splits", str(MAX_SPLITS), "--out", str(out), *extra]
    return CliRunner().invoke(cli, args)


def test_two_labs_datasets_give_every_table_a_rerun_is_restored_and_no_fit_is_made_twice(labs, tmp_path, monkeypatch):
    out = tmp_path / "bench"
    monkeypatch.setenv("TZSL_STUDY_CACHE", "1")
    result = _benchmark(labs, out)
    assert result.exit_code == 0, result.output
    for name in BENCHMARK_FILES:
        assert (out / name).is_file() and (out / name).stat().st_size > 0, name
    scores = pd.read_csv(out / "scores.csv")
    table = load_features(plain=labs / "lab_a").attributes
    n_confirm = min(MAX_SPLITS, sum(s.name.startswith("confirm-") for s in standard_splits(table)))
    assert set(scores["dataset"]) == {"lab_a", "lab_b"}
    assert {"dap-avg-logistic-c1", *METHODS} <= set(scores["method"])
    assert scores.groupby(["dataset", "method"])["split"].nunique().eq(n_confirm).all()
    assert scores["chance"].eq(1 / n_test_of(table)).all()
    assert scores[["per_class_accuracy", "trial_accuracy"]].notna().all().all()
    assert scores[["per_class_accuracy", "trial_accuracy"]].stack().between(0, 1).all()
    # the experiment file of each dataset runs alone with tzsl run, and names the recipe's split file
    experiment = (out / "experiments" / "lab_a.toml").read_text()
    assert 'kinds = ["file"]' in experiment and 'purpose = "confirm"' in experiment
    ranks = pd.read_csv(out / "ranks.csv")
    assert ranks["n_datasets"].eq(2).all() and np.isclose(ranks["mean_rank"].sum(), len(ranks) * (len(ranks) + 1) / 2)
    friedman = pd.read_csv(out / "friedman.csv").iloc[0]
    assert friedman["n_datasets"] == 2 and friedman["critical_difference"] > 0
    meta = pd.read_csv(out / "meta_analysis.csv")
    assert len(meta) == len(ranks) * (len(ranks) - 1)
    lines = result.output.replace(str(out), "OUT").splitlines()
    assert f"note: only the first {MAX_SPLITS} standard splits" in result.output
    assert len(lines) <= 13 and max(map(len, lines)) <= 120, result.output
    assert any(line.startswith("  lab_a: best ") and "chance 0.500" in line for line in lines), result.output
    manifest = json.loads((out / "manifest.json").read_text())
    assert [d["status"] for d in manifest["config"]["datasets"]] == ["done", "done"]

    refused = _benchmark(labs, out)
    assert refused.exit_code == 3 and "already exists; use --force" in refused.output
    before = (out / "scores.csv").read_bytes()
    again = _benchmark(labs, out, "--force")
    assert again.exit_code == 0, again.output
    assert "lab_a: restored from the study cache" in again.output
    assert (out / "scores.csv").read_bytes() == before
    # the methods changed, so no study is restored: every fit they ask for comes back from the fit store (a method
    # or dataset added later makes only its own fits)
    fewer = CliRunner().invoke(cli, ["benchmark", "--no-catalog", "--add", str(labs / "lab_a"), "--add",
                                     str(labs / "lab_b"), "--method", METHODS[0], "--max-splits", str(MAX_SPLITS),
                                     "--out", str(out), "--force"])
    assert fewer.exit_code == 0, fewer.output
    assert "restored" not in fewer.output and _fit_misses(out, "lab_a") == _fit_misses(out, "lab_b") == 0


def _fit_misses(out, dataset: str) -> int:
    """Fits the dataset's study made (not read back from the fit store), from its manifest's profile."""
    manifest = json.loads((out / "datasets" / dataset / "manifest.json").read_text())
    return sum(int(r["calls"]) for r in manifest["config"]["profile"] if r["stage"] == "fit_store.miss")


class NeverFits(BaseEstimator):
    """A plug-in attribute model whose every fit fails."""

    score_kind = "embedding"

    def fit(self, X, Y, groups=None):
        raise ValueError("a lab's method that cannot fit here")


def test_a_dataset_that_cannot_run_is_recorded_and_the_others_complete(labs, tmp_path):
    broken = tmp_path / "lab_broken"
    broken.mkdir()
    (broken / "classes.csv").write_text("class,a\nx,1\n")
    out = tmp_path / "bench"
    register_method("never-fits", family="embedding", paper="test only", attribute_model=NeverFits,
                    decision_rule=NearestAttributeRule, calibratable=False)
    try:
        result = CliRunner().invoke(cli, ["benchmark", "--no-catalog", "--add", str(labs / "lab_a"), "--add",
                                          str(broken), "--method", "eszsl", "--method", "never-fits",
                                          "--max-splits", "1", "--out", str(out)])
    finally:
        unregister_method("never-fits")
    assert result.exit_code == 1, result.output
    assert "lab_broken: failed (" in result.output
    assert set(pd.read_csv(out / "scores.csv")["dataset"]) == {"lab_a"}
    manifest = json.loads((out / "manifest.json").read_text())
    status = {d["name"]: d["status"] for d in manifest["config"]["datasets"]}
    assert status == {"lab_a": "partial", "lab_broken": "failed"}
    # one line per dataset whose fits failed, however many failed: the count, the first reason, the manifest
    lab_a = [line for line in result.stderr.splitlines() if line.startswith("lab_a: ")]
    assert len(lab_a) == 1 and lab_a[0].startswith("lab_a: ")
    assert "table row(s) with failed fits (its manifest.json lists them); " in lab_a[0]
    assert "never-fits: ValueError: a lab's method that cannot fit here" in lab_a[0] and len(lab_a[0]) < 250


def test_usage_errors_are_one_line(tmp_path):
    runner = CliRunner()
    unknown = runner.invoke(cli, ["benchmark", "--dataset", "mnist", "--out", str(tmp_path / "o")])
    assert unknown.exit_code == 3 and "unknown benchmark dataset(s) 'mnist'" in unknown.output
    nothing = runner.invoke(cli, ["benchmark", "--no-catalog", "--out", str(tmp_path / "o")])
    assert nothing.exit_code == 3 and "needs at least one --add FOLDER" in nothing.output
    listed = runner.invoke(cli, ["benchmark", "--list"])
    assert listed.exit_code == 0 and "phac2-penn: 60 classes, 10 unseen per split" in listed.output


def test_ranks_compare_methods_on_the_splits_every_method_completed():
    long = pd.DataFrame({"dataset": ["d"] * 6, "method": ["a", "b", "c"] * 2, "split": ["1"] * 3 + ["2"] * 3,
                         "score": [0.5, np.nan, 0.7, 0.4, 0.6, 0.2], "chance": 0.5})
    kept = complete_splits(long)
    assert kept["split"].eq("2").all() and len(kept) == 3


def test_a_method_that_never_ran_on_a_dataset_leaves_its_splits_and_the_ranks_but_not_the_dataset(tmp_path):
    from tzsl.studies.outputs.results_folder import ResultsDir

    # "auto" cannot run on d2 (NaN on every split): d2 keeps both its splits for a and b, and auto is not ranked
    rows = [{"dataset": d, "method": m, "split": k, "per_class_accuracy": v, "trial_accuracy": v, "chance": 0.5}
            for d, by_method in {"d1": {"a": 0.7, "b": 0.5, "auto": 0.6}, "d2": {"a": 0.6, "b": 0.8, "auto": np.nan}}
            .items() for m, v in by_method.items() for k in ("1", "2")]
    scores = pd.DataFrame(rows)
    long = scores.rename(columns={"per_class_accuracy": "score"})
    kept = complete_splits(long)
    assert kept.groupby("dataset")["split"].nunique().to_dict() == {"d1": 2, "d2": 2}
    assert set(kept.loc[kept["dataset"] == "d2", "method"]) == {"a", "b"}
    assert ranked_methods(kept) == (["a", "b"], {"auto": ["d2"]})
    summary = summarise(scores, pd.DataFrame(), ResultsDir(tmp_path))
    assert set(summary["ranks"]["method"]) == {"a", "b"} and summary["ranks"]["n_datasets"].eq(2).all()
    assert summary["unranked"] == {"auto": ["d2"]}


def test_the_benchmark_runs_dap_with_its_detectors_and_any_detector_asked_for():
    detector, methods = benchmark_methods()
    daps = [m["detector"] for m in methods if m["name"] == "dap"]
    assert daps == [d for d in BENCHMARK_DETECTORS if d != detector] and "auto" not in daps
    # auto is what a default is compared with (a --defaults run), not a candidate: make benchmark does not pay for it
    _, defaults = benchmark_methods(defaults=True)
    assert [m["detector"] for m in defaults if m["name"] == "dap"] == [*daps, *DEFAULTS_DETECTORS]
    _, more = benchmark_methods(["robust-logistic", "rbf-svm", detector])
    assert [m["detector"] for m in more if m["name"] == "dap"] == [*daps, "robust-logistic"]
    unknown = CliRunner().invoke(cli, ["benchmark", "--detector", "forest", "--out", "o"])
    assert unknown.exit_code == 3 and "unknown detector 'forest'" in unknown.output
    select = CliRunner().invoke(cli, ["benchmark", "--purpose", "select", "--defaults", "s", "--out", "o"])
    assert select.exit_code == 3 and "--defaults scores the defaults on the confirmation splits" in select.output


def _scores(means: dict[str, dict[str, float]], n_splits: int = 4) -> pd.DataFrame:
    """Long scores: per dataset and method ``n_splits`` splits around the given mean (paired noise)."""
    rng = np.random.default_rng(0)
    rows = []
    for dataset, by_method in means.items():
        noise = rng.normal(0, 0.01, n_splits)
        rows += [{"dataset": dataset, "method": m, "split": f"{k:02d}", "per_class_accuracy": mean + noise[k],
                  "trial_accuracy": mean, "chance": 0.2} for m, mean in by_method.items() for k in range(n_splits)]
    return pd.DataFrame(rows)


def test_leave_one_dataset_out_scores_a_choice_on_the_dataset_it_did_not_see(tmp_path):
    from tzsl.studies.benchmark.command import write_defaults
    from tzsl.studies.outputs.results_folder import ResultsDir

    # on d1 and d2 eszsl ranks first, on d3 sae: left out, d3 inherits eszsl (regret = sae - eszsl there);
    # d1 left out sees d2 (eszsl 1, sae 3.5) and d3 (sae 1, eszsl 4): sae's mean rank 2.25 beats eszsl's 2.5
    means = {"d1": {"eszsl": 0.6, "sae": 0.5, "dap-avg-logistic-c1": 0.4, "dap-avg": 0.45},
             "d2": {"eszsl": 0.7, "sae": 0.5, "dap-avg-logistic-c1": 0.55, "dap-avg": 0.5},
             "d3": {"eszsl": 0.3, "sae": 0.5, "dap-avg-logistic-c1": 0.35, "dap-avg": 0.4}}
    select = _scores(means)
    # auto runs in the --defaults run on the confirmation splits only (and not on d2): shown beside, never chosen
    # nor the hindsight best
    confirm = _scores({d: {**m, **({} if d == "d2" else {"dap-avg-auto": 0.9})} for d, m in means.items()})
    results = ResultsDir(tmp_path)
    lines = write_defaults(select, confirm, results)
    table = pd.read_csv(tmp_path / "defaults.csv")
    default = table[table["choice"] == "default"].set_index("dataset")
    assert default.loc["d3", "chosen"] == "eszsl" and default.loc["d3", "best"] == "sae"
    assert default.loc["d3", "regret"] == pytest.approx(0.2, abs=0.02)
    assert default.loc["d1", "chosen"] == "sae" and default.loc["d1", "regret"] == pytest.approx(0.1, abs=0.02)
    assert default.loc["d2", "chosen"] == "sae" and default.loc["d2", "regret"] == pytest.approx(0.2, abs=0.02)
    assert "d3" not in default.loc["d3", "seen"] and default.loc["d3", "seen"] == "d1, d2"
    detector = table[table["choice"] == "detector"].set_index("dataset")
    assert set(detector["chosen"]) <= {"dap-avg", "dap-avg-logistic-c1"}
    assert (table["regret"].dropna() >= -1e-12).all()
    assert "dap-avg-auto" not in set(table["chosen"]) | set(table["best"])
    assert default.loc["d3", "auto_score"] == pytest.approx(0.9, abs=0.02) and np.isnan(default.loc["d2", "auto_score"])
    # the choice made on the left-out dataset's own selection splits: here the same means, so its best, no regret
    # the bound: the one method with the least mean regret on the confirmation splits, in hindsight
    # (eszsl: regrets 0, 0 and 0.2 on d1-d3; among the DAP rows dap-avg: 0, 0.05, 0)
    bound = table[table["dataset"] == "(one method, in hindsight)"].set_index("choice")
    assert bound.loc["default", "chosen"] == "eszsl"
    assert bound.loc["default", "regret"] == pytest.approx(0.2 / 3, abs=0.01)
    assert bound.loc["detector", "chosen"] == "dap-avg"
    assert bound.loc["detector", "regret"] == pytest.approx(0.05 / 3, abs=0.01)
    assert "the least any one method reaches, in hindsight: 0.06" in lines[1]
    own = default.drop(index=["(every dataset)", "(one method, in hindsight)"])
    assert own["own_chosen"].to_dict() == {"d1": "eszsl", "d2": "eszsl", "d3": "sae"}
    assert own["own_regret"].to_numpy() == pytest.approx(0.0, abs=1e-12)
    assert detector.loc["d3", "own_chosen"] == "dap-avg"
    assert lines[0].startswith("defaults chosen with each dataset left out")
    every = table[table["dataset"] == "(every dataset)"].set_index("choice")
    assert every.loc["default", "chosen"] == "eszsl" and every.loc["detector", "chosen"] == "dap-avg"
    assert every.loc["default", "seen"] == "d1, d2, d3" and np.isnan(every.loc["default", "regret"])
    assert lines[-1] == ("chosen on every dataset's selection splits: default eszsl, detector dap-avg "
                         "(shipped: dap-avg-logistic-c1)")


def test_defaults_need_a_full_selection_benchmark(labs, tmp_path):
    select = tmp_path / "select"
    quick = CliRunner().invoke(cli, ["benchmark", "--no-catalog", "--add", str(labs / "lab_a"), "--method", "eszsl",
                                     "--purpose", "select", "--max-splits", "1", "--out", str(select)])
    assert quick.exit_code == 0, quick.output
    refused = CliRunner().invoke(cli, ["benchmark", "--no-catalog", "--add", str(labs / "lab_a"), "--method",
                                       "eszsl", "--defaults", str(select), "--out", str(tmp_path / "confirm")])
    assert refused.exit_code == 3 and "--defaults needs a full benchmark of the selection splits" in refused.output
    assert not (tmp_path / "confirm").exists()
