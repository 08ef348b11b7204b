"""A dataset or grasp folder never reads outside itself; signal CSV defects are one located line."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from tests.datasets.test_grasps import _grasps
from tests.datasets.test_validate import SIGNAL_TRIALS, _signal, signal_dataset
from tzsl.cli import cli
from tzsl.datasets import read_grasps, read_plain_dataset, validate_dataset, write_grasps
from tzsl.exceptions import DataFileError


def _outside_npz(tmp_path: Path) -> Path:
    secret = tmp_path / "elsewhere" / "secret.npz"
    secret.parent.mkdir()
    np.savez(secret, **_signal(seed=9))
    return secret


def test_symlinked_signal_outside_the_folder_is_refused_with_its_line(tmp_path):
    folder = signal_dataset(tmp_path)
    secret = _outside_npz(tmp_path)
    (folder / "signals" / "t2.npz").unlink()
    os.symlink(secret, folder / "signals" / "t2.npz")
    problems = validate_dataset(folder)
    assert [(p.file, p.line) for p in problems] == [("trials.csv", 3)]
    assert "symbolic link" in problems[0].message and "outside the folder" in problems[0].message
    with pytest.raises(DataFileError, match=r"trials\.csv:3: trial 't2': signal_file 'signals/t2\.npz' is a symbolic"):
        read_plain_dataset(folder)


def test_symlink_inside_the_folder_is_fine(tmp_path):
    folder = signal_dataset(tmp_path)
    (folder / "signals" / "t2.npz").rename(folder / "signals" / "real_t2.npz")
    os.symlink("real_t2.npz", folder / "signals" / "t2.npz")
    assert validate_dataset(folder) == []


def test_symlinked_folder_inside_pointing_outside_is_refused(tmp_path):
    folder = signal_dataset(tmp_path)
    secret = _outside_npz(tmp_path)
    os.symlink(secret.parent, folder / "linked")
    trials = SIGNAL_TRIALS.replace("signals/t4.npz", "linked/secret.npz")
    (folder / "trials.csv").write_text(trials)
    problems = validate_dataset(folder)
    assert [(p.file, p.line) for p in problems] == [("trials.csv", 5)]


@pytest.mark.parametrize("cell", ["../../etc/passwd.csv", "/etc/x.npz", "signals/../../x.npz"])
def test_dotdot_and_absolute_signal_paths_are_refused(tmp_path, cell):
    folder = signal_dataset(tmp_path, trials=SIGNAL_TRIALS.replace("signals/t1.npz", cell))
    problems = validate_dataset(folder)
    assert [(p.file, p.line) for p in problems] == [("trials.csv", 2)]
    assert "inside it" in problems[0].message


@pytest.mark.parametrize("name", ["trials.csv", "classes.csv", "dataset.toml"])
def test_dataset_tables_symlinked_outside_are_refused(tmp_path, name):
    folder = signal_dataset(tmp_path, toml='name = "x"\n')
    target = tmp_path / f"outside_{name}"
    (folder / name).rename(target)
    os.symlink(target, folder / name)
    problems = validate_dataset(folder)
    assert any(p.file == name and "outside the folder" in p.message for p in problems), problems


def test_validate_cli_reports_outside_link(tmp_path):
    folder = signal_dataset(tmp_path)
    secret = _outside_npz(tmp_path)
    (folder / "signals" / "t2.npz").unlink()
    os.symlink(secret, folder / "signals" / "t2.npz")
    result = CliRunner().invoke(cli, ["validate", str(folder)])
    assert result.exit_code != 0
    assert "trials.csv:3: trial 't2': signal_file 'signals/t2.npz' is a symbolic link" in result.stdout
    assert len(result.stderr.strip().splitlines()) == 1 and str(folder) in result.stderr


# ------------------------------------------------------------------ grasp folders
def _grasp_folder(tmp_path: Path) -> Path:
    folder = tmp_path / "grasps"
    write_grasps(folder, _grasps(2))
    return folder


def _set_file(folder: Path, row: int, value: str) -> None:
    lines = (folder / "grasps.csv").read_text().splitlines()
    header = lines[0].split(",")
    cells = lines[row].split(",")
    cells[header.index("file")] = value
    lines[row] = ",".join(cells)
    (folder / "grasps.csv").write_text("\n".join(lines) + "\n")


@pytest.mark.parametrize("value", ["../../outside.npz", "/etc/passwd"])
def test_grasp_file_outside_the_folder_is_refused(tmp_path, value):
    folder = _grasp_folder(tmp_path)
    _set_file(folder, 2, value)
    with pytest.raises(DataFileError, match=r"grasps\.csv:3: grasp .*: file .* must be a path relative"):
        read_grasps(folder)


def test_grasp_file_symlinked_outside_is_refused(tmp_path):
    folder = _grasp_folder(tmp_path)
    target = tmp_path / "outside.npz"
    rel = (folder / "grasps.csv").read_text().splitlines()[1].split(",")[-1]
    header = (folder / "grasps.csv").read_text().splitlines()[0].split(",")
    rel = (folder / "grasps.csv").read_text().splitlines()[1].split(",")[header.index("file")]
    (folder / rel).rename(target)
    os.symlink(target, folder / rel)
    with pytest.raises(DataFileError, match=r"grasps\.csv:2: grasp .*symbolic link.*outside the folder"):
        read_grasps(folder)


# ------------------------------------------------------------------ signal CSV defects
def _csv_signal_dataset(tmp_path: Path, text: str) -> Path:
    folder = signal_dataset(tmp_path)
    (folder / "signals" / "t3.csv").write_text(text)
    return folder


@pytest.mark.parametrize(
    ("text", "line", "words"),
    [
        ("p1,p2,p3\n", 1, "header line but no data lines"),
        ("p1,p2,p3\n1,2,3,\n4,5,6,\n", 2, "trailing comma"),
        ("p1,p2,p3\n1,2,3\n4,5,6,7\n", 3, "4 fields; the header has 3"),
        ("", 1, "file is empty"),
    ],
)
def test_signal_csv_defects_are_located(tmp_path, text, line, words):
    problems = validate_dataset(_csv_signal_dataset(tmp_path, text))
    assert [(p.file, p.line) for p in problems] == [("signals/t3.csv", line)], problems
    assert words in problems[0].message


def test_binary_signal_csv_is_one_line(tmp_path):
    folder = signal_dataset(tmp_path)
    (folder / "signals" / "t3.csv").write_bytes(bytes(range(256)) * 4)
    problems = validate_dataset(folder)
    assert len(problems) == 1 and "\n" not in str(problems[0]) and problems[0].file == "signals/t3.csv"


def test_constant_attribute_is_flagged(tmp_path):
    classes = "class,hard,soft,round\ncube,1,0,0\nball,0,1,0\ndisc,1,0,0\n"
    folder = signal_dataset(tmp_path, classes=classes.replace("disc,1,0,0", "disc,1,1,0"))
    problems = validate_dataset(folder)
    assert [(p.file, p.line) for p in problems] == [("classes.csv", 1)]
    assert ("attribute 'round' is 0 for every class" in problems[0].message
            and "remove the column" in problems[0].message)


def test_data_file_error_uses_path_colon_line():
    assert str(DataFileError("a/b.csv", "bad cell", line=7)) == "a/b.csv:7: bad cell"
    assert str(DataFileError("a/b.csv", "bad", trial="t1", line=3)) == "a/b.csv:3, trial t1: bad"
