"""Generated number blocks (README, benchmark README) from result CSVs (tzsl.reporting.readme_results)."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from tzsl.exceptions import ConfigError
from tzsl.models.protocol import LAST_BIT_NOTE
from tzsl.reporting.benchmark_blocks import MissingResults
from tzsl.reporting.manifests import produced_by
from tzsl.reporting.readme_results import (
    BEGIN,
    END,
    begin,
    end,
    evidence_block,
    evidence_summary_block,
    main,
    results_block,
    update_file,
)
from tzsl.studies.reproduce import reproduce_tables

sys.path.insert(0, str(Path(__file__).parent))
from test_reproduce import TINY_HAND

REPO = Path(__file__).resolve().parents[2]


def _results(root):
    root.mkdir()
    pd.DataFrame({
        "split": ["1", "2", "mean", "std", "control"], "chance": [0.1] * 5,
        "maxdap": [0.3, 0.2, 0.25, 0.07, 0.1], "maxdap_ci95_low": [0.2, 0.1, 0.15, None, 0.08],
        "maxdap_ci95_high": [0.4, 0.3, 0.35, None, 0.12],
        "avgdap": [0.35, 0.27, 0.31, 0.06, 0.099], "avgdap_ci95_low": [0.3, 0.2, 0.2412, None, 0.07],
        "avgdap_ci95_high": [0.4, 0.33, 0.3791, None, 0.13], "paper_maxdap": [None, None, 0.37, None, None],
        "paper_avgdap": [None, None, 0.39, None, None],
    }).to_csv(root / "table1_fusion.csv", index=False)
    sub = root / "fabric"
    sub.mkdir()
    pd.DataFrame({
        "condition": ["depth-sequence"] * 2, "config": [1, 1], "protocol": ["paper", "zero-shot-drop"],
        "zero_shot": [False, True], "test_groups": ["0 5 7", "0 7"], "chance": [1 / 3, 0.5],
        "majority": [0.48, 0.55], "lam_0": [0.45, 0.6], "lam_0_ci95_low": [0.3, 0.4], "lam_0_ci95_high": [0.6, 0.8],
        "lam_0_pcma": [0.4, 0.58], "lam_0_pcma_ci95_low": [0.3, 0.41], "lam_0_pcma_ci95_high": [0.5, 0.77],
        "paper_lam_0": [0.7545, None], "paper_row": ["Average", ""],
    }).to_csv(sub / "fabric_table1.csv", index=False)
    pd.DataFrame({"data": ["simulated"] * 2, "seed": ["0", "mean"], "method": ["LDAP"] * 2, "all": [0.5, 0.5],
                  "all_ci95_low": [0.4, 0.41], "all_ci95_high": [0.6, 0.59], "chance": [0.1, 0.1],
                  "paper_all": [None, 0.5963]}).to_csv(root / "hand_table5.csv", index=False)
    return root


def test_block_shows_ours_with_interval_baseline_and_paper(tmp_path):
    block = results_block(_results(tmp_path / "results"))
    assert "| PHAC-2 Table 1, AVGDAP (uniform prior), mean of 2 random splits | 0.310 [0.241, 0.379] | chance 0.100; " \
           "shuffled-rows control 0.099 [0.070, 0.130] | 0.39 |" in block
    assert ("zero-shot variant (zero-shot-drop: test groups 0 7), per-class mean accuracy | 0.580 [0.410, 0.770]"
            in block)
    assert "NOT zero-shot" in block and "majority 0.480" in block and "0.7545" in block
    assert "Hand Table 5 (SIMULATED grasps), LDAP" in block and "0.500 [0.410, 0.590]" in block


def test_update_rewrites_only_the_block_and_check_reports_drift(tmp_path):
    results = _results(tmp_path / "results")
    readme = tmp_path / "README.md"
    readme.write_text(f"# title\n\n## Results\n{BEGIN}\nold numbers\n{END}\n\n## After\ntext\n")
    assert update_file(readme, results, check=True)
    assert "old numbers" in readme.read_text()  # check does not write
    assert main([str(results), str(readme), "--check"]) == 1
    assert main([str(results), str(readme)]) == 0
    text = readme.read_text()
    assert ("old numbers" not in text and text.startswith("# title\n\n## Results\n")
            and text.endswith("## After\ntext\n"))
    assert "0.310 [0.241, 0.379]" in text
    assert main([str(results), str(readme), "--check"]) == 0  # up to date: no drift
    assert not update_file(readme, results)


def test_rows_that_can_move_with_the_last_bit_say_so_and_check_lets_only_them_differ(tmp_path):
    results = _results(tmp_path / "results")
    table = results / "fabric" / "fabric_table1.csv"
    fabric = pd.read_csv(table)
    fabric["note"] = f"public depth images; ESZSL and every lam_* column: {LAST_BIT_NOTE}"
    fabric.to_csv(table, index=False)
    readme = tmp_path / "README.md"
    readme.write_text(f"{BEGIN}\nold\n{END}\n")
    assert main([str(results), str(readme)]) == 0
    text = readme.read_text()
    fabric_rows = [line for line in text.splitlines() if line.startswith("| Fabric")]
    assert fabric_rows and all("(can move with the last bit)" in line for line in fabric_rows)
    assert not any("(can move" in line for line in text.splitlines() if line.startswith(("| PHAC-2", "| Hand")))
    fabric["lam_0"] = [0.47, 0.62]  # another machine's last bit: only the marked rows change
    fabric.to_csv(table, index=False)
    left: list[str] = []
    assert not update_file(readme, results, check=True, left=left)
    assert any("only rows marked" in line for line in left)
    hand = pd.read_csv(results / "hand_table5.csv")
    hand["all"] = [0.6, 0.6]  # an unmarked row that moves is drift
    hand.to_csv(results / "hand_table5.csv", index=False)
    assert main([str(results), str(readme), "--check"]) == 1


def test_errors(tmp_path):
    with pytest.raises(ConfigError, match="no such results folder"):
        results_block(tmp_path / "missing")
    (tmp_path / "empty").mkdir()
    with pytest.raises(ConfigError, match="none of the result tables"):
        results_block(tmp_path / "empty")
    readme = tmp_path / "README.md"
    readme.write_text("no markers\n")
    with pytest.raises(ConfigError, match="needs a"):
        update_file(readme, _results(tmp_path / "r"))
    readme.write_text(f"{begin('nope')}\n{end('nope')}\n")
    with pytest.raises(ConfigError, match="unknown block 'nope'"):
        update_file(readme, tmp_path / "r")
    readme.write_text(f"{BEGIN}\nx\n{END}\n{BEGIN}\ny\n{END}\n")
    with pytest.raises(ConfigError, match="needs exactly one"):
        update_file(readme, tmp_path / "r")
    readme.write_text(f"{BEGIN}\nno end\n")
    with pytest.raises(ConfigError, match="needs exactly one"):
        update_file(readme, tmp_path / "r")
    assert main([str(tmp_path / "r"), str(readme)]) == 3


def test_repository_readme_has_the_block():
    text = (REPO / "README.md").read_text()
    assert text.count(BEGIN) == 1 and text.count(END) == 1
    assert text.count(begin("evidence")) == 1 and text.count(end("evidence")) == 1  # the papers', then the evidence
    assert text.index(END) < text.index(begin("evidence"))
    docs = (REPO / "docs" / "user_guide" / "reproducing.md").read_text()
    assert docs.count(begin("results-evidence")) == 1
    bench = (REPO / "experiments" / "benchmarks" / "README.md").read_text()
    assert bench.count(begin("phac2-accuracy-benchmark")) == 1 and bench.count(end("phac2-accuracy-benchmark")) == 1




def test_check_on_a_tiny_reproduce_run_passes_then_fails_on_drift(tmp_path):
    """The README's own block mechanism on CSVs the shipped reproduce-tables writes (a tiny hand study)."""
    study = tmp_path / "hand.toml"
    study.write_text(TINY_HAND)
    reproduce_tables(tmp_path / "results", studies=(str(study),))
    readme = tmp_path / "README.md"
    readme.write_text((REPO / "README.md").read_text())
    assert main([str(tmp_path / "results"), str(readme), "--check"]) == 1  # the repository's block is another run's
    evidence_before = readme.read_text().split(begin("evidence"))[1]
    assert main([str(tmp_path / "results"), str(readme)]) == 0
    assert main([str(tmp_path / "results"), str(readme), "--check"]) == 0
    assert readme.read_text().split(begin("evidence"))[1] == evidence_before  # not the evidence folder: left as is
    assert "written by `tzsl reproduce-tables` at commit `" in readme.read_text() or \
        "written by `tzsl reproduce-tables`, commit not recorded" in readme.read_text()
    table = pd.read_csv(tmp_path / "results" / "hand_table5.csv")
    mean = table["seed"].astype(str) == "mean"
    assert f"{table.loc[mean, 'all'].iloc[0]:.3f} [" in readme.read_text()
    table.loc[mean, "all"] += 0.01  # the results move: the committed numbers drift
    table.to_csv(tmp_path / "results" / "hand_table5.csv", index=False)
    assert main([str(tmp_path / "results"), str(readme), "--check"]) == 1


