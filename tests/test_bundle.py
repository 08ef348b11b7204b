"""Model bundles: round trip, and refusal of corrupt, tampered, foreign-version and wrong-kind files."""

from __future__ import annotations

import json

import numpy as np
import pytest
from sklearn.linear_model import LogisticRegression

import tzsl
from tzsl.bundle import BUNDLE_KEY_ENV, load_bundle, read_bundle_header, save_bundle
from tzsl.exceptions import ConfigError, ModelBundleError


@pytest.fixture(autouse=True)
def _no_key(monkeypatch):
    monkeypatch.delenv(BUNDLE_KEY_ENV, raising=False)


@pytest.fixture
def fitted():
    rng = np.random.default_rng(0)
    X = rng.normal(size=(40, 3))
    y = (X[:, 0] > 0).astype(int)
    return LogisticRegression().fit(X, y), X


def _split(path):
    raw = path.read_bytes()
    magic_end = raw.index(b"\n") + 1
    header_end = raw.index(b"\n", magic_end) + 1
    return raw[:magic_end], json.loads(raw[magic_end:header_end]), raw[header_end:]


def test_round_trip_keeps_model_and_metadata(tmp_path, fitted):
    model, X = fitted
    meta = {"attribute_names": ("hard", "soft"), "prior": np.array([0.5, 0.25]), "n": np.int64(3)}
    path = save_bundle(tmp_path / "m.tzsl", model, kind="hand-dap", metadata=meta)
    loaded, got = load_bundle(path, expected_kind="hand-dap")
    np.testing.assert_array_equal(loaded.predict_proba(X), model.predict_proba(X))
    assert got["attribute_names"] == ["hard", "soft"]
    assert got["prior"] == [0.5, 0.25] and got["n"] == 3
    assert got["bundle"]["kind"] == "hand-dap"
    assert got["bundle"]["tzsl_version"] == tzsl.__version__
    assert got["bundle"]["signed"] is False
    header = read_bundle_header(path)
    assert header.kind == "hand-dap" and header.metadata["attribute_names"] == ["hard", "soft"]
    assert not list(tmp_path.glob(".*.tmp"))  # atomic write left no temporary file


def test_refuses_overwrite_without_force(tmp_path, fitted):
    path = save_bundle(tmp_path / "m.tzsl", fitted[0], kind="hand-dap")
    with pytest.raises(ConfigError, match="--force"):
        save_bundle(path, fitted[0], kind="hand-dap")
    save_bundle(path, fitted[0], kind="phac2-dap", force=True)
    assert read_bundle_header(path).kind == "phac2-dap"


@pytest.mark.parametrize("kind", ["", "Hand DAP", "hand_dap", None])
def test_bad_kind_rejected(tmp_path, fitted, kind):
    with pytest.raises(ConfigError, match="kind"):
        save_bundle(tmp_path / "m.tzsl", fitted[0], kind=kind)


def test_metadata_must_be_json(tmp_path, fitted):
    with pytest.raises(ConfigError, match="JSON"):
        save_bundle(tmp_path / "m.tzsl", fitted[0], kind="hand-dap", metadata={"model": object()})
    assert not (tmp_path / "m.tzsl").exists()


def test_flipped_payload_byte_is_rejected(tmp_path, fitted):
    path = save_bundle(tmp_path / "m.tzsl", fitted[0], kind="hand-dap")
    raw = bytearray(path.read_bytes())
    raw[-20] ^= 0x01
    path.write_bytes(bytes(raw))
    with pytest.raises(ModelBundleError, match="payload checksum mismatch"):
        load_bundle(path)


def test_truncated_file_is_rejected(tmp_path, fitted):
    path = save_bundle(tmp_path / "m.tzsl", fitted[0], kind="hand-dap")
    raw = path.read_bytes()
    path.write_bytes(raw[: len(raw) - 100])
    with pytest.raises(ModelBundleError, match="corrupt, truncated"):
        load_bundle(path)


def test_edited_metadata_is_rejected(tmp_path, fitted):
    path = save_bundle(tmp_path / "m.tzsl", fitted[0], kind="hand-dap", metadata={"fusion": "avg"})
    magic, header, payload = _split(path)
    header["metadata"]["fusion"] = "max"
    path.write_bytes(magic + json.dumps(header).encode() + b"\n" + payload)
    with pytest.raises(ModelBundleError, match="header checksum mismatch"):
        load_bundle(path)


