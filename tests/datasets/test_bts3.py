"""``bts3`` (yayaneath/biotac-sp-images, the BioTacSP Stability Set): its two registered files, its reader,
its class-attribute table (every value with its source), and the whole way on a small release made here
(the release's layout, CRLF lines) served on 127.0.0.1, never the network: ``tzsl data fetch``, ``tzsl
convert``, ``tzsl validate``, a zero-shot study that fetches it on first use, one line for a damaged file."""

from __future__ import annotations

import csv
import hashlib
import json
import re
from pathlib import Path

import numpy as np
import pytest

from tests.datasets.bts3_release import OBJECTS, write_release
from tests.datasets.fetch_server import registered_release, registry_of, run_cli, serve_folder
from tests.study_settings import FAST_TEMPLATE
from tzsl.datasets import (
    _registry,
    builtin_data_files,
    dataset_names,
    fetch_datasets,
    load_bts3,
    read_bts3_attributes,
    read_bts3_csv,
    registered_files,
)
from tzsl.datasets._bts3 import (
    ATTRIBUTE_TABLE,
    BTS3_ATTRIBUTES,
    BTS3_COMMIT,
    BTS3_FILES,
    BTS3_FINGERS,
    BTS3_PANELS,
    OBJECTS_PHOTO,
)
from tzsl.datasets._registry import registered_size
from tzsl.exceptions import ChecksumError, DataFileError

TABLE = Path(__file__).resolve().parents[2] / "tzsl" / "datasets" / ATTRIBUTE_TABLE

HEADER = "object,slipped," + ",".join(f"{f}_biotac_{i}" for f in BTS3_FINGERS for i in range(1, 25))


@pytest.fixture(autouse=True)
def _fresh_verdicts():
    _registry.clear_verification_cache()
    yield
    _registry.clear_verification_cache()


def _grasp(name: str, slipped: int, start: int) -> str:
    return f"{name},{slipped}," + ",".join(str(start + k) for k in range(72))


def _release(seed: int) -> bytes:
    rng = np.random.default_rng(seed)
    lines = [HEADER] + [_grasp(name, int(rng.integers(2)), int(rng.integers(100, 3000)))
                        for name in ("pringles", "coke", "yellow_sponge") for _ in range(3)]
    return ("\r\n".join(lines) + "\r\n").encode()


def test_the_registry_pins_both_files_at_one_commit():
    assert registered_files("bts3/") == sorted(BTS3_FILES.values())
    urls = _registry.registry().urls
    for relpath in BTS3_FILES.values():
        assert urls[relpath] == (f"https://raw.githubusercontent.com/yayaneath/biotac-sp-images/{BTS3_COMMIT}/"
                                 f"{relpath.removeprefix('bts3/')}")
    assert [registered_size(r) for r in registered_files("bts3/")] == [474438, 473721]


def test_the_reader_keeps_every_grasp_as_published(tmp_path):
    path = tmp_path / "biotac-palmdown-grasps.csv"
    path.write_bytes(_release(0))
    grasps = read_bts3_csv(path, "palm_down")
    assert grasps.X.shape == (9, 3, 24) and grasps.X.dtype == np.float64
    assert list(grasps.trials.columns) == ["grasp_id", "object", "slipped", "orientation", "source", "line"]
    assert grasps.trials["grasp_id"].iloc[0] == "palm_down_2" and set(grasps.trials["slipped"]) <= {0, 1}
    first = path.read_text().splitlines()[1].split(",")
    assert grasps.X[0].ravel().tolist() == [float(v) for v in first[2:]]  # ff 1..24, mf 1..24, th 1..24


@pytest.mark.parametrize(("lines", "where", "message"), [
    (["object,slipped,a", "x,0,1"], 1, "header is not object,slipped"),
    ([HEADER, _grasp("coke", 0, 5), _grasp("", 1, 5)], 3, "object name is empty"),
    ([HEADER, _grasp("coke", 2, 5)], 2, "slipped is"),
    ([HEADER, _grasp("coke", 0, 5).replace(",5,", ",five,", 1)], 2, "ff_biotac_1 holds 'five', not a number"),
    ([HEADER, "coke,0,1,2"], 2, "ff_biotac_3 holds"),
    ([HEADER], 1, "no grasps"),
])
def test_a_damaged_file_is_one_line_naming_it(tmp_path, lines, where, message):
    path = tmp_path / "biotac-palmside-grasps.csv"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(DataFileError, match=message) as info:
        read_bts3_csv(path, "palm_side")
    assert str(info.value).startswith(f"{path}:{where}: ") and len(str(info.value).splitlines()) == 1