@pytest.fixture
def accuracy_benchmark(monkeypatch):
    """The PHAC-2 accuracy benchmark's stage-2 module (experiments/benchmarks/phac2_accuracy.py)."""
    monkeypatch.syspath_prepend(str(REPO / "experiments" / "benchmarks"))
    import phac2_accuracy

    yield phac2_accuracy
    sys.modules.pop("phac2_accuracy", None)
    sys.modules.pop("phac2_posteriors", None)


def test_benchmark_block_from_the_benchmarks_own_summary(tmp_path, accuracy_benchmark):
    """accuracy.csv as the benchmark's summarise writes it (synthetic trials) -> the benchmark README's block."""
    rng = np.random.default_rng(0)
    frames = []
    for kind, n_splits in (("random", 4), ("challenging", 2)):
        for split in range(n_splits):
            classes = np.repeat(np.arange(5), 4)
            for method, p in (("dap-avg[paper]", 0.3), ("sae", 0.5)):
                frames.append(pd.DataFrame({"kind": kind, "split": f"{kind}{split}", "method": method, "class": classes,
                                            "correct": (rng.random(classes.size) < p).astype(float), "weight": np.nan}))
    table = accuracy_benchmark.summarise(pd.concat(frames, ignore_index=True))
    out = tmp_path / "bench"
    out.mkdir()
    table.to_csv(out / "accuracy.csv", index=False, float_format="%.4f")
    pd.DataFrame({"grid": ["paper"], "n_fits": [10], "mean_cv_log_loss": [0.47], "gamma=0.01": [0.9],
                  "gamma=0.1": [0.1]}).to_csv(out / "grid_summary.csv", index=False)
    readme = tmp_path / "README.md"
    readme.write_text((REPO / "experiments" / "benchmarks" / "README.md").read_text())
    assert main([str(out), str(readme)]) == 0
    text = readme.read_text()
    assert "| method | random (4 splits) | diff | challenging (2 splits) | diff |" in text
    sae = table[(table.method == "sae") & (table.kind == "random")].iloc[0]
    assert (f"| `sae` | {sae.accuracy:.3f} [{sae.ci95_low:.3f}, {sae.ci95_high:.3f}] | "
            f"{sae.diff_vs_avgdap:+.3f} [{sae.diff_ci95_low:+.3f}, {sae.diff_ci95_high:+.3f}] |") in text
    assert "| `dap-avg[paper]` | " in text and "| paper | 10 | 0.470 | 90% | 10% |" in text
    assert main([str(out), str(readme), "--check"]) == 0
    left: list[str] = []  # another benchmark's folder: this block is left as it is, and the run says so
    assert not update_file(readme, tmp_path / "empty", left=left)
    assert readme.read_text() == text and any("phac2-accuracy-benchmark left as it is" in line and
                                              "no accuracy.csv" in line for line in left)


