"""``physiclear`` (clear-nus/octopi, PhysiCLeAR): its registered files, the class-attribute table read from
``utils/constants.py`` (every value with its line) in both encodings, the paper's split as a split file, the
key frames, and the whole way on a small release of tiny videos made here and served on 127.0.0.1, never the
network: ``tzsl data fetch``, ``tzsl convert``, ``tzsl validate``, a zero-shot study that fetches it on first use,
one line for a video whose hash differs or that cannot be decoded."""

from __future__ import annotations

import csv
import hashlib
import json
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from tests.datasets.fetch_server import registered_release, registry_of, run_cli
from tests.datasets.physiclear_release import OBJECTS, constants_source, press_video, write_release
from tests.study_settings import FAST_TEMPLATE
from tzsl.datasets import (
    _registry,
    builtin_data_files,
    contact_key_frames,
    dataset_names,
    describe_physiclear_video,
    physiclear_split_file,
    physiclear_videos,
    read_octopi_constants,
    read_physiclear_attributes,
    registered_files,
)
from tzsl.datasets._physiclear_table import (
    ATTRIBUTE_TABLE,
    PHYSICLEAR_COMMIT,
    physiclear_records,
    physiclear_splits_from_constants,
)
from tzsl.evaluation import read_splits_csv
from tzsl.exceptions import ConfigError, DataFileError

TABLE = Path(__file__).resolve().parents[2] / "tzsl" / "datasets" / ATTRIBUTE_TABLE


@pytest.fixture(autouse=True)
def _fresh_verdicts():
    _registry.clear_verification_cache()
    yield
    _registry.clear_verification_cache()


def test_the_registry_pins_every_video_and_the_annotations_at_one_commit():
    files = registered_files("physiclear/")
    videos = [f for f in files if f.endswith(".mov")]
    assert len(videos) == 476 and files == sorted([*videos, "physiclear/utils/constants.py"])
    urls = _registry.registry().urls
    for relpath in files:
        assert urls[relpath] == (f"https://raw.githubusercontent.com/clear-nus/octopi/{PHYSICLEAR_COMMIT}/"
                                 f"{relpath.removeprefix('physiclear/')}")
    assert builtin_data_files("physiclear") == files and "physiclear" in dataset_names(convertible=True)


# ----------------------------------------------------------------------------- the class table and split