def _forge(path, fitted_model):
    """Swap in another payload and recompute both checksums, as an attacker could."""
    import hashlib
    import io

    import joblib

    magic, header, _ = _split(path)
    buf = io.BytesIO()
    joblib.dump(fitted_model, buf)
    payload = buf.getvalue()
    header["payload_sha256"] = hashlib.sha256(payload).hexdigest()
    header["payload_bytes"] = len(payload)
    fields = {k: v for k, v in header.items() if k not in ("header_sha256", "hmac_sha256")}
    canonical = json.dumps(fields, sort_keys=True, separators=(",", ":")).encode()
    header["header_sha256"] = hashlib.sha256(canonical).hexdigest()
    path.write_bytes(magic + json.dumps(header).encode() + b"\n" + payload)


def test_forgery_passes_checksums_but_not_the_signature(tmp_path, fitted, monkeypatch):
    """Checksums catch corruption only (documented); with TZSL_BUNDLE_KEY a forgery is refused."""
    other = LogisticRegression(C=0.01).fit(fitted[1], (fitted[1][:, 1] > 0).astype(int))
    plain = save_bundle(tmp_path / "plain.tzsl", fitted[0], kind="hand-dap")
    _forge(plain, other)
    assert load_bundle(plain)[0].C == 0.01  # no key: undetectable, as the docstring says

    monkeypatch.setenv(BUNDLE_KEY_ENV, "secret")
    signed = save_bundle(tmp_path / "signed.tzsl", fitted[0], kind="hand-dap")
    assert read_bundle_header(signed).signed
    load_bundle(signed)
    _forge(signed, other)
    with pytest.raises(ModelBundleError, match="signature does not match"):
        load_bundle(signed)


def test_signed_bundle_needs_the_same_key_and_unsigned_is_refused_with_a_key(tmp_path, fitted, monkeypatch):
    monkeypatch.setenv(BUNDLE_KEY_ENV, "secret")
    path = save_bundle(tmp_path / "m.tzsl", fitted[0], kind="hand-dap")
    monkeypatch.setenv(BUNDLE_KEY_ENV, "another secret")
    with pytest.raises(ModelBundleError, match="signature"):
        load_bundle(path)
    monkeypatch.delenv(BUNDLE_KEY_ENV)
    unsigned = save_bundle(tmp_path / "u.tzsl", fitted[0], kind="hand-dap")
    monkeypatch.setenv(BUNDLE_KEY_ENV, "secret")
    with pytest.raises(ModelBundleError, match="not signed"):
        load_bundle(unsigned)


def test_other_minor_version_is_rejected(tmp_path, fitted, monkeypatch):
    major, minor, *_ = tzsl.__version__.split(".")
    monkeypatch.setattr(tzsl, "__version__", f"{major}.{int(minor) + 1}.0")
    path = save_bundle(tmp_path / "m.tzsl", fitted[0], kind="hand-dap")
    monkeypatch.undo()
    with pytest.raises(ModelBundleError, match=rf"written by tzsl {major}\.{int(minor) + 1}\.0"):
        load_bundle(path)


def test_patch_version_difference_is_accepted(tmp_path, fitted, monkeypatch):
    major, minor, *_ = tzsl.__version__.split(".")
    monkeypatch.setattr(tzsl, "__version__", f"{major}.{minor}.99")
    path = save_bundle(tmp_path / "m.tzsl", fitted[0], kind="hand-dap")
    monkeypatch.undo()
    load_bundle(path)


def test_wrong_kind_is_rejected(tmp_path, fitted):
    path = save_bundle(tmp_path / "m.tzsl", fitted[0], kind="phac2-dap")
    with pytest.raises(ModelBundleError, match="'phac2-dap' model, expected a 'hand-dap'"):
        load_bundle(path, expected_kind="hand-dap")


@pytest.mark.parametrize("content, message", [
    (b"", "not a tzsl model bundle"),
    (b"PK\x03\x04 a zip file", "not a tzsl model bundle"),
    (b"TZSL-MODEL-BUNDLE\n{not json}\n", "not valid JSON"),
    (b"TZSL-MODEL-BUNDLE\n{\"format\": \"tzsl-model-bundle\"", "truncated"),
    (b"TZSL-MODEL-BUNDLE\n{\"format\": \"other\"}\n", "does not name the format"),
])
def test_garbage_files_are_rejected(tmp_path, content, message):
    path = tmp_path / "x.tzsl"
    path.write_bytes(content)
    with pytest.raises(ModelBundleError, match=message):
        load_bundle(path)


def test_missing_file(tmp_path):
    with pytest.raises(ModelBundleError, match="not found"):
        load_bundle(tmp_path / "absent.tzsl")
