"""``tzsl simulate-grasps``, ``evaluate-hand``, ``train-hand`` and ``predict`` end to end."""

from __future__ import annotations

import json

import pandas as pd
import pytest
from click.testing import CliRunner

from tzsl.cli import EXIT_TZSL_ERROR, cli
from tzsl.datasets import load_hand_table4, read_grasps
from tzsl.studies.hand.study import HAND_OUTPUTS

TABLE = load_hand_table4()


def _run(*args: str):
    return CliRunner().invoke(cli, [str(a) for a in args], catch_exceptions=False)


def _one_line_error(result, *needles: str) -> None:
    assert result.exit_code == EXIT_TZSL_ERROR, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("tzsl: error: "), result.output
    for needle in needles:
        assert needle in lines[0], (needle, lines[0])


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    root = tmp_path_factory.mktemp("hand_cli")
    sim = _run("simulate-grasps", "--out", root / "g", "--grasps-per-object", 20, "--seed", 2)
    assert sim.exit_code == 0, sim.output
    train = _run("train-hand", "--grasps", root / "g", "--out", root / "m.tzsl", "--seed", 0)
    assert train.exit_code == 0, train.output
    classes = root / "classes.csv"
    TABLE.K.loc[TABLE.test_objects].rename_axis("object").to_csv(classes)
    return root, sim.output, train.output, classes


def test_simulate_help_says_it_is_a_simulator():
    text = " ".join(_run("simulate-grasps", "--help").output.split())
    assert "simulat" in text.lower() and "exercise and demonstrate" in text and "not the paper's data" in text


def test_simulate_writes_a_readable_folder_and_refuses_overwrite(trained):
    root, output, _, _ = trained
    assert "wrote 320 simulated grasps of 16 objects" in output and "SIMULATED" in output
    grasps = read_grasps(root / "g")
    assert len(grasps) == 320 and {g.object_name for g in grasps} == set(TABLE.K.index)
    _one_line_error(_run("simulate-grasps", "--out", root / "g"), "grasps.csv already exists", "--force")


def test_train_hand_reports_training_objects(trained):
    _, _, output, _ = trained
    assert "fitted on 120 grasps of training objects" in output and "200 grasps of other objects ignored" in output
    assert "method hand-dap" in output


def test_predict_several_grasps_decides(trained):
    root, _, _, classes = trained
    files = [root / "g" / f"bowl_{i:03d}.npz" for i in range(6)]
    out = _run("predict", "--model", root / "m.tzsl", "--classes", classes, "--k", 2, "--top", 3, *files)
    assert out.exit_code == 0, out.output
    assert out.output.count("grasp ") >= 6 and "per-grasp decisions:" in out.output
    assert "SC-MDAP (k=2): decided" in out.output
    df = _run("predict", "--model", root / "m.tzsl", "--classes", classes, "--multi-grasp", "df", *files)
    assert df.exit_code == 0 and "DF-MDAP: decided" in df.output


def test_predict_errors_are_one_line(trained, tmp_path):
    root, _, _, classes = trained
    grasp = root / "g" / "tube_000.npz"
    bad_classes = tmp_path / "c.csv"
    pd.DataFrame({"object": ["a"], "plastic": [1]}).to_csv(bad_classes, index=False)
    _one_line_error(_run("predict", "--model", root / "m.tzsl", "--classes", bad_classes, grasp),
                    "missing attribute column(s)", str(bad_classes))
    corrupt = tmp_path / "m.tzsl"
    raw = bytearray((root / "m.tzsl").read_bytes())
    raw[-50] ^= 0xFF
    corrupt.write_bytes(bytes(raw))
    _one_line_error(_run("predict", "--model", corrupt, "--classes", classes, grasp), "checksum mismatch")
    _one_line_error(_run("predict", "--model", root / "m.tzsl", "--classes", classes, tmp_path / "none.npz"),
                    "grasp file not found")
    _one_line_error(_run("predict", "--model", tmp_path / "no.tzsl", "--classes", classes, grasp), "not found")