def test_eszsl_public_block_from_the_benchmarks_summary(tmp_path):
    """eszsl_public.csv (the benchmark's summarise columns) -> its block; the public formulation has no difference."""
    from tzsl.reporting.benchmark_blocks import ESZSL_PUBLIC_FILE, MissingResults, eszsl_public_block

    with pytest.raises(MissingResults, match="phac2_eszsl_public.py"):
        eszsl_public_block(tmp_path)
    pd.DataFrame({"purpose": ["confirm"] * 2, "seed": 0, "method": ["public-eszsl", "tzsl-eszsl"], "n_splits": 50,
                  "accuracy": [0.30, 0.33], "ci95_low": [0.25, 0.28], "ci95_high": [0.35, 0.38],
                  "diff_vs_public": [0.0, 0.03], "diff_ci95_low": [0.0, 0.01], "diff_ci95_high": [0.0, 0.05],
                  "share_at_grid_edge": [0.5, 0.1]}).to_csv(tmp_path / ESZSL_PUBLIC_FILE, index=False)
    block = eszsl_public_block(tmp_path)
    assert "the paired difference to `public-eszsl`" in block
    assert "| confirm | `public-eszsl` | 50 | 0.300 [0.250, 0.350] | - | 50% |" in block
    assert "| confirm | `tzsl-eszsl` | 50 | 0.330 [0.280, 0.380] | +0.030 [+0.010, +0.050] | 10% |" in block


