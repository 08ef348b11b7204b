"""The sha256 registry: coverage of the PROVENANCE tables and verification on first use."""

from __future__ import annotations

import shutil

import pooch
import pytest

from tests.datasets.biotac_slide_release import catalog_files
from tzsl.datasets import _registry, fetch, load_phac2_hold_mat, load_phac2_penn, registered_files
from tzsl.exceptions import ChecksumError, DataMissingError

LABELS = "phac2/derived/phac2_labels_60x24.csv"


@pytest.fixture(autouse=True)
def _fresh_verdicts():
    _registry.clear_verification_cache()
    yield
    _registry.clear_verification_cache()


def test_registry_covers_the_provenance_tables():
    assert len(registered_files("phac2/penn_bolt_ml_data/static_adjective_phase_set/")) == 96
    assert len(registered_files("phac2/imperial_cvpr2021_hold/")) == 60
    assert len(registered_files("phac2/penn_bolt_pilot_2012_training_tests/")) == 5
    assert len(registered_files("phac2/derived/")) == 4
    assert len(registered_files("gelsight_press/")) == 45
    assert len(registered_files("fabric/depth224/")) == 1300
    assert len(registered_files("fabric/")) == 1308
    # the label-leaking HMM features are deliberately not registered
    assert not [r for r in registered_files() if "hmm" in r]
    assert _registry.registered_hash(LABELS) == (
        "sha256:9354631684f9cd3827426570a4238c0df9eeb620149789e96d3a5ce93e4e920e"
    )
    assert _registry.registered_hash(registered_files("fabric/depth224/")[0]) is None


@pytest.mark.realdata
def test_every_registered_file_verifies_on_the_real_data(data_dir):
    """Every file of the shared data's datasets (the catalog's are fetched on first use, not shared)."""
    catalog = catalog_files()  # once: it reads the whole registry
    paths = [fetch(rel, data_dir) for rel in registered_files() if rel not in catalog]
    assert all(p.is_file() for p in paths)


def test_missing_file_names_source_and_destination(tmp_path):
    with pytest.raises(DataMissingError) as err:
        fetch(LABELS, tmp_path)
    msg = str(err.value)
    assert str(tmp_path / LABELS) in msg
    assert "data/README.md" in msg
    hold = "phac2/imperial_cvpr2021_hold/acrylic_211_01_HOLD.mat"
    with pytest.raises(DataMissingError) as err:
        fetch(hold, tmp_path)
    msg = str(err.value)
    assert "github.com/arahosu/cvpr_imperial2" in msg and str(tmp_path / hold) in msg
    assert "TZSL_DATA_DIR" in msg


def test_loaders_fail_fast_on_an_empty_home(tmp_path):
    with pytest.raises(DataMissingError, match="Penn-haptics-bolt"):
        load_phac2_penn(tmp_path)
    with pytest.raises(DataMissingError, match="HOLD.mat"):
        load_phac2_hold_mat(tmp_path)


def test_unregistered_path_is_a_key_error(tmp_path):
    with pytest.raises(KeyError):
        fetch("phac2/not_a_file.csv", tmp_path)


@pytest.mark.realdata
def test_corrupted_copy_gives_checksum_error(data_dir, tmp_path):
    dest = tmp_path / LABELS
    dest.parent.mkdir(parents=True)
    shutil.copyfile(data_dir / LABELS, dest)
    assert fetch(LABELS, tmp_path) == dest  # an intact copy verifies
    data = bytearray(dest.read_bytes())
    data[100] ^= 0x01
    dest.write_bytes(bytes(data))
    with pytest.raises(ChecksumError) as err:
        fetch(LABELS, tmp_path)
    msg = str(err.value)
    assert "9354631684f9cd3827426570a4238c0df9eeb620149789e96d3a5ce93e4e920e" in msg
    assert pooch.file_hash(str(dest)) in msg
    assert str(dest) in msg


@pytest.mark.realdata
def test_verdict_is_cached_per_file_state(data_dir, tmp_path, monkeypatch):
    dest = tmp_path / LABELS
    dest.parent.mkdir(parents=True)
    shutil.copyfile(data_dir / LABELS, dest)
    calls = []
    real = pooch.file_hash
    monkeypatch.setattr(pooch, "file_hash", lambda *a, **k: calls.append(a) or real(*a, **k))
    fetch(LABELS, tmp_path)
    fetch(LABELS, tmp_path)
    assert len(calls) == 1
    dest.write_bytes(dest.read_bytes() + b"\n")  # changed file -> checked again
    with pytest.raises(ChecksumError):
        fetch(LABELS, tmp_path)
    assert len(calls) == 2


@pytest.mark.realdata
def test_explicit_download_verifies_the_hash(data_dir, tmp_path):
    """download=True goes through pooch; here with a local 'downloader' (no network)."""
    rel = "phac2/imperial_cvpr2021_hold/acrylic_211_01_HOLD.mat"
    seen = []

    def copy_from_shared(url, output_file, pup):
        seen.append(url)
        shutil.copyfile(data_dir / rel, output_file)

    path = fetch(rel, tmp_path / "home", download=True, downloader=copy_from_shared)
    assert path == tmp_path / "home" / rel and path.is_file()
    assert seen == [
        "https://raw.githubusercontent.com/arahosu/cvpr_imperial2/"
        "04932b5235f0b8026bed13547941a61cb7adcf60/data/acrylic_211_01_HOLD.mat"
    ]

    def corrupt(url, output_file, pup):
        with open(output_file, "wb") as fh:
            fh.write(b"not the file")

    other = "phac2/imperial_cvpr2021_hold/acrylic_211_02_HOLD.mat"
    with pytest.raises(ChecksumError):
        fetch(other, tmp_path / "home", download=True, downloader=corrupt)
    assert not (tmp_path / "home" / other).exists()