def test_train_hand_errors_are_one_line(trained, tmp_path):
    root, _, _, _ = trained
    _one_line_error(_run("train-hand", "--grasps", root / "g", "--out", root / "m.tzsl"), "--force")
    _one_line_error(_run("train-hand", "--grasps", tmp_path, "--out", tmp_path / "m.tzsl"), "grasps.csv")


@pytest.mark.slow
def test_evaluate_hand_on_a_grasp_folder(trained, tmp_path):
    root, _, _, _ = trained
    out = tmp_path / "res"
    result = _run("evaluate-hand", "--grasps", root / "g", "--out", out, "--seeds", "0", "--n-sequences", 5)
    assert result.exit_code == 0, result.output
    assert sorted(p.name for p in out.iterdir()) == sorted([*HAND_OUTPUTS, "manifest.json"])  # one manifest
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["config"]["hand"]["simulated"] is False and manifest["config"]["hand"]["seeds"] == [0]
    assert any(path.endswith("grasps.csv") for path in manifest["data_files"])
    assert "Table 5" in result.output and "59.63%" in result.output and "simulating" not in result.output
    _one_line_error(_run("evaluate-hand", "--grasps", root / "g", "--out", out), "already exists", "--force")


@pytest.mark.parametrize("seeds", ["a", "1,1", "3-x", ""])
def test_bad_seeds(tmp_path, seeds):
    result = _run("evaluate-hand", "--out", tmp_path, "--seeds", seeds)
    assert result.exit_code == 2, result.output  # a usage error, before any data is read
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("tzsl: error: ") and "--seeds" in lines[0], result.output


def test_evaluate_hand_says_it_simulates(tmp_path):
    (tmp_path / "hand_table5.csv").write_text("x\n")  # refused before any simulation or fit
    result = CliRunner().invoke(cli, ["evaluate-hand", "--out", str(tmp_path), "--seeds", "0"], catch_exceptions=False)
    assert "no --grasps given: simulating grasps with seed(s) [0]" in result.output
    assert result.exit_code == EXIT_TZSL_ERROR and "hand_table5.csv already exists" in result.output


def test_train_hand_on_few_grasps_leaves_out_what_it_cannot_learn_and_predicts(tmp_path):
    """Issue 31: a small grasp folder (3 grasps per object) trains as a study would relax it: attributes
    a BioTac sees fewer than 2 grasps of a label for are left out (a note each, recorded in the bundle),
    calibration folds and PCA components shrink to what the grasps allow (notes), and predict ranks."""
    from tzsl.inference.bundle import read_bundle_header

    assert _run("simulate-grasps", "--out", tmp_path / "g", "--grasps-per-object", 3, "--seed", 2).exit_code == 0
    train = _run("train-hand", "--grasps", tmp_path / "g", "--out", tmp_path / "m.tzsl", "--seed", 0)
    assert train.exit_code == 0, train.output
    notes = [line for line in train.output.splitlines() if line.startswith("note: ")]
    left_out = [line for line in notes if " left out of the model: " in line]
    assert left_out and any("PCA components 8 -> " in line for line in notes)
    metadata = read_bundle_header(tmp_path / "m.tzsl").metadata
    recorded = {r["attribute"] for r in metadata["left_out_attributes"]}
    assert recorded == {line.split("'")[1] for line in left_out}
    assert not recorded & set(metadata["attribute_names"])
    classes = tmp_path / "classes.csv"
    TABLE.K.loc[TABLE.test_objects].rename_axis("object").to_csv(classes)
    out = _run("predict", "--model", tmp_path / "m.tzsl", "--classes", classes, tmp_path / "g" / "bowl_000.npz")
    assert out.exit_code == 0, out.output
    assert "grasp " in out.output