def test_block_tabulates_every_method_by_study_from_the_comparison(tmp_path):
    root = _results(tmp_path / "results")
    pd.DataFrame({
        "study": ["phac2-random", "phac2-random", "phac2-random", "hand"],
        "data": ["real", "real", "real", "simulated"],
        "method": ["dap-avg", "sae", "ldap", "sae"],
        "accuracy": [0.31, 0.35, None, 0.3], "ci95_low": [0.19, 0.24, None, 0.2], "ci95_high": [0.44, 0.46, None, 0.4],
        "paper_accuracy": [0.39, None, None, None], "chance": [0.1, 0.1, None, 0.1],
        "difference": [None, 0.04, None, -0.1], "difference_ci95_low": [None, -0.07, None, -0.2],
        "difference_ci95_high": [None, 0.16, None, 0.0], "reference": ["dap-avg"] * 3 + ["ldap"],
        "note": ["", "", "not applicable: takes grasps", ""],
    }).to_csv(root / "method_comparison.csv", index=False)
    block = evidence_block(root)
    assert "| method | phac2-random, ref. dap-avg, chance 0.10 | hand (SIMULATED), ref. ldap, chance 0.10 |" in block
    assert "| `dap-avg` | 0.31 (0.19-0.44) [0.39] |  |" in block
    assert "| `sae` | 0.35 (0.24-0.46), Δ +0.04 (-0.07, +0.16) | 0.30 (0.20-0.40), Δ -0.10 (-0.20, +0.00) |" in block
    assert "| `ldap` | n/a |  |" in block


def test_one_file_holds_several_named_blocks(tmp_path, monkeypatch):
    from tzsl.reporting import readme_results

    monkeypatch.setitem(readme_results.BLOCKS, "a", lambda root: f"A from {root.name}")
    monkeypatch.setitem(readme_results.BLOCKS, "a-b", lambda root: "AB")
    page = tmp_path / "page.md"
    page.write_text(f"x\n{begin('a-b')}\nold\n{end('a-b')}\nmiddle\n{begin('a')}\nold\n{end('a')}\ny\n")
    assert update_file(page, tmp_path)
    assert page.read_text() == (f"x\n{begin('a-b')}\nAB\n{end('a-b')}\nmiddle\n{begin('a')}\nA from {tmp_path.name}\n"
                                f"{end('a')}\ny\n")
    assert not update_file(page, tmp_path, check=True)


def test_search_benchmark_block_reads_every_summary(tmp_path):
    from tzsl.reporting.benchmark_blocks import search_benchmark_block

    with pytest.raises(ConfigError, match="phac2_search.py"):
        search_benchmark_block(tmp_path)
    for seed, low in ((0, -0.02), (1, -0.04)):
        pd.DataFrame([{"seed": seed, "grid": "paper", "n_splits": 10, "grid_avgdap": 0.3, "grid_ci95_low": 0.2,
                       "grid_ci95_high": 0.4, "halving_avgdap": 0.29, "halving_ci95_low": 0.2,
                       "halving_ci95_high": 0.39, "difference": low / 2, "difference_ci95_low": low,
                       "difference_ci95_high": 0.01 if seed == 0 else -0.001, "same_choice_share": 0.5,
                       "grid_cpu_s": 47.5, "halving_cpu_s": 28.9, "cpu_ratio": 1.64}]).to_csv(
            tmp_path / f"search_summary_seed{seed}_paper.csv", index=False)
    block = search_benchmark_block(tmp_path)
    assert ("| paper | 0 | 10 | 0.300 [0.200, 0.400] | 0.290 [0.200, 0.390] | -0.010 [-0.020, +0.010] | yes | 50% |"
            in block)
    assert "| paper | 1 | 10 |" in block and "-0.020 [-0.040, -0.001] | no |" in block
    assert "| 47.5 | 28.9 | 1.64 |" in block
