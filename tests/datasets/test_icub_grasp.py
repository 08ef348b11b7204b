"""``icub-grasp`` (clear-nus/icub_grasp_dataset, the iCub Grasp Dataset): its 180 registered files, its reader,
its class-attribute table (every value with the README's phrase and the words that decide it), and the whole
way on a small release made here (the release's layout, CRLF lines) served on 127.0.0.1, never the network:
``tzsl data fetch``, ``tzsl convert``, ``tzsl validate``, a zero-shot study that fetches it on first use, one
line for a damaged file."""

from __future__ import annotations

import csv
import json
import re
from pathlib import Path

import numpy as np
import pytest

from tests.datasets.fetch_server import registered_release, run_cli
from tests.study_settings import FAST_TEMPLATE
from tzsl.datasets import (
    ICUB_GRASP_CHANNELS,
    _registry,
    builtin_data_files,
    dataset_names,
    read_icub_grasp_attributes,
    read_icub_grasp_trial,
    registered_files,
)
from tzsl.datasets._icub_grasp import (
    ATTRIBUTE_TABLE,
    ICUB_GRASP_ATTRIBUTES,
    ICUB_GRASP_COMMIT,
    ICUB_GRASP_DIR,
    ICUB_GRASP_OBJECTS,
    N_GRASPS,
)
from tzsl.datasets._registry import registered_size
from tzsl.exceptions import DataFileError

TABLE = Path(__file__).resolve().parents[2] / "tzsl" / "datasets" / ATTRIBUTE_TABLE
#: Grasps per object in the small release (files ``_1`` and ``_2``).
GRASPS = 2


@pytest.fixture(autouse=True)
def _fresh_verdicts():
    _registry.clear_verification_cache()
    yield
    _registry.clear_verification_cache()


def grasp_text(values: np.ndarray) -> bytes:
    """One grasp file in the release's layout: ``-10000``, then 7 lines per time slice (CRLF, trailing space).

    ``values``: (n_slices, 74), the channels of :data:`ICUB_GRASP_CHANNELS`."""
    lines = ["-10000"]
    for row in values:
        for start, stop in ((0, 9), (9, 14), *((14 + 12 * f, 26 + 12 * f) for f in range(5))):
            lines.append(" ".join(f"{v:g}" for v in row[start:stop]) + " ")
    return ("\r\n".join(lines) + "\r\n").encode()


def write_release(root: Path, seed: int = 0) -> dict[str, bytes]:
    """``GRASPS`` grasps of every object under ``root/icub-grasp/iCubGraspDataset/``, their readings shifted by
    the object's row of the shipped table; returns registered path -> content."""
    rng = np.random.default_rng(seed)
    classes = read_icub_grasp_attributes().classes
    files = {}
    for obj in ICUB_GRASP_OBJECTS:
        base = 200 - 30 * np.resize(classes.loc[obj].to_numpy(dtype=float), 74)
        for n in range(1, GRASPS + 1):
            relpath = f"{ICUB_GRASP_DIR}{obj}_{n}.txt"
            files[relpath] = grasp_text(np.round(base + 3 * rng.standard_normal((6, 74)), 3))
            (root / relpath).parent.mkdir(parents=True, exist_ok=True)
            (root / relpath).write_bytes(files[relpath])
    return files


def test_the_registry_pins_20_grasps_of_each_of_the_9_objects_at_one_commit():
    files = registered_files(ICUB_GRASP_DIR)
    assert files == sorted(f"{ICUB_GRASP_DIR}{o}_{n}.txt" for o in ICUB_GRASP_OBJECTS for n in range(1, N_GRASPS + 1))
    urls = _registry.registry().urls
    for relpath in files:
        assert urls[relpath] == (f"https://raw.githubusercontent.com/clear-nus/icub_grasp_dataset/{ICUB_GRASP_COMMIT}/"
                                 f"{relpath.removeprefix('icub-grasp/')}")
    assert sum(registered_size(r) or 0 for r in files) == 1111911  # the 180 files at that commit


def test_the_reader_keeps_every_value_as_published(tmp_path):
    values = np.arange(3 * 74, dtype=float).reshape(3, 74) / 4
    path = tmp_path / "book_1.txt"
    path.write_bytes(grasp_text(values))
    read = read_icub_grasp_trial(path)
    assert read.shape == (3, 74) and read.dtype == np.float64 and np.array_equal(read, values)
    assert len(ICUB_GRASP_CHANNELS) == 74 and ICUB_GRASP_CHANNELS[:2] == ("joint_7", "joint_8")
    assert ICUB_GRASP_CHANNELS[14] == "thumb_1" and ICUB_GRASP_CHANNELS[-1] == "little_12"


GOOD = grasp_text(np.ones((2, 74))).decode().split("\r\n")  # 15 lines and a last empty one


