"""``tzsl run`` and ``tzsl report`` end to end, and the issue's "done when" on real PHAC-2 data."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from tzsl.cli import EXIT_TZSL_ERROR, cli

REPO = Path(__file__).resolve().parents[2]

TINY = {"n_C": 1, "n_gamma": 1, "n_draws": 1, "cv": 3}

PLAIN_TOML = """
study = "phac2-dap"
[dataset]
plain = "phac2_plain"
[methods]
multilabel = false
sweep = false
eszsl = false
embedding = false
[splits]
kinds = ["random"]
n_splits = 2
n_test = 10
seed = 0
[svm]
cv = 3
n_C = 1
n_gamma = 1
n_draws = 1
[compute]
cache = false
progress = false
"""


def _run(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


def test_run_print_config_prints_resolved_settings():
    result = _run("run", "phac2-dap", "--print-config")
    assert result.exit_code == 0, result.output
    assert "[svm]" in result.output and "cv = 5" in result.output and 'undersampling = "select"' in result.output


def test_run_reports_file_and_key_path_of_problems(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text("study = 'phac2-dap'\n[dataset]\nbuiltin = 'phac2-penn'\n[svm]\nn_C = 2.5\ngrids = 3\n")
    result = _run("run", path)
    assert result.exit_code == EXIT_TZSL_ERROR
    assert f"{path}: svm.n_C: 2.5: expected a valid integer" in result.output
    assert f"{path}: svm.grids: unknown key" in result.output
    assert "Traceback" not in result.output


def test_report_command(tmp_path):
    pd.DataFrame({"split": ["1"], "avgdap": [0.3], "paper_avgdap": [0.41]}).to_csv(tmp_path / "table1_fusion.csv",
                                                                                   index=False)
    result = _run("report", tmp_path)
    assert result.exit_code == 0, result.output
    assert (tmp_path / "report.html").is_file()
    again = _run("report", tmp_path)
    assert again.exit_code == EXIT_TZSL_ERROR and "--force" in again.output
    assert _run("report", tmp_path, "--force").exit_code == 0
    missing = _run("report", tmp_path / "none")
    assert missing.exit_code == EXIT_TZSL_ERROR and "not found" in missing.output


@pytest.mark.slow
@pytest.mark.realdata
def test_plain_folder_from_convert_gives_the_builtin_accuracies(tmp_path, data_dir):
    """Done when: convert PHAC-2 to a plain folder, validate it, run it from a TOML file -> same accuracies."""
    from tzsl.features import dataset_features
    from tzsl.studies.config import ZeroShotSettings
    from tzsl.studies.outputs.results_folder import ResultsDir
    from tzsl.studies.zero_shot.study import run_zero_shot_tables

    folder = tmp_path / "phac2_plain"
    converted = _run("convert", "--dataset", "phac2-penn", "--out", folder, "--data-dir", data_dir)
    assert converted.exit_code == 0, converted.output
    validated = _run("validate", folder)
    assert validated.exit_code == 0, validated.output
    assert "valid" in validated.output
    experiment = tmp_path / "plain.toml"
    experiment.write_text(PLAIN_TOML)
    ran = _run("run", experiment, "--out", tmp_path / "plain_results")
    assert ran.exit_code == 0, ran.output
    ours = pd.read_csv(tmp_path / "plain_results" / "table1_fusion.csv")

    config = ZeroShotSettings.of_preset("phac2-dap", splits={"n_splits": 2, "n_test": 10, "seed": 0}, svm=dict(TINY),
                                        methods={"multilabel": False}, compute={"progress": False, "cache": False})
    builtin = run_zero_shot_tables(dataset_features("phac2-penn", data_dir=data_dir), ResultsDir(tmp_path / "builtin"),
                                   config)["table1_fusion"]
    assert list(ours["split"].astype(str)) == ["1", "2", "mean", "std", "control"]
    for column in ("maxdap", "avgdap", "avgdap_per_class_mean", "n_attributes", "n_test_objects"):
        # CSV numbers carry 6 significant digits (tzsl.studies.outputs.results_folder.CSV_FLOAT_FORMAT)
        np.testing.assert_allclose(ours[column].to_numpy(float), builtin[column].to_numpy(float), rtol=0,
                                   atol=1e-6, err_msg=column)
    # the same splits: identical per-attribute test accuracies on every split
    per_plain = pd.read_csv(tmp_path / "plain_results" / "attribute_accuracy_per_split.csv")
    per_builtin = pd.read_csv(tmp_path / "builtin" / "attribute_accuracy_per_split.csv")
    pd.testing.assert_frame_equal(per_plain, per_builtin)
    assert ours.loc[ours["split"] == "mean", "avgdap"].iloc[0] > 0.15  # well above chance (0.1)
