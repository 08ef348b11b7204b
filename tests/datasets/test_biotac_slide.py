"""``biotac-slide`` (dexrob/BioTac_slide_20_50): its registry entries, its class-attribute table (every
value with its source), its raw-CSV reader, and the whole way on a small release made here and served on
127.0.0.1 (never the network): ``tzsl data fetch``, ``tzsl convert``, ``tzsl validate``, a zero-shot study
that fetches it on first use, and one line naming the file when a file is damaged."""

from __future__ import annotations

import csv
import json
import re
import shutil
from pathlib import Path

import numpy as np
import pytest

from tests.datasets.biotac_slide_release import MATERIALS, release_registry, write_release
from tests.datasets.fetch_server import run_cli, serve_folder
from tests.study_settings import FAST_TEMPLATE
from tzsl.datasets import (
    BIOTAC_SLIDE_CHANNELS,
    _fetch,
    _registry,
    builtin_data_files,
    dataset_names,
    read_biotac_slide_attributes,
    read_biotac_slide_csv,
    registered_files,
)
from tzsl.datasets._biotac_slide import ATTRIBUTE_RULES, ATTRIBUTE_TABLE, BIOTAC_SLIDE_COMMIT, MATERIAL_DOCUMENT
from tzsl.datasets._registry import registered_size
from tzsl.exceptions import DataFileError

TABLE = Path(__file__).resolve().parents[2] / "tzsl" / "datasets" / ATTRIBUTE_TABLE


@pytest.fixture(autouse=True)
def _fresh_verdicts():
    _registry.clear_verification_cache()
    yield
    _registry.clear_verification_cache()


def _error_line(stderr: str) -> str:
    lines = [line for line in stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("tzsl: error: "), stderr
    return lines[0]


# ----------------------------------------------------------------------------- the registry and the class table


def test_the_registry_pins_the_1000_slides_at_one_commit():
    files = registered_files("biotac-slide/")
    assert len(files) == 1000 and builtin_data_files("biotac-slide") == files
    assert {f.split("/")[2] for f in files} == {f"mat{m}" for m in range(1, 21)}
    urls = _registry.registry().urls
    prefix = f"https://raw.githubusercontent.com/dexrob/BioTac_slide_20_50/{BIOTAC_SLIDE_COMMIT}/raw_data/"
    assert all(urls[f] == prefix + f.removeprefix("biotac-slide/raw_data/") for f in files)
    assert all(_registry.registered_hash(f).startswith("sha256:") for f in files)
    assert sum(registered_size(f) for f in files) == 115_306_989
    assert "biotac-slide" in dataset_names(convertible=True)
    code, out, _ = run_cli("datasets", "--json")
    assert code == 0 and "biotac-slide" in [d["name"] for d in json.loads(out)]


def test_every_attribute_of_the_class_table_has_its_source():
    with open(TABLE, encoding="utf-8", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 20 * len(ATTRIBUTE_RULES)
    for row in rows:
        column, ones, zeros = ATTRIBUTE_RULES[row["attribute"]]
        assert row["source"] == f"{MATERIAL_DOCUMENT} table, row {row['material']}, column {column}", row
        assert row["cell"].strip() and row["cell"].lower() in ones | zeros, row
        assert row["value"] == ("1" if row["cell"].lower() in ones else "0"), row
    table = read_biotac_slide_attributes()
    assert table.classes.shape == (20, 3) and list(table.classes.columns) == ["thick", "rough", "not_smooth"]
    assert table.materials["mat1"] == "carpet_net" and table.materials["mat20"] == "metal"
    assert len(np.unique(table.classes.to_numpy(), axis=0)) == 5
    assert table.classes.sum().to_dict() == {"thick": 6, "rough": 7, "not_smooth": 9}


@pytest.mark.parametrize(("change", "message"), [
    (lambda r: r.update(value="1") if r["material"] == "mat2" and r["attribute"] == "thick" else None,
     r"mat2 thick: value '1' does not follow from cell 'thin'"),
    (lambda r: r.update(source=r["source"].replace("Thickness", "Roughness")) if r["material"] == "mat5" else None,
     r"mat5 thick: source must be"),
    (lambda r: r.update(cell="very rough") if r["material"] == "mat7" and r["attribute"] == "rough" else None,
     r"cell 'very rough' of column Roughness justifies no value"),
    (lambda r: r.update(source="") if r["material"] == "mat9" and r["attribute"] == "rough" else None,
     r"mat9 rough: source must be"),
])
def test_a_value_without_its_justification_is_refused_in_one_line(tmp_path, change, message):
    with open(TABLE, encoding="utf-8", newline="") as fh:
        rows = list(csv.DictReader(fh))
    for row in rows:
        change(row)
    path = tmp_path / "table.csv"
    with open(path, "w", encoding="utf-8", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]), lineterminator="\n")
        writer.writeheader()
        writer.writerows(rows)
    with pytest.raises(DataFileError, match=message) as info:
        read_biotac_slide_attributes(path)
    assert len(str(info.value).splitlines()) == 1 and re.match(rf"{re.escape(str(path))}:\d+: ", str(info.value))


