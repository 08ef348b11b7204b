"""``tzsl extract`` end to end on the real data."""

from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner

from tzsl.cli import EXIT_TZSL_ERROR, cli
from tzsl.datasets._feature_table import read_feature_table


def _run(*args: str):
    return CliRunner().invoke(cli, list(args), catch_exceptions=False)


def test_extract_penn_summary(data_dir):
    result = _run("extract", "--dataset", "phac2-penn", "--data-dir", str(data_dir))
    assert result.exit_code == 0, result.output
    lines = dict(line.split(":", 1) for line in result.output.strip().splitlines())
    assert lines["trials"].strip() == "600"
    assert lines["objects"].strip() == "60"
    assert lines["sensors"].strip().startswith("2 ")
    assert lines["attributes"].strip().startswith("19 kept")
    assert "crinkly" in lines["dropped"] and "bumpy" not in lines["dropped"]


def test_extract_hold_mat_writes_table_and_refuses_overwrite(data_dir, tmp_path):
    out = tmp_path / "hold.npz"
    result = _run("extract", "--dataset", "phac2-hold-mat", "--data-dir", str(data_dir), "--out", str(out))
    assert result.exit_code == 0, result.output
    table = read_feature_table(out)
    assert table.X.shape == (60, 2, 26)
    assert np.isfinite(table.X).all()
    again = CliRunner().invoke(cli, ["extract", "--dataset", "phac2-hold-mat", "--data-dir", str(data_dir),
                                     "--out", str(out)])
    assert again.exit_code == EXIT_TZSL_ERROR
    assert "--force" in again.output


def test_hold_mat_gripper_features_match_penn(data_dir):
    """The two real sources agree: HOLD min/mean aperture == Penn features 20/21 (HOLD EP)."""
    from tzsl.features import dataset_features

    hold = dataset_features("phac2-hold-mat", data_dir=data_dir)
    penn = dataset_features("phac2-penn", data_dir=data_dir)
    penn_rows = penn.trials.set_index("trial_id").index.get_indexer(hold.trials["trial_id"])
    assert (penn_rows >= 0).all()
    for raw_name, penn_name in (("aperture_min", "gripper_min"), ("aperture_mean", "gripper_mean")):
        hold_col = [i for i, n in enumerate(hold.feature_names) if n == f"hold:{raw_name}"]
        penn_col = [i for i, n in enumerate(penn.feature_names) if n == f"hold:{penn_name}"]
        assert len(hold_col) == 1 and len(penn_col) == 1, (hold.feature_names, penn.feature_names)
        np.testing.assert_allclose(hold.X[:, 0, hold_col[0]], penn.X[penn_rows, 0, penn_col[0]], rtol=0, atol=1e-9)


@pytest.mark.parametrize("args, message", [
    (["--dataset", "phac2-h5", "--path", "/nonexistent/phac2.h5"], "/nonexistent/phac2.h5"),
    (["--dataset", "phac2-h5"], "--path"),
])
def test_extract_bad_input_is_one_clear_line(args, message, tmp_path):
    result = CliRunner().invoke(cli, ["extract", *args, "--data-dir", str(tmp_path)])
    assert result.exit_code == EXIT_TZSL_ERROR
    assert message in result.output
    assert "Traceback" not in result.output


def test_extract_missing_data_says_what_to_download(tmp_path):
    result = CliRunner().invoke(cli, ["extract", "--dataset", "phac2-penn", "--data-dir", str(tmp_path)])
    assert result.exit_code == EXIT_TZSL_ERROR
    assert "tzsl: error:" in result.output and "phac2" in result.output