@pytest.mark.parametrize(("lines", "where", "message"), [
    (["10000", *GOOD[1:]], 1, "first line is not -10000"),
    (GOOD[:12], 9, "the time slice starting here has 4 of its 7 lines"),
    (GOOD[:8], 1, r"holds 1 time slice\(s\); at least 2 needed"),
    ([*GOOD[:3], "14 15 11 14", *GOOD[4:]], 4, "line 3 of a time slice holds 4 values; expected 12"),
    ([*GOOD[:9], GOOD[9].replace("1", "one", 1), *GOOD[10:]], 10, "'one' is not a number"),
    ([*GOOD[:2], GOOD[2].replace("1", "nan", 1), *GOOD[3:]], 3, "not finite"),
])
def test_a_damaged_file_is_one_line_naming_it(tmp_path, lines, where, message):
    path = tmp_path / "lotion_3.txt"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(DataFileError, match=message) as info:
        read_icub_grasp_trial(path)
    assert str(info.value).startswith(f"{path}:{where}: ") and len(str(info.value).splitlines()) == 1


def test_a_file_that_is_not_text_is_one_line_naming_it(tmp_path):
    path = tmp_path / "book_2.txt"
    path.write_bytes(b"-10000\r\n\x89PNG\x00")
    with pytest.raises(DataFileError, match="not a text file of numbers") as info:
        read_icub_grasp_trial(path)
    assert str(info.value).startswith(f"{path}: ") and len(str(info.value).splitlines()) == 1


# ----------------------------------------------------------------------------- the class table


def test_every_value_of_the_class_table_has_its_source():
    with open(TABLE, encoding="utf-8", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == len(ICUB_GRASP_OBJECTS) * len(ICUB_GRASP_ATTRIBUTES) == 54
    for row in rows:
        phrase = ICUB_GRASP_OBJECTS[row["object"]]
        assert row["class"] == row["object"] and row["value"] in ("0", "1"), row
        assert row["source"] == f"README.txt: '{phrase}'", row
        assert row["evidence"].split("'")[1] in phrase, row  # the words of the README that decide it
    table = read_icub_grasp_attributes()
    assert table.classes.shape == (9, 6) and list(table.classes.columns) == list(ICUB_GRASP_ATTRIBUTES)
    assert len(np.unique(table.classes.to_numpy(), axis=0)) == 6
    assert table.classes.sum().to_dict() == {"container": 6, "bottle": 4, "can": 2, "stuffed_toy": 2, "book": 1,
                                             "has_contents": 4}
    assert table.classes.loc["med_coke"].tolist() == [1, 0, 1, 0, 0, 1]
    assert table.classes.loc["empty_vitamin_water"].tolist() == [1, 1, 0, 0, 0, 0]


def _edited_table(tmp_path: Path, change) -> Path:
    with open(TABLE, encoding="utf-8", newline="") as fh:
        rows = list(csv.DictReader(fh))
    rows = [row for row in rows if change(row) is not False]
    path = tmp_path / "table.csv"
    with open(path, "w", encoding="utf-8", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]), lineterminator="\n")
        writer.writeheader()
        writer.writerows(rows)
    return path


def _only(obj: str, attribute: str, new: dict[str, str]):
    return lambda r: r.update(new) if r["object"] == obj and r["attribute"] == attribute else None


@pytest.mark.parametrize(("change", "message"), [
    (_only("book", "book", {"source": "photo"}), "book book: source must be \"README.txt: 'a hardcover book'\""),
    (_only("lotion", "can", {"source": "README.txt: 'soda can (empty)'"}), "lotion can: source must be"),
    (_only("med_coke", "can", {"evidence": "a can"}), "med_coke can: source must be .* evidence 'a can'"),
    (_only("blue_bear", "stuffed_toy", {"evidence": "'blue teddy bear': a toy"}),
     "blue_bear stuffed_toy: source must"),
    (_only("monkey_toy", "bottle", {"value": "yes"}), "monkey_toy bottle: value 'yes' is not 0 or 1"),
    (_only("lotion", "has_contents", {"attribute": "plastic"}), "attribute 'plastic' has no definition"),
    (lambda r: r.update(object="full_coke", **{"class": "full_coke"}) if r["object"] == "book" else None,
     "object 'full_coke' .* is not one the README describes"),
    (_only("empty_coke", "can", {"class": "coke"}), "object 'empty_coke' \\(class 'coke'\\)"),
])
def test_a_value_without_its_justification_is_refused_in_one_line(tmp_path, change, message):
    path = _edited_table(tmp_path, change)
    with pytest.raises(DataFileError, match=message) as info:
        read_icub_grasp_attributes(path)
    assert len(str(info.value).splitlines()) == 1 and re.match(rf"{re.escape(str(path))}:\d+: ", str(info.value))


def test_an_object_or_attribute_left_out_or_given_twice_is_refused_in_one_line(tmp_path):
    path = _edited_table(tmp_path, lambda r: not (r["object"] == "book" and r["attribute"] == "can"))
    with pytest.raises(DataFileError, match=r"book lacks attribute\(s\) \['can'\]"):
        read_icub_grasp_attributes(path)
    path = _edited_table(tmp_path, lambda r: r["object"] != "lotion")
    with pytest.raises(DataFileError, match=r"object\(s\) \['lotion'\] of the README have no line"):
        read_icub_grasp_attributes(path)
    path = _edited_table(tmp_path, _only("book", "can", {"attribute": "bottle"}))
    with pytest.raises(DataFileError, match="book is given twice for 'bottle'"):
        read_icub_grasp_attributes(path)


