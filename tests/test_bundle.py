"""Model bundles: round trip, and refusal of corrupt, tampered, foreign-version and wrong-kind files."""

from __future__ import annotations

import json

import numpy as np
import pytest
from sklearn.linear_model import LogisticRegression

import tzsl
from tzsl.exceptions import ConfigError, ModelBundleError
from tzsl.inference.bundle import BUNDLE_KEY_ENV, load_bundle, read_bundle_header, save_bundle


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

    import skops.io as sio

    magic, header, _ = _split(path)
    payload = sio.dumps(fitted_model)
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


# ---------------------------------------------------------------------- a bundle cannot run code
def _craft(path, payload: bytes, **fields):
    """Write a bundle around ``payload`` with valid checksums (what anyone can do)."""
    import hashlib

    header = {"format": "tzsl-model-bundle", "format_version": 2, "tzsl_version": tzsl.__version__,
              "kind": "hand-dap", "created": "", "metadata": {}, "payload_format": "skops",
              "payload_bytes": len(payload), "payload_sha256": hashlib.sha256(payload).hexdigest(), **fields}
    canonical = json.dumps(header, sort_keys=True, separators=(",", ":")).encode()
    header["header_sha256"] = hashlib.sha256(canonical).hexdigest()
    path.write_bytes(b"TZSL-MODEL-BUNDLE\n" + json.dumps(header).encode() + b"\n" + payload)
    return path


def test_skops_payload_naming_os_system_is_refused(tmp_path):
    import os

    import skops.io as sio

    path = _craft(tmp_path / "evil.tzsl", sio.dumps({"f": os.system, "g": eval}))
    with pytest.raises(ModelBundleError, match=r"evil\.tzsl: the model names type\(s\) tzsl does not trust: "
                       r"builtins\.eval, posix\.system") as info:
        load_bundle(path)
    assert "\n" not in str(info.value)


def test_untrusted_class_is_refused_by_name(tmp_path):
    from fractions import Fraction

    import skops.io as sio

    path = _craft(tmp_path / "odd.tzsl", sio.dumps({"x": Fraction(1, 3)}))
    with pytest.raises(ModelBundleError, match="does not trust: fractions.Fraction"):
        load_bundle(path)


def test_trusted_types_cover_every_tzsl_model_class_and_nothing_else():
    import inspect

    import tzsl.models
    from tzsl.inference.skops_bundles import is_trusted_type

    classes = [obj for name in tzsl.models.__all__ if inspect.isclass(obj := getattr(tzsl.models, name))]
    assert classes
    for cls in classes:
        assert is_trusted_type(f"{cls.__module__}.{cls.__qualname__}"), cls
    assert is_trusted_type("sklearn.linear_model._logistic.LogisticRegression")
    assert is_trusted_type("numpy.dtype")
    for name in ("posix.system", "builtins.eval", "os.system", "tzsl.models.np", "tzsl.models._dap.np",
                 "sklearn.utils._joblib.joblib", "tzsl.models", "subprocess.Popen", "tzsl.models.nonexistent",
                 "sklearn.base.clone"):
        assert not is_trusted_type(name), name


def test_payload_that_is_not_skops_is_refused(tmp_path):
    path = _craft(tmp_path / "junk.tzsl", b"PK\x03\x04 not really a zip")
    with pytest.raises(ModelBundleError, match=r"junk\.tzsl: the model is not a readable skops file"):
        load_bundle(path)


@pytest.mark.parametrize(("fields", "message"), [
    ({"metadata": [1, 2]}, "field 'metadata' is not a JSON object"),
    ({"metadata": "text"}, "field 'metadata' is not a JSON object"),
    ({"kind": 3}, "field 'kind' is not a JSON string"),
    ({"kind": "../x"}, "kind '../x' is not lower-case"),
    ({"format_version": "2"}, "field 'format_version' is not a JSON number"),
    ({"payload_format": "pickle"}, "payload format 'pickle' is not one of"),
])
def test_header_fields_of_the_wrong_type_are_refused(tmp_path, fields, message):
    import skops.io as sio

    path = _craft(tmp_path / "m.tzsl", sio.dumps({"a": 1}), **fields)
    with pytest.raises(ModelBundleError, match=message) as info:
        load_bundle(path)
    assert "\n" not in str(info.value)
    with pytest.raises(ModelBundleError, match=message):
        read_bundle_header(path)


def test_header_that_is_json_but_not_an_object(tmp_path):
    path = tmp_path / "x.tzsl"
    path.write_bytes(b"TZSL-MODEL-BUNDLE\n[1, 2, 3]\n")
    with pytest.raises(ModelBundleError, match="header is not a JSON object"):
        load_bundle(path)


def test_old_pickle_bundle_is_refused_unless_trusted(tmp_path, fitted):
    import io

    import joblib

    buf = io.BytesIO()
    joblib.dump(fitted[0], buf)
    path = _craft(tmp_path / "old.tzsl", buf.getvalue(), format_version=1)
    del_format = json.loads(path.read_bytes().split(b"\n")[1])
    assert del_format["format_version"] == 1
    with pytest.raises(ModelBundleError, match=r"old\.tzsl: old bundle format \(version 1\) holding a pickle.*"
                       r"re-run the train command with --out.*--trust-pickle"):
        load_bundle(path)
    model, meta = load_bundle(path, trust_pickle=True)
    assert model.C == fitted[0].C and meta["bundle"]["payload_format"] == "pickle"