def test_headlines_come_from_the_run_with_the_most_random_splits(tmp_path):
    """The headline block: the fusion x prior table with the most random splits and its comparison (same prefix)."""
    root = _results(tmp_path / "results")

    def variants(n_random: int, accuracy: float) -> pd.DataFrame:
        return pd.DataFrame({
            "study": "phac2", "data": "real", "split_kind": ["random", "random", "challenging"],
            "method": ["dap-avg", "dap-max", "dap-avg"], "fusion": ["avg", "max", "avg"], "prior": "uni",
            "accuracy": [accuracy, accuracy + 0.01, 0.2], "ci95_low": [0.25, 0.26, 0.1], "ci95_high": [0.35, 0.36, 0.3],
            "chance": 0.1, "fit_seconds": 1.0, "difference": [None, 0.01, None],
            "difference_ci95_low": [None, -0.005, None], "difference_ci95_high": [None, 0.025, None],
            "reference": "dap-avg", "n_splits": [n_random, n_random, 5], "n_trials": 100,
            "sd_over_splits": [0.08, 0.081, 0.05], "sd_over_refit_seeds": [0.04, 0.041, 0.03], "note": ""})

    variants(5, 0.31).to_csv(root / "dap_fusion_prior.csv", index=False)
    variants(50, 0.3).to_csv(root / "headlines_dap_fusion_prior.csv", index=False)
    pd.DataFrame({"study": "phac2-headlines", "data": "real", "split_kind": ["random", "random", "challenging"],
                  "method": ["dap-avg", "sae", "sae"], "accuracy": [0.3, 0.37, None], "ci95_low": [0.25, 0.3, None],
                  "ci95_high": [0.35, 0.44, None], "difference": [None, 0.07, None],
                  "difference_ci95_low": [None, 0.02, None], "difference_ci95_high": [None, 0.12, None],
                  "n_splits": [50, 50, 5], "sd_over_splits": [0.08, 0.09, None],
                  "sd_over_refit_seeds": [0.04, 0.0, None]}).to_csv(
        root / "headlines_phac2_method_comparison.csv", index=False)
    block = evidence_block(root)
    assert "`headlines_dap_fusion_prior.csv`, `headlines_phac2_method_comparison.csv`" in block
    assert "| random (50) | `dap-avg` | 0.300 [0.250, 0.350] | reference | 0.080 / 0.040 |" in block
    assert "| random (50) | `dap-max` | 0.310 [0.260, 0.360] | +0.010 [-0.005, +0.025] | 0.081 / 0.041 |" in block
    assert "| challenging (5) | `dap-avg` | 0.200 [0.100, 0.300] | reference | 0.050 / 0.030 |" in block
    assert "| random (50) | `sae` | 0.370 [0.300, 0.440] | +0.070 [+0.020, +0.120] | 0.090 / 0.000 |" in block
    assert "random (5)" not in block and "challenging (5) | `sae`" not in block  # the 5-split run; a failed row


def test_comparison_columns_are_study_and_split_kind(tmp_path):
    root = _results(tmp_path / "results")
    pd.DataFrame({"study": ["phac2", "phac2-headlines", "phac2-headlines"], "data": "real",
                  "split_kind": ["random", "random", "challenging"], "method": "dap-avg",
                  "accuracy": [0.31, 0.3, 0.2], "ci95_low": [0.2, 0.25, 0.1], "ci95_high": [0.4, 0.35, 0.3],
                  "chance": [0.1, 0.1, 0.105], "reference": "dap-avg"}).to_csv(root / "method_comparison.csv",
                                                                              index=False)
    block = evidence_block(root)
    assert ("| method | phac2, random splits, ref. dap-avg, chance 0.10 | "
            "phac2-headlines, random splits, ref. dap-avg, "
            "chance 0.10 | phac2-headlines, challenging splits, ref. dap-avg, chance 0.10 |") in block
    assert "| `dap-avg` | 0.31 (0.20-0.40) | 0.30 (0.25-0.35) | 0.20 (0.10-0.30) |" in block


