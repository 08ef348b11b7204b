"""validate_dataset: every problem of a plain-file dataset folder, with file and line.

Each case builds a small folder in tmp_path (text written verbatim, so line numbers are
visible in the test) with exactly one kind of defect and checks the reported file, line and
message.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tzsl.datasets import Problem, validate_dataset
from tzsl.features import SIGNAL_STATISTICS

CLASSES = """class,hard,soft,round
cube,1,0,0
ball,0,1,1
disc,1,0,1
"""

# line numbers:   1 header, 2..9 rows
TRIALS = """trial_id,class,object,sensor,f_a,f_b
t1,cube,cube_1,left,1.0,2.0
t1,cube,cube_1,right,1.5,2.5
t2,ball,ball_1,left,3.0,4.0
t2,ball,ball_1,right,3.5,4.5
t3,disc,disc_1,left,5.0,6.0
t3,disc,disc_1,right,5.5,6.5
t4,cube,cube_2,left,7,8
t4,cube,cube_2,right,7.5,8.5
"""

GROUPS = """attribute,group
hard,material
soft,material
round,shape
"""

SPLITS = """split,object,role
s1,cube_1,train
s1,ball_1,train
s1,disc_1,test
"""

SIGNAL_TRIALS = """trial_id,class,object,signal_file
t1,cube,cube_1,signals/t1.npz
t2,ball,ball_1,signals/t2.npz
t3,disc,disc_1,signals/t3.csv
t4,cube,cube_2,signals/t4.npz
"""


def _signal(n: int = 6, seed: int = 0) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    return {"p1": rng.standard_normal(n), "p2": rng.standard_normal(n), "p3": rng.standard_normal(n)}


def _write_csv_signal(path: Path, arrays: dict[str, np.ndarray]) -> None:
    lines = [",".join(arrays)] + [",".join(repr(float(arrays[c][r])) for c in arrays)
                                  for r in range(len(next(iter(arrays.values()))))]
    path.write_text("\n".join(lines) + "\n")


def make_dataset(root: Path, *, classes: str | None = CLASSES, trials: str | None = TRIALS,
                 groups: str | None = GROUPS, splits: str | None = SPLITS, toml: str | None = None,
                 signals: dict[str, dict | bytes] | None = None) -> Path:
    folder = root / "ds"
    folder.mkdir(parents=True)
    for name, text in (("classes.csv", classes), ("trials.csv", trials), ("attribute_groups.csv", groups),
                       ("splits.csv", splits), ("dataset.toml", toml)):
        if text is not None:
            (folder / name).write_text(text)
    if signals is not None:
        (folder / "signals").mkdir()
        for rel, content in signals.items():
            path = folder / rel
            if isinstance(content, bytes):
                path.write_bytes(content)
            elif path.suffix == ".csv":
                _write_csv_signal(path, content)
            else:
                np.savez(path, **content)
    return folder


def signal_dataset(root: Path, **overrides) -> Path:
    signals = {"signals/t1.npz": _signal(seed=1), "signals/t2.npz": _signal(seed=2),
               "signals/t3.csv": _signal(seed=3), "signals/t4.npz": _signal(seed=4)}
    signals.update(overrides.pop("signals", {}))
    return make_dataset(root, trials=overrides.pop("trials", SIGNAL_TRIALS), splits=None, signals=signals,
                        **overrides)


def _one(problems: list[Problem], file: str, line: int | None, text: str) -> Problem:
    """Assert ``problems`` holds exactly one problem and it is as expected (file, line, text)."""
    assert len(problems) == 1, "\n".join(map(str, problems))
    p = problems[0]
    assert (p.file, p.line) == (file, line), str(p)
    assert text in p.message, str(p)
    shown = str(p)
    assert shown.startswith(f"{file}:{line}: " if line is not None else f"{file}: ")
    return p


def test_clean_folders(tmp_path):
    assert validate_dataset(make_dataset(tmp_path / "a"), statistics=SIGNAL_STATISTICS) == []
    assert validate_dataset(signal_dataset(tmp_path / "b"), statistics=SIGNAL_STATISTICS) == []


def test_missing_class(tmp_path):
    trials = TRIALS.replace("t3,disc,disc_1,left", "t3,cone,disc_1,left").replace(
        "t3,disc,disc_1,right", "t3,cone,disc_1,right")
    problems = validate_dataset(make_dataset(tmp_path, trials=trials))
    assert [(p.file, p.line) for p in problems] == [("trials.csv", 6), ("trials.csv", 7)]
    assert "class 'cone' is not in classes.csv" in problems[0].message


def test_unknown_attribute_in_groups(tmp_path):
    groups = GROUPS.replace("round,shape", "round,shape\nsquare,shape")
    _one(validate_dataset(make_dataset(tmp_path, groups=groups)), "attribute_groups.csv", 5,
         "unknown attribute 'square'")


def test_attribute_without_group_and_repeated(tmp_path):
    groups = "attribute,group\nhard,material\nhard,shape\nsoft,material\n"
    problems = validate_dataset(make_dataset(tmp_path, groups=groups))
    assert [(p.file, p.line) for p in problems] == [("attribute_groups.csv", 3), ("attribute_groups.csv", None)]
    assert "listed twice (also line 2)" in problems[0].message
    assert "['round']" in problems[1].message and "no group" in problems[1].message


@pytest.mark.parametrize("cell, shown", [("2", "'2'"), ("yes", "'yes'"), ("", "empty"), ("0.5", "'0.5'")])
def test_non_binary_or_empty_attribute_entry(tmp_path, cell, shown):
    classes = CLASSES.replace("ball,0,1,1", f"ball,0,{cell},1")
    _one(validate_dataset(make_dataset(tmp_path, classes=classes)), "classes.csv", 3,
         f"class 'ball', attribute 'soft': entry is {shown}; expected 0 or 1")


def test_identical_attribute_rows(tmp_path):
    classes = CLASSES.replace("disc,1,0,1", "disc,1,0,0")
    _one(validate_dataset(make_dataset(tmp_path / "a", classes=classes)), "classes.csv", 4,
         "class 'disc' has the same attribute row as class 'cube' (line 2)")
    allowed = make_dataset(tmp_path / "b", classes=classes, toml="[classes]\nallow_identical_rows = true\n")
    assert validate_dataset(allowed) == []


def test_duplicate_class_row(tmp_path):
    classes = CLASSES + "ball,1,1,1\n"
    _one(validate_dataset(make_dataset(tmp_path, classes=classes)), "classes.csv", 5,
         "class 'ball' is defined twice (also line 3)")


def test_classes_header_and_missing_file(tmp_path):
    _one(validate_dataset(make_dataset(tmp_path / "a", classes="name,hard\ncube,1\n", trials=None, groups=None,
                                       splits=None)
                          )[:1], "classes.csv", 1, "first column must be 'class'")
    problems = validate_dataset(make_dataset(tmp_path / "b", classes=None, groups=None))
    _one(problems, "classes.csv", None, "file not found")
    _one(validate_dataset(tmp_path / "nowhere"), str(tmp_path / "nowhere"), None, "dataset folder not found")


def test_signal_file_missing(tmp_path):
    folder = signal_dataset(tmp_path)
    (folder / "signals" / "t2.npz").unlink()
    _one(validate_dataset(folder), "trials.csv", 3, "trial 't2': signal file 'signals/t2.npz' not found")


def test_signal_file_unreadable(tmp_path):
    folder = signal_dataset(tmp_path, signals={"signals/t4.npz": b"not a zip archive"})
    _one(validate_dataset(folder), "signals/t4.npz", None, "not a readable .npz archive")
    folder = signal_dataset(tmp_path / "b", signals={"signals/t3.csv": b"p1,p2,p3\n1,2,x\n"})
    _one(validate_dataset(folder), "signals/t3.csv", 2, "channel 'p3' holds 'x'")


def test_wrong_channel_count_and_names(tmp_path):
    short = _signal(seed=5)
    del short["p3"]
    p = _one(validate_dataset(signal_dataset(tmp_path / "a", signals={"signals/t2.npz": short})),
             "signals/t2.npz", None, "has 2 channel(s), expected 3 as in the first signal file 'signals/t1.npz'")
    assert "missing ['p3']" in p.message and "trials.csv line 3" in p.message
    renamed = _signal(seed=5)
    renamed["q3"] = renamed.pop("p3")
    p = _one(validate_dataset(signal_dataset(tmp_path / "b", signals={"signals/t4.npz": renamed})),
             "signals/t4.npz", None, "missing ['p3']; extra ['q3']")
    # channels configured in dataset.toml: files may hold more, but none may lack one
    toml = '[signals]\nchannels = ["p2", "p4"]\n'
    problems = validate_dataset(signal_dataset(tmp_path / "c", toml=toml))
    assert len(problems) == 4 and all("missing ['p4']" in p.message and "[signals] channels" in p.message
                                      for p in problems)


def test_nan_and_inf_in_features(tmp_path):
    trials = TRIALS.replace("t2,ball,ball_1,right,3.5,4.5", "t2,ball,ball_1,right,nan,4.5").replace(
        "t4,cube,cube_2,left,7,8", "t4,cube,cube_2,left,7,inf")
    problems = validate_dataset(make_dataset(tmp_path, trials=trials))
    assert [(p.file, p.line) for p in problems] == [("trials.csv", 5), ("trials.csv", 8)]
    assert "feature 'f_a' is nan (NaN/inf)" in problems[0].message
    assert "feature 'f_b' is inf (NaN/inf)" in problems[1].message


def test_non_numeric_and_empty_features(tmp_path):
    trials = TRIALS.replace("t1,cube,cube_1,left,1.0,2.0", "t1,cube,cube_1,left,one,").replace(
        "t3,disc,disc_1,right,5.5,6.5", "t3,disc,disc_1,right,5.5,6.5,7")
    problems = validate_dataset(make_dataset(tmp_path, trials=trials))
    assert [str(p) for p in problems] == [
        "trials.csv:7: row has 7 fields; the header has 6",
        "trials.csv:6: trial 't3' has no row for sensor 'right' (it has ['left']; every trial needs one row "
        "per sensor)",
        "trials.csv:2: trial 't1': feature 'f_a' is 'one', not a number",
        "trials.csv:2: trial 't1': feature 'f_b' is empty",
    ]


def test_nan_in_signals(tmp_path):
    bad_csv = _signal(seed=3)
    bad_csv["p2"][3] = np.nan
    _one(validate_dataset(signal_dataset(tmp_path / "a", signals={"signals/t3.csv": bad_csv})),
         "signals/t3.csv", 5, "channel 'p2' is NaN or empty (1 non-finite value(s) in the file)")
    bad_npz = _signal(seed=4)
    bad_npz["p1"][[2, 4]] = np.inf
    _one(validate_dataset(signal_dataset(tmp_path / "b", signals={"signals/t4.npz": bad_npz})),
         "signals/t4.npz", None, "channel 'p1' is infinite at row 2 (2 non-finite value(s) in the file)")


def test_duplicate_trial_ids_per_sensor(tmp_path):
    trials = TRIALS + "t2,ball,ball_1,left,9,9\n"
    _one(validate_dataset(make_dataset(tmp_path / "a", trials=trials)), "trials.csv", 10,
         "duplicate trial id 't2' with sensor 'left' (also line 4)")
    single = "trial_id,class,f\nt1,cube,1\nt2,ball,2\nt1,cube,3\n"
    _one(validate_dataset(make_dataset(tmp_path / "b", trials=single, splits=None)), "trials.csv", 4,
         "duplicate trial id 't1' (also line 2)")


def test_trial_missing_a_sensor_row(tmp_path):
    trials = TRIALS.replace("t3,disc,disc_1,right,5.5,6.5\n", "")
    _one(validate_dataset(make_dataset(tmp_path, trials=trials)), "trials.csv", 6,
         "trial 't3' has no row for sensor 'right'")


def test_splits_naming_unknown_objects(tmp_path):
    splits = SPLITS + "s1,pyramid_9,test\ns1,cube_2,validation\n"
    problems = validate_dataset(make_dataset(tmp_path, splits=splits))
    assert [str(p) for p in problems] == [
        "splits.csv:5: unknown object 'pyramid_9': no trial in trials.csv has it",
        "splits.csv:6: role 'validation' is not one of ('train', 'test')",
    ]


def test_object_in_two_classes_and_inconsistent_sensor_rows(tmp_path):
    trials = TRIALS.replace("t4,cube,cube_2,left", "t4,ball,cube_1,left")
    problems = validate_dataset(make_dataset(tmp_path, trials=trials, splits=None))
    texts = [str(p) for p in problems]
    assert "trials.csv:8: object 'cube_1' has class 'ball' here but 'cube' on line 2; an object belongs to one " \
           "class" in texts
    assert any(t.startswith("trials.csv:9: trial 't4': class, object differ(s) from its row on line 8") for t in texts)


def test_signal_paths_must_stay_inside(tmp_path):
    trials = SIGNAL_TRIALS.replace("signals/t2.npz", "../t2.npz").replace("signals/t4.npz", "signals/t4.mat")
    problems = validate_dataset(signal_dataset(tmp_path, trials=trials))
    assert [(p.file, p.line) for p in problems] == [("trials.csv", 3), ("trials.csv", 5)]
    assert "relative to the folder, inside it" in problems[0].message
    assert "unsupported type '.mat'" in problems[1].message


def test_features_and_signal_file_together(tmp_path):
    trials = "trial_id,class,signal_file,f_x\nt1,cube,signals/t1.npz,1\n"
    _one(validate_dataset(make_dataset(tmp_path, trials=trials, splits=None)), "trials.csv", 1,
         "has a signal_file column and feature columns ['f_x']")


def test_settings_problems(tmp_path):
    toml = 'name = "x"\ncolour = "red"\n\n[signals]\nbaseline_rows = -3\nstatistics = ["mean", "mode"]\n'
    problems = validate_dataset(signal_dataset(tmp_path / "a", toml=toml), statistics=SIGNAL_STATISTICS)
    assert [str(p) for p in problems] == [
        "dataset.toml:2: unknown key 'colour'; known: ['name', '[classes]', '[signals]']",
        "dataset.toml:5: [signals] baseline_rows is -3; expected an integer >= 0",
        "dataset.toml:6: unknown statistic(s) ['mode']; choose from " + ", ".join(SIGNAL_STATISTICS),
    ]
    _one(validate_dataset(signal_dataset(tmp_path / "b", toml="name = \n")), "dataset.toml", 1, "not valid TOML")
    _one(validate_dataset(make_dataset(tmp_path / "c", toml="[signals]\nbaseline_rows = 2\n")), "dataset.toml", 1,
         "[signals] settings given but trials.csv has feature columns")


def test_signal_shorter_than_baseline(tmp_path):
    folder = signal_dataset(tmp_path, toml="[signals]\nbaseline_rows = 5\n",
                            signals={"signals/t2.npz": _signal(n=4, seed=9)})
    _one(validate_dataset(folder), "signals/t2.npz", None, "signal has 4 rows; at least 5 needed")


def test_every_problem_at_once(tmp_path):
    classes = CLASSES.replace("ball,0,1,1", "ball,0,7,1") + "cube,0,0,0\n"
    trials = TRIALS.replace("t2,ball,ball_1,left,3.0", "t2,ball,ball_1,left,x") + "t9,cone,c9,left,1,1\n"
    groups = GROUPS + "weight,physical\n"
    splits = SPLITS + "s1,nobody,test\n"
    problems = validate_dataset(make_dataset(tmp_path, classes=classes, trials=trials, groups=groups, splits=splits))
    where = {(p.file, p.line) for p in problems}
    assert {("classes.csv", 3), ("classes.csv", 5), ("attribute_groups.csv", 5), ("trials.csv", 4),
            ("trials.csv", 10), ("splits.csv", 5)} <= where


@pytest.mark.parametrize("file, separator", [("classes.csv", ";"), ("trials.csv", ";"), ("trials.csv", "\t"),
                                             ("splits.csv", ";")])
def test_a_file_separated_by_semicolons_or_tabs_is_named_with_its_separator(tmp_path, file, separator):
    """A spreadsheet in a comma-decimal locale saves "CSV" with ';' (or a tab-separated export): the header is
    one field then; say which separator it holds instead of listing the columns it seems to lack."""
    texts = {"classes.csv": CLASSES, "trials.csv": TRIALS, "splits.csv": SPLITS}
    texts[file] = texts[file].replace(",", separator)
    folder = make_dataset(tmp_path, classes=texts["classes.csv"], trials=texts["trials.csv"],
                          splits=texts["splits.csv"])
    _one([p for p in validate_dataset(folder) if p.file == file], file, 1,
         f"fields are separated by {separator!r}, not by commas; save the file as comma-separated CSV")


@pytest.mark.parametrize("encode, shown", [(lambda t: t.encode("utf-16"), "(it is UTF-16)"),
                                           (lambda t: t.encode("latin-1") + b"caf\xe9\n", "(byte 0xe9 at byte")])
def test_a_file_that_is_not_utf8_says_what_it_is(tmp_path, encode, shown):
    folder = make_dataset(tmp_path)
    (folder / "trials.csv").write_bytes(encode(TRIALS))
    _one(validate_dataset(folder), "trials.csv", None, f"cannot read the file as UTF-8 text {shown}")