# ----------------------------------------------------------------------------- the raw CSV reader

HEADER = "timestamp," + ",".join(BIOTAC_SLIDE_CHANNELS)


def _line(t: float, tail: str = "") -> str:
    return f"{t}," + ",".join(["7"] * 44) + "," + tail


@pytest.mark.parametrize(("lines", "where", "message"), [
    (["time,pdc", _line(1.0)], 1, "header is not timestamp,tdc,tac,pdc"),
    ([HEADER, _line(1.0), _line(1.01, "5")], 3, r"a value \('5'\) follows the last channel"),
    ([HEADER, _line(1.0), _line(1.01, "5,6")], 3, "a line has 47 fields"),
    ([HEADER, _line(1.0), _line(1.01).replace(",7,", ",x,", 1)], 3, "tdc holds 'x', not a number"),
    ([HEADER, _line(1.0), "1.01,7,7"], 3, "channel 'pdc' is NaN or empty"),
    ([HEADER, _line(1.0), _line(1.02), _line(1.01)], 4, "timestamp does not increase"),
    ([HEADER], 1, "no samples"),
])
def test_a_damaged_csv_is_refused_in_one_line_naming_the_file_and_line(tmp_path, lines, where, message):
    path = tmp_path / "mat1_1_bio.csv"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(DataFileError, match=message) as info:
        read_biotac_slide_csv(path)
    assert str(info.value).startswith(f"{path}:{where}: ") and len(str(info.value).splitlines()) == 1


def test_the_reader_keeps_the_44_channels_as_published(tmp_path):
    path = tmp_path / "mat1_1_bio.csv"
    path.write_text("\n".join([HEADER, _line(1.0), _line(1.01)[:-1], _line(1.02)]) + "\n")  # with or without the comma
    values = read_biotac_slide_csv(path)
    assert values.shape == (3, 44) and values.dtype == np.float64 and (values == 7).all()


# ----------------------------------------------------------------------------- the whole way, on a served release


@pytest.fixture
def release(tmp_path, monkeypatch):
    """The small release served on 127.0.0.1 and registered instead of tzsl's registry; yields
    (served folder, base URL, registered path -> content)."""
    served = tmp_path / "served"
    files = write_release(served)
    with serve_folder(served) as (base, _requested):
        pup = release_registry(tmp_path / "registry.txt", files, base)
        monkeypatch.setattr(_registry, "registry", lambda: pup)
        monkeypatch.setattr(_fetch, "registry", lambda: pup)
        yield served, base, files


def test_fetch_convert_validate(tmp_path, release):
    _, _, files = release
    home = tmp_path / "home"
    code, out, err = run_cli("data", "fetch", "biotac-slide", "--data-dir", home, "--no-progress")
    assert code == 0, err
    assert f"biotac-slide: 0 present, {len(files)} downloaded" in out
    assert all((home / relpath).read_bytes() == content for relpath, content in files.items())
    code, out, err = run_cli("convert", "--dataset", "biotac-slide", "--data-dir", home, "--out", tmp_path / "plain")
    assert code == 0, err
    assert f"20 classes x 3 attributes, {len(files)} trials, 1 sensor(s), 44 channels" in out
    code, out, err = run_cli("validate", tmp_path / "plain")
    assert code == 0, err + out
    assert "features:   176 per sensor from signal files: 44 channels x 4 statistics" in out
    assert f"classes:              20 ({len(MATERIALS)} with trials, 5 distinct attribute rows)" in out
    assert out.rstrip().endswith("valid")
    trials = (tmp_path / "plain" / "trials.csv").read_text().splitlines()
    assert trials[0] == "trial_id,class,object,trial_index,sensor,signal_file"
    assert trials[1].startswith("mat1_1,carpet_net,carpet_net,1,biotac,signals/")