def test_a_malformed_table_is_one_line_naming_it(tmp_path):
    path = tmp_path / "table.csv"
    path.write_text('object,class,attribute,value,source,evidence\nbook,book,book,1,"README.txt: \'x\n')
    with pytest.raises(DataFileError, match="not a readable CSV table") as info:
        read_icub_grasp_attributes(path)
    assert str(info.value).startswith(f"{path}: ") and len(str(info.value).splitlines()) == 1
    path.write_text("object;class;value\n")
    with pytest.raises(DataFileError, match=r"columns are \['object;class;value'\]") as info:
        read_icub_grasp_attributes(path)
    assert str(info.value).startswith(f"{path}:1: ")


# ----------------------------------------------------------------------------- the whole way, on a served release


@pytest.fixture
def served(tmp_path, monkeypatch):
    """The small release served on 127.0.0.1 and registered instead of tzsl's registry; yields
    registered path -> content."""
    folder = tmp_path / "served"
    files = write_release(folder)
    with registered_release(folder, files, tmp_path / "registry.txt", monkeypatch):
        yield files


def test_it_is_a_builtin_catalog_dataset():
    assert "icub-grasp" in dataset_names(convertible=True)
    assert builtin_data_files("icub-grasp") == registered_files(ICUB_GRASP_DIR)
    code, out, _ = run_cli("datasets", "--json")
    assert code == 0 and "icub-grasp" in [d["name"] for d in json.loads(out)]


def test_fetch_convert_validate(tmp_path, served):
    home, plain = tmp_path / "home", tmp_path / "plain"
    n = GRASPS * len(ICUB_GRASP_OBJECTS)
    code, out, err = run_cli("data", "fetch", "icub-grasp", "--data-dir", home, "--no-progress")
    assert code == 0 and f"icub-grasp: 0 present, {n} downloaded" in out, err
    code, out, err = run_cli("convert", "--dataset", "icub-grasp", "--data-dir", home, "--out", plain)
    assert code == 0, err
    assert f"9 classes x 6 attributes, {n} trials, 1 sensor(s), 74 channels per signal file" in out
    code, out, err = run_cli("validate", plain)
    assert code == 0 and out.rstrip().endswith("valid"), err + out
    assert "sensors:    1 (hand)" in out and "6 distinct attribute rows" in out
    trials = (plain / "trials.csv").read_text().splitlines()
    assert trials[1].startswith("full_vitamin_water_1,full_vitamin_water,full_vitamin_water,1,")
    with np.load(next((plain / "signals").glob("full_vitamin_water_1*"))) as signal:
        assert signal.files == list(ICUB_GRASP_CHANNELS)
        stored = np.column_stack([signal[c] for c in ICUB_GRASP_CHANNELS])
    published = read_icub_grasp_trial(home / f"{ICUB_GRASP_DIR}full_vitamin_water_1.txt")
    assert np.array_equal(stored, published)


def test_a_study_fetches_it_on_first_use_and_runs(tmp_path, served, monkeypatch):
    monkeypatch.chdir(tmp_path)
    home = tmp_path / "first-use"
    home.mkdir()
    (tmp_path / "icub.toml").write_text(
        f'study = "zero-shot"\ndescription = "icub-grasp, small release"\n[dataset]\nbuiltin = "icub-grasp"\n'
        f'data_dir = "{home}"\n[output]\nfolder = "results"\n' + FAST_TEMPLATE)
    code, out, err = run_cli("run", "icub.toml", "--no-progress")
    assert code == 0, err + out
    assert f"first use: fetching {GRASPS * 9} data files of icub-grasp" in out + err
    manifest = json.loads((tmp_path / "results" / "manifest.json").read_text())
    assert manifest["config"]["dataset"] == "icub-grasp"
    size = manifest["config"]["dataset_size"]
    assert size["objects"] == 9 and size["sensors"] == 1 and size["trials"] == GRASPS * 9
    assert (tmp_path / "results" / "method_comparison.csv").is_file()


def test_a_damaged_file_in_the_data_home_is_one_line_naming_it(tmp_path, served):
    home = tmp_path / "home"
    assert run_cli("data", "fetch", "icub-grasp", "--data-dir", home, "--no-progress")[0] == 0
    damaged = f"{ICUB_GRASP_DIR}book_2.txt"
    (home / damaged).write_bytes(served[damaged][:-30])
    code, _, err = run_cli("convert", "--dataset", "icub-grasp", "--data-dir", home, "--out", tmp_path / "plain")
    lines = [line for line in err.splitlines() if line.strip()]
    assert code != 0 and len(lines) == 1 and lines[0].startswith("tzsl: error: "), err
    assert str(home / damaged) in lines[0] and "tzsl data fetch icub-grasp" in lines[0]
    assert not (tmp_path / "plain").exists()