def test_a_served_release_is_fetched_verified_and_read(tmp_path, monkeypatch):
    served, home = tmp_path / "served", tmp_path / "home"
    files = {relpath: _release(seed) for seed, relpath in enumerate(BTS3_FILES.values())}
    for relpath, content in files.items():
        (served / relpath).parent.mkdir(parents=True, exist_ok=True)
        (served / relpath).write_bytes(content)
    with serve_folder(served) as (base, _requested):
        pup = registry_of(tmp_path / "registry.txt", [f"{r} sha256:{hashlib.sha256(c).hexdigest()} {base}/{r}"
                                                      for r, c in files.items()])
        monkeypatch.setattr(_registry, "registry", lambda: pup)
        [report] = fetch_datasets(["bts3"], home, pup=pup, progress=False)
        assert sorted(report.downloaded) == sorted(files)
        grasps = load_bts3(home)
        assert len(grasps.trials) == 18 and grasps.X.shape == (18, 3, 24)
        assert grasps.trials["orientation"].tolist() == ["palm_down"] * 9 + ["palm_side"] * 9
        (home / BTS3_FILES["palm_side"]).write_bytes(files[BTS3_FILES["palm_side"]][:-10])
        _registry.clear_verification_cache()
        with pytest.raises(ChecksumError) as info:
            load_bts3(home)
        assert len(str(info.value).splitlines()) == 1 and "biotac-palmside-grasps.csv" in str(info.value)


# ----------------------------------------------------------------------------- the class table


def test_every_value_of_the_class_table_has_its_source():
    with open(TABLE, encoding="utf-8", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 41 * len(BTS3_ATTRIBUTES) and len(BTS3_PANELS) == 41
    for row in rows:
        r, c = BTS3_PANELS[row["object"]]
        assert row["class"] == row["object"] and row["value"] in ("0", "1"), row
        assert row["source"] in (f"{OBJECTS_PHOTO}, row {r}, column {c}", f"object name '{row['object']}'"), row
        assert row["evidence"].strip(), row
        if row["source"].startswith("object name"):  # a name justifies a value only through a word of it
            assert row["evidence"].split("'")[1] in row["object"], row
    table = read_bts3_attributes()
    assert table.classes.shape == (41, 12) and list(table.classes.columns) == list(BTS3_ATTRIBUTES)
    assert len(np.unique(table.classes.to_numpy(), axis=0)) == 22
    assert table.classes.sum().to_dict() == {
        "metal": 7, "paperboard_box": 6, "fabric": 5, "soft": 6, "rough": 10, "ball_shaped": 5, "cylindrical": 16,
        "box_shaped": 12, "figure": 5, "open_top": 6, "container": 27, "transparent": 2}
    assert table.classes.loc["coke", ["metal", "cylindrical", "container"]].tolist() == [1, 1, 1]
    assert table.classes.loc["minion", ["fabric", "soft", "figure", "container"]].tolist() == [1, 1, 1, 0]


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
    (lambda r: r.update(source="") if r["object"] == "coke" and r["attribute"] == "metal" else None,
     r"coke metal: source must be 'objects.jpg, row 4, column 5' or \"object name 'coke'\""),
    (lambda r: r.update(source="objects.jpg, row 1, column 1") if r["object"] == "milk" else None,
     "milk metal: source must be 'objects.jpg, row 7, column 2'"),
    (lambda r: r.update(evidence=" ") if r["object"] == "apple" and r["attribute"] == "soft" else None,
     "apple soft: source must be"),
    (lambda r: r.update(value="2") if r["object"] == "train" and r["attribute"] == "figure" else None,
     "train figure: value '2' is not 0 or 1"),
    (lambda r: r.update(attribute="heavy") if r["object"] == "cone" and r["attribute"] == "rough" else None,
     "attribute 'heavy' has no definition"),
    (lambda r: r.update(object="mug", **{"class": "mug"}) if r["object"] == "olaf" else None,
     "object 'mug' .* has no panel in objects.jpg"),
])
def test_a_value_without_its_justification_is_refused_in_one_line(tmp_path, change, message):
    path = _edited_table(tmp_path, change)
    with pytest.raises(DataFileError, match=message) as info:
        read_bts3_attributes(path)
    assert len(str(info.value).splitlines()) == 1 and re.match(rf"{re.escape(str(path))}:\d+: ", str(info.value))