def test_the_readme_block_holds_the_headlines_and_the_evidence_block_the_rest(tmp_path):
    """README stays short: the per-split-kind and per-study tables go to the evidence block (docs)."""
    root = _results(tmp_path / "results")
    pd.DataFrame({"study": ["phac2"], "data": "real", "split_kind": "random", "method": "dap-avg", "accuracy": [0.3],
                  "ci95_low": [0.2], "ci95_high": [0.4], "chance": [0.1], "reference": "dap-avg"}).to_csv(
        root / "method_comparison.csv", index=False)
    readme, evidence = results_block(root), evidence_block(root)
    assert "| method | phac2, random splits" in evidence and "| method | phac2" not in readme
    assert "| result | ours [95% CI]" in readme
    with pytest.raises(MissingResults, match="neither dap_fusion_prior.csv nor method_comparison.csv"):
        evidence_block(_results(tmp_path / "bare"))


def test_grid_summary_and_pairs_report_the_share_at_a_grid_edge(tmp_path, accuracy_benchmark):
    """Stage 1's per-split files of three grids -> grid_summary.csv (share at an edge, CPU) -> the block; the
    adaptive grid is compared with the extended one on the same trials (grid_pairs)."""
    from tzsl.reporting.benchmark_blocks import benchmark_accuracy_block

    edges = {"paper": [[1, 1], [1, 0]], "extended": [[1, 0], [0, 0]], "adaptive": [[0, 0], [0, 0]]}
    gamma = {"paper": 0.01, "extended": 1e-4, "adaptive": 1e-6}
    for grid, cpu in (("paper", 4.0), ("extended", 6.0), ("adaptive", 15.0)):
        for split in ("random-1", "random-2"):
            np.savez(tmp_path / f"{grid}_{split}.npz", log_loss=np.full((2, 2), 0.5),
                     gamma=np.full((2, 2), gamma[grid]), at_edge=np.array(edges[grid], dtype=bool), cpu_seconds=cpu)
    summary = accuracy_benchmark.grid_summary(tmp_path).set_index("grid")
    assert summary.loc["paper", "share_at_edge"] == 0.75 and summary.loc["adaptive", "share_at_edge"] == 0.0
    assert summary.loc["adaptive", "cpu_seconds_per_split"] == 15.0 and summary.loc["adaptive", "gamma<1e-4"] == 1.0
    assert summary.loc["extended", "gamma=0.0001"] == 1.0
    rng = np.random.default_rng(1)
    classes = np.repeat(np.arange(5), 4)
    trials = pd.concat([pd.DataFrame({"kind": "random", "split": f"s{s}", "method": f"dap-avg[{g}]", "class": classes,
                                      "correct": (rng.random(classes.size) < 0.4).astype(float), "weight": np.nan})
                        for g in ("paper", "extended", "adaptive") for s in range(3)], ignore_index=True)
    pairs = accuracy_benchmark.grid_pairs(trials).set_index("method")
    row = pairs.loc["dap-avg[adaptive]"]
    assert row.reference == "dap-avg[extended]" and row.n_splits == 3
    ad, ex = (trials[trials.method == m].correct.mean() for m in ("dap-avg[adaptive]", "dap-avg[extended]"))
    assert np.isclose(row["diff"], ad - ex) and row.diff_ci95_low <= row["diff"] <= row.diff_ci95_high
    out = tmp_path / "bench"
    out.mkdir()
    accuracy_benchmark.summarise(trials).to_csv(out / "accuracy.csv", index=False)
    summary.reset_index().to_csv(out / "grid_summary.csv", index=False)
    assert "| adaptive | 8 | 0.500 | 0% | 15.0 | " in benchmark_accuracy_block(out)
    table = accuracy_benchmark.summarise(trials)
    table.insert(1, "purpose", "confirm")
    table.insert(2, "seed", "1")
    table.to_csv(out / "accuracy.csv", index=False)
    pairs.reset_index().to_csv(out / "grid_pairs.csv", index=False)
    block = benchmark_accuracy_block(out)
    assert "| method | random (3 splits, confirm, seed 1) | diff |" in block
    assert f"| `dap-avg[adaptive]` | `dap-avg[extended]` | 3 | {row['diff']:+.3f} [" in block