def test_every_value_of_the_table_has_its_line_in_constants_py():
    with open(TABLE, encoding="utf-8", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 74 * 4
    variables = {"hardness": "HARDNESS_RANK", "roughness": "ROUGHNESS_RANK", "bumpiness": "TEXTURE_RANK",
                 "material": "MATERIALS"}
    for row in rows:
        assert re.fullmatch(rf"utils/constants\.py, {variables[row['property']]}, line \d+", row["source"]), row
    table = read_physiclear_attributes()
    assert table.ranks.shape == (74, 3) and set(np.unique(table.ranks)) == {0, 1, 2}
    assert table.ranks.loc["aluminium_foil"].tolist() == [1, 1, 1] and table.materials["egg"] == "food"
    assert len(physiclear_videos(table)) == 408  # the paper's 74 objects and 408 videos


def test_both_encodings_of_the_ranks():
    levels = read_physiclear_attributes(encoding="levels")
    thresholds = read_physiclear_attributes(encoding="thresholds")
    ranks = levels.ranks
    for prop in ("hardness", "roughness", "bumpiness"):
        block = levels.classes.filter(regex=f"^{prop}_")
        assert block.shape[1] == 3 and (block.sum(axis=1) == 1).all()
        above = thresholds.classes.filter(regex=f"^{prop}_above_").to_numpy()
        assert above.shape[1] == 2 and (above.sum(axis=1) == ranks[prop].to_numpy()).all()
    materials = levels.classes.filter(regex="^material_")
    counts = levels.materials.value_counts()
    assert sorted(c.removeprefix("material_") for c in materials) == sorted(counts[counts >= 3].index)
    assert (materials.sum(axis=1) <= 1).all()
    every = read_physiclear_attributes(min_material_objects=0).classes.filter(regex="^material_")
    assert every.shape[1] == levels.materials.nunique() and (every.sum(axis=1) == 1).all()
    with pytest.raises(ConfigError, match="encoding must be one of levels, thresholds"):
        read_physiclear_attributes(encoding="ordinal")


def test_the_split_file_is_the_papers_split_and_the_study_reads_it():
    text = physiclear_split_file().read_text()
    frame = pd.read_csv(physiclear_split_file())
    assert list(frame.columns) == ["split", "object", "role"]
    counts = frame.groupby(["split", "role"]).size().to_dict()
    assert counts == {("physiclear-test", "test"): 7, ("physiclear-test", "train"): 67,
                      ("physiclear-validation", "test"): 6, ("physiclear-validation", "train"): 60}
    assert "physiclear-validation,nylon_shirt,test" in text  # denim has its row: left out of that split
    assert "physiclear-validation,denim," not in text
    for encoding in ("levels", "thresholds"):
        table = read_physiclear_attributes(encoding=encoding)
        splits = read_splits_csv(physiclear_split_file(), table.classes)
        assert [s.name for s in splits] == ["physiclear-validation", "physiclear-test"]
        assert set(splits[1].train_objects) | set(splits[1].test_objects) == set(table.classes.index)
        assert [s.excluded_attributes for s in splits] == [(), ()]


def test_the_table_and_split_are_made_from_constants_py(tmp_path):
    path = tmp_path / "constants.py"
    path.write_text("import os\n" + constants_source(OBJECTS))
    constants = read_octopi_constants(path)
    records, left_out = physiclear_records(constants, [*OBJECTS, "apple"])
    assert left_out == ["apple"] and len(records) == 4 * len(OBJECTS)
    lines = path.read_text().splitlines()
    for row in records.itertuples(index=False):
        number = int(row.source.rsplit(" ", 1)[1])
        assert f"'physiclear_{row.object}':" in lines[number - 1] and row.value in lines[number - 1]
    shipped = pd.read_csv(TABLE, dtype=str).set_index(["object", "property"])["value"]
    assert records.set_index(["object", "property"])["value"].to_dict() == shipped.loc[list(OBJECTS)].to_dict()
    classes = read_physiclear_attributes().classes.loc[list(OBJECTS)]
    split_lines = physiclear_splits_from_constants(constants, classes).splitlines()
    assert split_lines[0] == "split,object,role" and "physiclear-test,orange,test" in split_lines


@pytest.mark.parametrize(("text", "message"), [
    ("HARDNESS_RANK = {\n", "cannot read it as Python source"),
    ("HARDNESS_RANK = {}\n", "no literal assignment of MATERIALS, ROUGHNESS_RANK"),
    ("HARDNESS_RANK = {'physiclear_egg': rank}\n", "HARDNESS_RANK holds an entry that is not a literal"),
])
def test_a_damaged_constants_py_is_one_line_naming_it(tmp_path, text, message):
    path = tmp_path / "constants.py"
    path.write_text(text)
    with pytest.raises(DataFileError, match=message) as info:
        read_octopi_constants(path)
    assert str(info.value).startswith(str(path)) and len(str(info.value).splitlines()) == 1


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


@pytest.mark.parametrize(("change", "message"), [
    (lambda r: r.update(value="3") if r["object"] == "egg" and r["property"] == "hardness" else None,
     "egg hardness: rank '3' is not 0, 1 or 2"),
    (lambda r: r.update(source="utils/constants.py, HARDNESS_RANK, line 9") if r["object"] == "egg"
     and r["property"] == "roughness" else None, "egg roughness: source must be 'utils/constants.py, ROUGHNESS_RANK"),
    (lambda r: r.update(property="weight") if r["object"] == "rug" and r["property"] == "bumpiness" else None,
     "property 'weight' is not one of"),
    (lambda r: r.update(value="Soft Plastic") if r["object"] == "rug" and r["property"] == "material" else None,
     "rug material 'Soft Plastic' is not a lower-case word"),
    (lambda r: r.update(object="egg") if r["object"] == "potato" and r["property"] == "material" else None,
     "egg is given twice for 'material'"),
    (lambda r: not (r["object"] == "potato" and r["property"] == "hardness"), r"potato lacks \['hardness'\]"),
])
def test_a_table_value_without_its_source_is_refused_in_one_line(tmp_path, change, message):
    path = _edited_table(tmp_path, change)
    with pytest.raises(DataFileError, match=message) as info:
        read_physiclear_attributes(path)
    assert len(str(info.value).splitlines()) == 1 and str(info.value).startswith(str(path))


# ----------------------------------------------------------------------------- key frames and features


def test_the_key_frames_span_the_contact_at_half_maximum():
    diff = np.array([0, 0.5, 0.6, 0.5, 1.0, 2.6, 3.0, 2.8, 2.4, 2.0, 1.9, 1.8, 0.9, 0.7, 0.8])
    # the contact: frames 5-11, over 0.5 + 0.5 * (3.0 - 0.5) = 1.75; the key frames round(linspace(5, 11, 5))
    assert contact_key_frames(diff).tolist() == [5, 7, 8, 10, 11]
    with pytest.raises(DataFileError, match="the contact lasts 2 frames"):
        contact_key_frames(np.array([0, 0.5, 0.5, 3.0, 3.0, 0.5, 0.5, 0.5]), source="v.mov")
    with pytest.raises(DataFileError, match="no contact"):
        contact_key_frames(np.zeros(10), source="v.mov")


def test_a_video_is_described_by_its_key_frames(tmp_path):
    path = tmp_path / "egg_0.mov"
    path.write_bytes(press_video(np.array([2.0, 0.0, 0.0]), 0))
    features, names = describe_physiclear_video(path)
    assert features.shape == (len(names),) and np.isfinite(features).all() and len(names) % 5 == 0
    assert names[0] == "key1_mean" and names[-1].startswith("key5_")
    still = tmp_path / "still_0.mov"
    still.write_bytes(b"\0" * 100)
    with pytest.raises(DataFileError, match="cannot decode video") as info:
        describe_physiclear_video(still)
    assert str(info.value).startswith(str(still)) and len(str(info.value).splitlines()) == 1


# ----------------------------------------------------------------------------- the whole way, on a served release


@pytest.fixture(scope="module")
def release(tmp_path_factory):
    """The small release, written once for the module (its videos take seconds to encode); tests read it only."""
    folder = tmp_path_factory.mktemp("physiclear") / "served"
    return folder, write_release(folder)


@pytest.fixture
def served(release, tmp_path, monkeypatch):
    """The small release served on 127.0.0.1 and registered instead of tzsl's registry; yields
    (served folder, registered path -> content)."""
    folder, files = release
    with registered_release(folder, files, tmp_path / "registry.txt", monkeypatch):
        yield folder, files


def test_fetch_convert_validate(tmp_path, served):
    _, files = served
    home, plain = tmp_path / "home", tmp_path / "plain"
    code, out, err = run_cli("data", "fetch", "physiclear", "--data-dir", home, "--no-progress")
    assert code == 0 and f"physiclear: 0 present, {len(files)} downloaded" in out, err
    code, out, err = run_cli("convert", "--dataset", "physiclear", "--data-dir", home, "--out", plain)
    assert code == 0, err
    assert f"{len(OBJECTS)} classes x 14 attributes, {2 * len(OBJECTS)} trials, 1 sensor(s)" in out  # no paper, wood
    code, out, err = run_cli("validate", plain)
    assert code == 0 and out.rstrip().endswith("valid"), err + out
    trials = pd.read_csv(plain / "trials.csv")
    assert trials["trial_id"].tolist()[:2] == ["aluminium_foil_0", "aluminium_foil_1"]
    assert (trials["class"] == trials["object"]).all() and set(trials["sensor"]) == {"gelsight"}
    split = pd.read_csv(plain / "splits.csv")  # the paper's split over the written objects
    shipped = pd.read_csv(physiclear_split_file())
    assert set(split["object"]) == set(OBJECTS)
    both = split.merge(shipped, on=["split", "object"])  # denim tests here: nylon_shirt, its row, is not written
    assert (both["role_x"] == both["role_y"]).all() and len(both) == len(split) - 1


def test_a_study_fetches_it_on_first_use_and_runs(tmp_path, served, monkeypatch):
    monkeypatch.chdir(tmp_path)
    home = tmp_path / "first-use"
    home.mkdir()
    (tmp_path / "physiclear.toml").write_text(
        f'study = "zero-shot"\ndescription = "physiclear, small release"\n[dataset]\nbuiltin = "physiclear"\n'
        f'data_dir = "{home}"\n[output]\nfolder = "results"\n'
        + FAST_TEMPLATE.replace("[splits]\nn_splits = 2", '[splits]\nkinds = ["file"]'))  # its own split, no path
    code, out, err = run_cli("run", "physiclear.toml", "--no-progress")
    assert code == 0, err + out
    splits = pd.read_csv(tmp_path / "results" / "splits.csv")
    assert set(splits["split"]) == {"physiclear-validation", "physiclear-test"} and splits["kind"].eq("file").all()
    assert f"first use: fetching {2 * len(OBJECTS) + 1} data files of physiclear" in out + err
    manifest = json.loads((tmp_path / "results" / "manifest.json").read_text())
    size = manifest["config"]["dataset_size"]
    assert manifest["config"]["dataset"] == "physiclear" and size["objects"] == len(OBJECTS)
    assert size["sensors"] == 1 and size["trials"] == 2 * len(OBJECTS)


@pytest.mark.parametrize("damage", ["hash", "undecodable"])
def test_a_damaged_video_is_one_line_naming_it(tmp_path, served, monkeypatch, damage):
    folder, files = served
    home = tmp_path / "home"
    assert run_cli("data", "fetch", "physiclear", "--data-dir", home, "--no-progress")[0] == 0
    damaged = "physiclear/dataset/egg_1.mov"
    if damage == "hash":
        (home / damaged).write_bytes(files[damaged][:-30])
    else:  # registered with the hash of its bytes, and not a video
        garbage = b"not a video " * 40
        (home / damaged).write_bytes(garbage)
        lines = [f"{r} sha256:{hashlib.sha256(garbage if r == damaged else c).hexdigest()}"
                 for r, c in files.items()]
        pup = registry_of(tmp_path / "registry2.txt", lines)
        monkeypatch.setattr(_registry, "registry", lambda: pup)
    code, _, err = run_cli("convert", "--dataset", "physiclear", "--data-dir", home, "--out", tmp_path / "plain")
    lines = [line for line in err.splitlines() if line.strip()]
    assert code != 0 and len(lines) == 1 and lines[0].startswith("tzsl: error: "), err
    assert str(home / damaged) in lines[0]
    assert ("tzsl data fetch physiclear" if damage == "hash" else "cannot decode video") in lines[0]
    assert not (tmp_path / "plain").exists()


def test_the_shipped_table_and_split_are_those_of_the_pinned_constants_py():
    """Against the release's own file when the data home holds it (``tzsl data fetch physiclear``)."""
    from tzsl.datasets import fetch, get_data_home
    from tzsl.datasets._physiclear_table import CONSTANTS_FILE

    if not (get_data_home() / CONSTANTS_FILE).is_file():
        pytest.skip(f"{CONSTANTS_FILE} is not in the data home")
    constants = read_octopi_constants(fetch(CONSTANTS_FILE))
    stems = sorted({Path(r).stem.rpartition("_")[0] for r in registered_files("physiclear/dataset/")})
    records, left_out = physiclear_records(constants, stems)
    assert len(stems) == 87 and len(left_out) == 13
    assert records.to_csv(index=False, lineterminator="\n") == TABLE.read_text()
    table = read_physiclear_attributes()
    assert physiclear_splits_from_constants(constants, table.classes) == physiclear_split_file().read_text()