def test_a_study_fetches_it_on_first_use_and_runs(tmp_path, release, monkeypatch):
    _, _, files = release
    monkeypatch.chdir(tmp_path)
    home = tmp_path / "first-use"
    home.mkdir()
    (tmp_path / "slide.toml").write_text(
        f'study = "zero-shot"\ndescription = "biotac-slide, small release"\n'
        f'[dataset]\nbuiltin = "biotac-slide"\ndata_dir = "{home}"\n'
        f'[output]\nfolder = "results"\n' + FAST_TEMPLATE)
    code, out, err = run_cli("run", "slide.toml", "--no-progress")
    assert code == 0, err + out
    assert f"first use: fetching {len(files)} data files of biotac-slide" in out + err
    assert all((home / relpath).is_file() for relpath in files)
    manifest = json.loads((tmp_path / "results" / "manifest.json").read_text())
    assert manifest["config"]["dataset"] == "biotac-slide"
    assert manifest["config"]["dataset_size"] == {"attributes": 3, "features_per_sensor": 176,
                                                  "objects": len(MATERIALS), "sensors": 1, "trials": len(files)}
    assert (tmp_path / "results" / "method_comparison.csv").is_file()
    assert any(p.endswith("classes.csv") for p in manifest["data_files"])


def test_a_damaged_download_or_file_is_one_line_naming_it(tmp_path, release):
    served, base, files = release
    home = tmp_path / "home"
    first = next(iter(files))
    (served / first).write_bytes(files[first].replace(b"\n", b"\n0", 1))  # the server's copy changed
    code, _, err = run_cli("data", "fetch", "biotac-slide", "--data-dir", home, "--no-progress", "--workers", "1")
    line = _error_line(err)
    assert Path(first).name in line and "sha256" in line.lower() and base in line
    assert not (home / first).exists()
    (served / first).write_bytes(files[first])
    assert run_cli("data", "fetch", "biotac-slide", "--data-dir", home, "--no-progress")[0] == 0
    second = sorted(files)[1]
    (home / second).write_bytes(files[second][:-40])  # damaged in the data home after the fetch
    code, _, err = run_cli("convert", "--dataset", "biotac-slide", "--data-dir", home, "--out", tmp_path / "plain")
    line = _error_line(err)
    assert code != 0 and str(home / second) in line and "tzsl data fetch biotac-slide" in line
    assert not (tmp_path / "plain").exists()


def test_a_registered_but_malformed_csv_names_its_file_and_line(tmp_path, release, monkeypatch):
    """A release file that verifies but cannot be read (as if the release itself were damaged)."""
    _, base, files = release
    broken = dict(files)
    name = sorted(files)[2]
    lines = files[name].decode().splitlines()
    lines[5] = lines[5].rstrip(",") + ",oops"
    broken[name] = ("\n".join(lines) + "\n").encode()
    home = tmp_path / "home"
    for relpath, content in broken.items():
        (home / relpath).parent.mkdir(parents=True, exist_ok=True)
        (home / relpath).write_bytes(content)
    pup = release_registry(tmp_path / "broken.txt", broken, base)
    monkeypatch.setattr(_registry, "registry", lambda: pup)
    code, _, err = run_cli("convert", "--dataset", "biotac-slide", "--data-dir", home, "--out", tmp_path / "plain")
    line = _error_line(err)
    assert code != 0 and f"{home / name}:6: a value ('oops') follows the last channel" in line
    shutil.rmtree(home)


def test_a_malformed_class_table_is_one_line(tmp_path):
    """The class table's reader (shared by every catalog dataset) refuses a CSV it cannot parse in one line."""
    from tzsl.datasets import read_biotac_slide_attributes
    from tzsl.exceptions import DataFileError

    bad = tmp_path / "table.csv"
    bad.write_bytes(b'material,class\n"unclosed,quote\n')
    with pytest.raises(DataFileError, match=r"table\.csv: not a readable CSV table") as info:
        read_biotac_slide_attributes(bad)
    assert "\n" not in str(info.value)