def _comparison(root: Path) -> Path:
    """A stacked method_comparison.csv as ``tzsl evidence`` writes it (two studies, one split kind each)."""
    pd.DataFrame({
        "study": ["phac2", "phac2", "phac2", "hand", "hand"], "data": ["real"] * 3 + ["simulated"] * 2,
        "split_kind": ["random", "random", "random", "paper", "paper"],
        "method": ["dap-avg", "sae", "ale", "ldap", "sae"],
        "accuracy": [0.3, 0.36, 0.25, 0.44, None], "ci95_low": [0.2, 0.25, 0.15, 0.37, None],
        "ci95_high": [0.4, 0.47, 0.35, 0.51, None], "chance": [0.1, 0.1, 0.1, 0.1, 0.1],
        "difference": [None, 0.06, -0.05, None, None], "difference_ci95_low": [None, 0.01, -0.1, None, None],
        "difference_ci95_high": [None, 0.11, 0.0, None, None], "reference": ["dap-avg"] * 3 + ["ldap"] * 2,
        "note": ["", "", "", "", "not run"]}).to_csv(root / "method_comparison.csv", index=False)
    return root


def test_evidence_summary_pairs_each_study_reference_with_its_most_accurate_method(tmp_path):
    root = tmp_path / "evidence"
    root.mkdir()
    (root / "manifest.json").write_text('{"study_list": "evidence", "commit": "0123abcd4567"}')
    block = evidence_summary_block(_comparison(root))
    assert "written by `tzsl evidence` at commit `0123abcd4567`" in block
    assert ("| phac2 (random) | `dap-avg` 0.300 [0.200, 0.400] | `sae` 0.360 [0.250, 0.470] | "
            "+0.060 [+0.010, +0.110] | 0.100 |") in block
    assert "hand" not in block.split("| chance |")[1]  # no other method with an accuracy: no row
    with pytest.raises(MissingResults, match="run `make evidence` first"):
        evidence_summary_block(tmp_path / "missing")
    with pytest.raises(MissingResults, match="no method_comparison.csv"):
        evidence_summary_block(_results(tmp_path / "papers"))


def test_produced_by_names_the_command_and_commit_or_says_what_is_missing(tmp_path):
    assert produced_by(tmp_path) == "no manifest.json: command and commit not recorded"
    (tmp_path / "manifest.json").write_text('{"study_list": "reproduce-tables", "commit": null}')
    assert produced_by(tmp_path) == "`tzsl reproduce-tables`, commit not recorded, environment not recorded"
    (tmp_path / "manifest.json").write_text('{"commit": "abc-dirty"}')
    assert produced_by(tmp_path) == "a command not recorded at commit `abc-dirty`, environment not recorded"


def test_produced_by_says_whether_the_run_was_in_the_locked_environment(tmp_path):
    def manifest(environment):
        (tmp_path / "manifest.json").write_text(json.dumps(
            {"study_list": "reproduce-tables", "commit": "abc", "environment": environment}))
        return produced_by(tmp_path)

    lock = {"lock_file": "requirements/core.lock.txt", "lock_sha256": "fb3f068277de28f9"}
    assert manifest({**lock, "matches_lock": True, "differs": {}}) == (
        "`tzsl reproduce-tables` at commit `abc`, in the locked environment (`requirements/core.lock.txt`, "
        "sha256 `fb3f0682`)")
    moved = manifest({**lock, "matches_lock": False, "differs": {
        "numpy": {"locked": "2.4.6", "installed": "2.5.0"}, "h5py": {"locked": "3.16.0", "installed": None}}})
    assert moved.endswith("NOT in the locked environment (`requirements/core.lock.txt`, sha256 `fb3f0682`): "
                          "h5py missing (locked 3.16.0), numpy 2.5.0 (locked 2.4.6)")
    assert manifest({"lock_file": None, "matches_lock": None, "differs": {}}).endswith(
        "outside a checkout with a lock (versions in its manifest)")


