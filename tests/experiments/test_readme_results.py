"""The README's Results block is generated from result CSVs (tzsl.experiments.readme_results)."""

from __future__ import annotations

import pandas as pd
import pytest

from tzsl.exceptions import ConfigError
from tzsl.experiments.readme_results import BEGIN, END, main, results_block, update_readme


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
    assert "zero-shot variant (zero-shot-drop: test groups 0 7), per-class mean accuracy | 0.580 [0.410, 0.770]" in block
    assert "NOT zero-shot" in block and "majority 0.480" in block and "0.7545" in block
    assert "Hand Table 5 (SIMULATED grasps), LDAP" in block and "0.500 [0.410, 0.590]" in block


def test_update_rewrites_only_the_block_and_check_reports_drift(tmp_path):
    results = _results(tmp_path / "results")
    readme = tmp_path / "README.md"
    readme.write_text(f"# title\n\n## Results\n{BEGIN}\nold numbers\n{END}\n\n## After\ntext\n")
    assert update_readme(readme, results, check=True)
    assert "old numbers" in readme.read_text()  # check does not write
    assert main([str(results), str(readme), "--check"]) == 1
    assert main([str(results), str(readme)]) == 0
    text = readme.read_text()
    assert "old numbers" not in text and text.startswith("# title\n\n## Results\n") and text.endswith("## After\ntext\n")
    assert "0.310 [0.241, 0.379]" in text
    assert main([str(results), str(readme), "--check"]) == 0  # up to date: no drift
    assert not update_readme(readme, results)


def test_errors(tmp_path):
    with pytest.raises(ConfigError, match="no such results folder"):
        results_block(tmp_path / "missing")
    (tmp_path / "empty").mkdir()
    with pytest.raises(ConfigError, match="none of the result tables"):
        results_block(tmp_path / "empty")
    readme = tmp_path / "README.md"
    readme.write_text("no markers\n")
    with pytest.raises(ConfigError, match="needs exactly one"):
        update_readme(readme, _results(tmp_path / "r"))
    assert main([str(tmp_path / "r"), str(readme)]) == 3


def test_repository_readme_has_the_block():
    from pathlib import Path

    text = (Path(__file__).resolve().parents[2] / "README.md").read_text()
    assert text.count(BEGIN) == 1 and text.count(END) == 1


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
    block = results_block(root)
    assert "| method | phac2-random, ref. dap-avg, chance 0.10 | hand (SIMULATED), ref. ldap, chance 0.10 |" in block
    assert "| `dap-avg` | 0.31 (0.19-0.44) [0.39] |  |" in block
    assert "| `sae` | 0.35 (0.24-0.46), Δ +0.04 (-0.07, +0.16) | 0.30 (0.20-0.40), Δ -0.10 (-0.20, +0.00) |" in block
    assert "| `ldap` | n/a |  |" in block