def test_an_object_or_attribute_left_out_is_refused_in_one_line(tmp_path):
    path = _edited_table(tmp_path, lambda r: not (r["object"] == "cone" and r["attribute"] == "soft"))
    with pytest.raises(DataFileError, match=r"cone lacks attribute\(s\) \['soft'\]"):
        read_bts3_attributes(path)
    path = _edited_table(tmp_path, lambda r: r["object"] != "cone")
    with pytest.raises(DataFileError, match=r"object\(s\) \['cone'\] of objects.jpg have no line"):
        read_bts3_attributes(path)


# ----------------------------------------------------------------------------- the whole way, on a served release


@pytest.fixture
def served(tmp_path, monkeypatch):
    """The small release served on 127.0.0.1 and registered instead of tzsl's registry; yields
    (served folder, registered path -> content)."""
    folder = tmp_path / "served"
    files = write_release(folder)
    with registered_release(folder, files, tmp_path / "registry.txt", monkeypatch):
        yield folder, files


def test_it_is_a_builtin_catalog_dataset():
    assert "bts3" in dataset_names(convertible=True) and builtin_data_files("bts3") == sorted(BTS3_FILES.values())
    code, out, _ = run_cli("datasets", "--json")
    assert code == 0 and "bts3" in [d["name"] for d in json.loads(out)]


def test_fetch_convert_validate(tmp_path, served):
    _, files = served
    home, plain = tmp_path / "home", tmp_path / "plain"
    code, out, err = run_cli("data", "fetch", "bts3", "--data-dir", home, "--no-progress")
    assert code == 0 and "bts3: 0 present, 2 downloaded" in out, err
    code, out, err = run_cli("convert", "--dataset", "bts3", "--data-dir", home, "--out", plain)
    assert code == 0, err
    n = 2 * 2 * len(OBJECTS)
    assert f"41 classes x 12 attributes, {n} trials, 3 sensor(s), 24 feature columns per sensor" in out
    code, out, err = run_cli("validate", plain)
    assert code == 0 and out.rstrip().endswith("valid"), err + out
    assert "sensors:    3 (ff, mf, th)" in out and "24 feature columns per sensor" in out
    trials = (plain / "trials.csv").read_text().splitlines()
    assert trials[0].startswith("trial_id,class,object,trial_index,sensor,electrode_1,electrode_2,")
    first = files[BTS3_FILES["palm_down"]].decode().splitlines()[1].split(",")
    assert trials[1].split(",")[:5] == ["palm_down_2", "coke", "coke", "1", "ff"]
    assert [float(v) for v in trials[1].split(",")[5:]] == [float(v) for v in first[2:26]]  # ff as published


def test_a_study_fetches_it_on_first_use_and_runs(tmp_path, served, monkeypatch):
    monkeypatch.chdir(tmp_path)
    home = tmp_path / "first-use"
    home.mkdir()
    (tmp_path / "bts3.toml").write_text(
        f'study = "zero-shot"\ndescription = "bts3, small release"\n[dataset]\nbuiltin = "bts3"\n'
        f'data_dir = "{home}"\n[output]\nfolder = "results"\n' + FAST_TEMPLATE)
    code, out, err = run_cli("run", "bts3.toml", "--no-progress")
    assert code == 0, err + out
    assert "first use: fetching 2 data files of bts3" in out + err
    manifest = json.loads((tmp_path / "results" / "manifest.json").read_text())
    assert manifest["config"]["dataset"] == "bts3"
    size = manifest["config"]["dataset_size"]
    assert size["objects"] == len(OBJECTS) and size["sensors"] == 3 and size["features_per_sensor"] == 24
    assert size["trials"] == 4 * len(OBJECTS) and 0 < size["attributes"] <= 12
    assert (tmp_path / "results" / "method_comparison.csv").is_file()


def test_a_damaged_file_in_the_data_home_is_one_line_naming_it(tmp_path, served):
    _, files = served
    home = tmp_path / "home"
    assert run_cli("data", "fetch", "bts3", "--data-dir", home, "--no-progress")[0] == 0
    damaged = BTS3_FILES["palm_side"]
    (home / damaged).write_bytes(files[damaged][:-30])
    code, _, err = run_cli("convert", "--dataset", "bts3", "--data-dir", home, "--out", tmp_path / "plain")
    lines = [line for line in err.splitlines() if line.strip()]
    assert code != 0 and len(lines) == 1 and lines[0].startswith("tzsl: error: "), err
    assert str(home / damaged) in lines[0] and "tzsl data fetch bts3" in lines[0]
    assert not (tmp_path / "plain").exists()