def test_each_block_reads_its_own_folder(tmp_path):
    """--block: the README's papers block from the papers' folder, its evidence block from the evidence
    folder; the evidence block is left as it is while that folder is missing, and says so."""
    papers = _results(tmp_path / "results")
    readme = tmp_path / "README.md"
    readme.write_text(f"{BEGIN}\nold\n{END}\n{begin('evidence')}\nnot yet\n{end('evidence')}\n")
    left: list[str] = []
    assert not update_file(readme, tmp_path / "results" / "evidence", blocks=["evidence"], left=left)
    assert "not yet" in readme.read_text() and any("block evidence left as it is" in line for line in left)
    assert main([str(papers), str(readme), "--block", "readme"]) == 0
    assert "old" not in readme.read_text() and "not yet" in readme.read_text()
    (papers / "evidence").mkdir()
    evidence = _comparison(papers / "evidence")
    assert main([str(evidence), str(readme), "--block", "evidence", "--check"]) == 1
    assert main([str(evidence), str(readme), "--block", "evidence"]) == 0
    assert "not yet" not in readme.read_text() and "| phac2 (random) | `dap-avg`" in readme.read_text()
    assert main([str(papers), str(readme), "--block", "readme", "--check"]) == 0  # the papers' block still reads
    # results/table1_fusion.csv, not the evidence folder's copy beneath it
    moved = (papers / "table1_fusion.csv").read_text().replace("0.31,", "0.91,")
    assert moved != (papers / "table1_fusion.csv").read_text()
    (evidence / "table1_fusion.csv").write_text(moved)
    assert main([str(papers), str(readme), "--block", "readme", "--check"]) == 0
    with pytest.raises(ConfigError, match="has no block 'nope'"):
        update_file(readme, papers, blocks=["nope"])


def test_detectors_block_pairs_the_chosen_detector_with_dap_avg_and_eszsl(tmp_path):
    """The README's detectors block: the run with the most splits comparing the chosen detector's DAP,
    its rows paired with dap-avg, and the chosen DAP minus ESZSL paired over the per-split table."""
    from tzsl.models.attribute_training import STUDY_DETECTOR
    from tzsl.reporting.readme_results import detectors_block
    from tzsl.studies.config import dap_label

    chosen = dap_label("avg", STUDY_DETECTOR)
    with pytest.raises(MissingResults, match=f"no method comparison with {chosen}"):
        detectors_block(tmp_path)
    for folder, n in (("few", 2), ("many", 4)):
        (tmp_path / folder).mkdir()
        rows = [{"split_kind": "random", "method": m, "accuracy": acc, "ci95_low": acc - 0.1, "ci95_high": acc + 0.1,
                 "n_splits": n, "difference": d, "difference_ci95_low": d - 0.05, "difference_ci95_high": d + 0.05}
                for m, acc, d in (("dap-avg", 0.3, np.nan), (chosen, 0.4, 0.1), ("eszsl", 0.35, 0.05))]
        pd.DataFrame(rows).to_csv(tmp_path / folder / "x_phac2_method_comparison.csv", index=False)
        per_split = pd.DataFrame({"split": [str(i) for i in range(n)] + ["mean", "std"], "split_kind": "random",
                                  chosen: [0.4, 0.5, 0.4, 0.5][:n] + [0.45, 0.05],
                                  "eszsl": [0.3, 0.4, 0.3, 0.4][:n] + [0.35, 0.05]})
        per_split.to_csv(tmp_path / folder / "x_phac2_methods.csv", index=False)
    text = detectors_block(tmp_path)
    assert f"| random (4) | `{chosen}` | 0.400 [0.300, 0.500] | +0.100 [+0.050, +0.150] |" in text
    assert "| random (4) | `dap-avg` | 0.300 [0.200, 0.400] | reference |" in text
    assert f"| random (4) | `{chosen}` minus `eszsl` | | +0.100 [+0.100, +0.100] (over splits) |" in text
