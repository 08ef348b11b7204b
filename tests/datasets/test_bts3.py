"""``bts3`` (yayaneath/biotac-sp-images, the BioTacSP Stability Set): its two registered files, its reader,
and a fetch of a small release made here (the release's layout, CRLF lines) from 127.0.0.1, never the network."""

from __future__ import annotations

import hashlib

import numpy as np
import pytest

from tests.datasets.fetch_server import registry_of, serve_folder
from tzsl.datasets import _registry, fetch_datasets, load_bts3, read_bts3_csv, registered_files
from tzsl.datasets._bts3 import BTS3_COMMIT, BTS3_FILES, BTS3_FINGERS
from tzsl.datasets._registry import registered_size
from tzsl.exceptions import ChecksumError, DataFileError

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