def test_arrays_round_trip_as_npz_and_pandas_inside_models(tmp_path):
    import pandas as pd
    from sklearn.dummy import DummyClassifier

    arrays = {"state_dict": {"conv.weight": np.arange(6.0).reshape(2, 3)},
              "classes": np.array(["a", "b"], dtype=object)}
    path = save_bundle(tmp_path / "a.tzsl", arrays, kind="deep")
    got, meta = load_bundle(path)
    assert meta["bundle"]["payload_format"] == "npz"
    assert got["state_dict"]["conv.weight"].tolist() == [[0, 1, 2], [3, 4, 5]]
    assert got["classes"].tolist() == ["a", "b"]

    model = DummyClassifier().fit([[0], [1]], [0, 1])
    model.table_ = pd.DataFrame({"hard": [1, 0], "name": ["x", "y"]}, index=pd.Index(["cube", "ball"], name="object"))
    model.series_ = pd.Series([0.5, 0.25], index=["hard", "soft"], name="prior")
    path = save_bundle(tmp_path / "p.tzsl", model, kind="hand-dap")
    loaded, meta = load_bundle(path)
    assert meta["bundle"]["payload_format"] == "skops"
    pd.testing.assert_frame_equal(loaded.table_, model.table_)
    pd.testing.assert_series_equal(loaded.series_, model.series_)


def test_tzsl_bundle_keeps_users_imports_working():
    """``tzsl.bundle`` (documented before the bundles moved to tzsl.inference) re-exports the same functions."""
    import tzsl.bundle as old
    from tzsl.inference import bundle, skops_bundles

    assert old.load_bundle is bundle.load_bundle and old.save_bundle is bundle.save_bundle
    assert old.read_bundle_header is bundle.read_bundle_header and old.is_trusted_type is skops_bundles.is_trusted_type


# --------------------------------------------------------------------------- classes that moved (issue 43)


def _with_schema(payload: bytes, edit) -> bytes:
    """``payload`` (a skops zip) with ``edit(schema)`` applied to its schema.json, other members unchanged."""
    import io
    import zipfile

    with zipfile.ZipFile(io.BytesIO(payload)) as archive:
        schema = edit(json.loads(archive.read("schema.json")))
        out = io.BytesIO()
        with zipfile.ZipFile(out, "w") as copy_to:
            for info in archive.infolist():
                copy_to.writestr(info, json.dumps(schema).encode() if info.filename == "schema.json"
                                 else archive.read(info))
    return out.getvalue()


def _modules_renamed(node, names: dict):
    if isinstance(node, dict):
        node = {k: _modules_renamed(v, names) for k, v in node.items()}
        if node.get("__module__") in names:
            node["__module__"] = names[node["__module__"]]
    elif isinstance(node, list):
        node = [_modules_renamed(v, names) for v in node]
    return node


@pytest.fixture
def zero_shot_model():
    from tzsl.models import SAE, NearestAttributeRule, ZeroShotClassifier

    rng = np.random.default_rng(1)
    rows = np.array([[1, 0, 1], [0, 1, 1], [1, 1, 0], [0, 0, 1], [1, 0, 0]], float)
    y = np.repeat(np.arange(5), 12)
    X = rows[y] @ rng.normal(size=(3, 6)) + 0.3 * rng.normal(size=(60, 6))
    model = ZeroShotClassifier(attribute_model=SAE(), decision_rule=NearestAttributeRule(metric="cosine"))
    return model.fit(X, rows[y]), X, rows


def test_a_model_file_saved_before_the_rooms_loads(tmp_path, zero_shot_model):
    """A payload naming the classes by their modules before issue 43 (``tzsl.models._sae``) loads and ranks
    as the model it was saved from: :data:`MOVED_MODULES` is applied when reading."""
    from tzsl.inference.skops_bundles import MOVED_MODULES, renamed_moved_modules, skops_payload

    model, X, rows = zero_shot_model
    payload = skops_payload(model)
    old = _with_schema(payload, lambda s: _modules_renamed(s, {new: old for old, new in MOVED_MODULES.items()}))
    assert b"tzsl.models._sae" not in payload  # the fixture is what a file saved before the move holds
    import io
    import zipfile
    schema = zipfile.ZipFile(io.BytesIO(old)).read("schema.json").decode()
    assert '"tzsl.models._sae"' in schema and '"tzsl.models._decision"' in schema
    assert renamed_moved_modules(payload) is payload  # nothing moved: the same bytes
    loaded, _ = load_bundle(_craft(tmp_path / "old.tzsl", old))
    assert type(loaded.attribute_model_).__module__ == "tzsl.models.embedding._sae"
    np.testing.assert_array_equal(loaded.decision_function(X, rows), model.decision_function(X, rows))


def test_a_moved_module_name_smuggles_nothing_in(tmp_path, zero_shot_model):
    """The renamed type is checked like any other: a name imported into a moved module is still refused."""
    from tzsl.inference.skops_bundles import skops_payload

    def smuggle(schema):
        schema["content"]["content"]["decision_rule"].update({"__module__": "tzsl.models._hand_dap",
                                                              "__class__": "ConfigError"})
        return schema

    payload = _with_schema(skops_payload(zero_shot_model[0]), smuggle)
    with pytest.raises(ModelBundleError, match=r"does not trust: tzsl\.models\.hand\._hand_dap\.ConfigError"):
        load_bundle(_craft(tmp_path / "odd.tzsl", payload))


def test_the_moved_modules_map_names_old_paths_gone_and_new_paths_present():
    import importlib.util

    from tzsl.inference.skops_bundles import MOVED_MODULES

    assert MOVED_MODULES
    gone = [old for old in MOVED_MODULES if importlib.util.find_spec(old) is not None]
    missing = [new for new in MOVED_MODULES.values() if importlib.util.find_spec(new) is None]
    assert not gone and not missing, (gone, missing)
