"""Saved model bundles: one file holding a fitted model, what it needs at predict time, and checks.

A bundle (by convention ``*.tzsl``) is written by :func:`save_bundle` and read by
:func:`load_bundle`. Layout, in this order::

    TZSL-MODEL-BUNDLE\\n           # magic line
    {"format": ..., ...}\\n         # header: one line of JSON (UTF-8)
    <payload bytes>               # the model: a skops file, or an .npz of arrays

The header records the bundle format and its version, the tzsl version that wrote it, the model
``kind`` (``"zero-shot"``, ``"per-ep"``, ``"deep"``, ...), the creation time, the user's
``metadata`` (a JSON object: attribute names, feature layout, fusion, ...), ``payload_format``,
``payload_sha256`` (sha256 of the payload bytes), ``header_sha256`` (sha256 of the canonical JSON of
every other header field, so metadata edits are caught too) and, when the key is set,
``hmac_sha256`` (see below).

Payload formats (format version 2) - neither can run code when it is read:

``"npz"``
    A nested dict of numpy arrays as an ``.npz`` archive read with ``allow_pickle=False`` (keys
    joined with ``/``): the arrays of linear models (:mod:`tzsl.inference.linear_bundles`), of DAP
    models (:mod:`tzsl.inference.detector_bundles`) and of the deep model
    (:mod:`tzsl.inference.deep_bundles`).
``"skops"``
    Other estimators, with :mod:`skops.io`; types outside tzsl's trusted list are refused by name
    before anything is built (:mod:`tzsl.inference.skops_bundles`).

:func:`load_bundle` checks, before deserialising anything: the magic line, the header (a JSON
object with well-typed fields), both checksums, the signature (when ``TZSL_BUNDLE_KEY`` is set),
the format version, the tzsl ``major.minor`` version (models are not portable across minor
versions: estimator internals and the feature layout may change) and the expected kind. Any
failure raises :class:`~tzsl.exceptions.ModelBundleError`: one line with the file and the reason.

Trust
-----
A bundle cannot run code when loaded, so a model file from a colleague is as safe to load as a
data file. The sha256 checksums detect corruption (a truncated copy, a flipped byte, a hand-edited
header); they do not stop someone who wants to pass off a different model, since they can be
recomputed. To be sure a bundle comes from your own machines, set the environment variable
``TZSL_BUNDLE_KEY`` to a secret shared by the machines that write and read bundles:
:func:`save_bundle` then signs the header (which holds the payload's sha256) with HMAC-SHA256, and
:func:`load_bundle` refuses any bundle whose signature is missing or wrong. Without the key,
signatures are neither made nor checked.

Bundles of format version 1 (tzsl before this format) hold a pickle, which *can* run code: they
are refused with a message saying how to re-save them, unless ``trust_pickle=True``
(``tzsl predict --trust-pickle``) is given for a file whose author you trust.
"""

from __future__ import annotations

import hashlib
import hmac
import io
import json
import os
import re
from collections.abc import Mapping
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import numpy as np

from tzsl._io import atomic_write, read_npz
from tzsl.exceptions import ConfigError, DataFileError, ModelBundleError
from tzsl.inference.skops_bundles import read_skops_payload, skops_payload

__all__ = [
    "BUNDLE_FORMAT",
    "BUNDLE_FORMAT_VERSION",
    "BUNDLE_KEY_ENV",
    "BundleHeader",
    "load_bundle",
    "read_bundle_header",
    "save_bundle",
]

#: Name written in every header.
BUNDLE_FORMAT = "tzsl-model-bundle"
#: Version of the file layout described in the module docstring (1: pickle payload, refused).
BUNDLE_FORMAT_VERSION = 2
#: Environment variable holding the HMAC key (any non-empty text).
BUNDLE_KEY_ENV = "TZSL_BUNDLE_KEY"

_MAGIC = b"TZSL-MODEL-BUNDLE\n"
_KIND = re.compile(r"^[a-z0-9][a-z0-9-]*$")
_MAX_HEADER = 16 * 1024 * 1024  # a header line longer than this is not ours
_PAYLOAD_FORMATS = ("skops", "npz")
_PICKLE_VERSION = 1


@dataclass(frozen=True)
class BundleHeader:
    """What a bundle says about itself (readable without deserialising the model).

    Attributes
    ----------
    path : Path
    kind : str
    tzsl_version : str
        Version of tzsl that wrote the bundle.
    format_version : int
    created : str
        ISO 8601 UTC time of writing.
    metadata : dict
    payload_sha256 : str
    signed : bool
        Whether the bundle carries an HMAC signature.
    payload_format : str
        ``"skops"``, ``"npz"`` or (format version 1) ``"pickle"``.
    """

    path: Path
    kind: str
    tzsl_version: str
    format_version: int
    created: str
    metadata: dict
    payload_sha256: str
    signed: bool
    payload_format: str = "skops"


def _tzsl_version() -> str:
    import tzsl  # noqa: PLC0415 - read at call time (tests patch it)

    return str(tzsl.__version__)


def _major_minor(version: str) -> tuple[str, ...]:
    return tuple(str(version).split(".")[:2])


def _key() -> bytes | None:
    key = os.environ.get(BUNDLE_KEY_ENV, "")
    return key.encode("utf-8") if key else None


def _jsonable(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, Path):
        return str(value)
    if isinstance(value, (set, frozenset)):
        return sorted(value)
    raise TypeError(f"{type(value).__name__} is not JSON-serialisable")


def _canonical(fields: dict) -> bytes:
    return json.dumps(fields, sort_keys=True, separators=(",", ":"), ensure_ascii=True).encode("ascii")


def _signed_fields(header: dict) -> dict:
    return {k: v for k, v in header.items() if k not in ("header_sha256", "hmac_sha256")}


# ----------------------------------------------------------------------------- writing
def save_bundle(
    path: str | Path,
    model: Any,
    *,
    kind: str,
    metadata: dict | None = None,
    force: bool = False,
) -> Path:
    """Write ``model`` and ``metadata`` to a bundle file, atomically.

    Parameters
    ----------
    path : str or Path
        Destination (``.tzsl`` by convention); its folder is created if needed.
    model : object
        A fitted estimator (stored with skops; pandas tables inside it are supported), or a
        dict (possibly nested) of numpy arrays (stored as ``.npz``, e.g. network weights).
    kind : str
        Model kind, lower-case words joined by ``-`` (``"zero-shot"``, ``"per-ep"``, ``"deep"``).
        :func:`load_bundle` can insist on it.
    metadata : dict, optional
        JSON-serialisable description needed to use the model (numpy arrays and scalars, paths,
        tuples and sets are converted to lists / numbers / text).
    force : bool, default False
        Replace an existing file.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    ConfigError
        Bad ``kind``, metadata that is not JSON-serialisable, or ``path`` exists without ``force``.
    ModelBundleError
        The model cannot be serialised.
    """
    path = Path(path)
    if not isinstance(kind, str) or not _KIND.match(kind):
        raise ConfigError(f"bundle kind must be lower-case words joined by '-', got {kind!r}")
    if path.exists() and not force:
        raise ConfigError(f"{path} already exists; use --force to overwrite it")
    metadata = {} if metadata is None else metadata
    if not isinstance(metadata, dict):
        raise ConfigError(f"bundle metadata must be a dict, got {type(metadata).__name__}")
    if "bundle" in metadata:
        raise ConfigError("bundle metadata must not use the key 'bundle' (load_bundle adds it)")
    try:
        metadata = json.loads(json.dumps(metadata, default=_jsonable))
    except (TypeError, ValueError) as exc:
        raise ConfigError(f"bundle metadata is not JSON-serialisable: {exc}") from None
    try:
        payload_format, payload = _serialise(model)
    except ConfigError:
        raise
    except Exception as exc:  # noqa: BLE001 - any serialisation failure is reported the same way
        raise ModelBundleError(f"{path}: cannot serialise the model ({type(exc).__name__}: {exc})") from None
    header: dict[str, Any] = {
        "format": BUNDLE_FORMAT,
        "format_version": BUNDLE_FORMAT_VERSION,
        "tzsl_version": _tzsl_version(),
        "kind": kind,
        "created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "metadata": metadata,
        "payload_format": payload_format,
        "payload_bytes": len(payload),
        "payload_sha256": hashlib.sha256(payload).hexdigest(),
    }
    return _write(path, header, payload)


def _write(path: Path, header: dict, payload: bytes) -> Path:
    """Add the checksums (and signature) to ``header`` and write the bundle file."""
    header = dict(header)
    signed = _canonical(header)
    header["header_sha256"] = hashlib.sha256(signed).hexdigest()
    key = _key()
    if key is not None:
        header["hmac_sha256"] = hmac.new(key, signed, hashlib.sha256).hexdigest()
    line = json.dumps(header, sort_keys=True, ensure_ascii=True).encode("ascii") + b"\n"

    def _save(tmp: Path) -> None:
        with open(tmp, "wb") as fh:
            fh.write(_MAGIC)
            fh.write(line)
            fh.write(payload)

    return atomic_write(path, _save)


# ----------------------------------------------------------------------------- payloads
def _is_array_tree(obj: Any) -> bool:
    if isinstance(obj, np.ndarray):
        return True
    return isinstance(obj, Mapping) and len(obj) > 0 and all(
        isinstance(k, str) and "/" not in k and _is_array_tree(v) for k, v in obj.items())


def _flatten(tree: Mapping, prefix: str = "") -> dict[str, np.ndarray]:
    flat: dict[str, np.ndarray] = {}
    for key, value in tree.items():
        if isinstance(value, Mapping):
            flat.update(_flatten(value, f"{prefix}{key}/"))
            continue
        array = np.asarray(value)
        if array.dtype.hasobject:
            if not all(isinstance(v, str) for v in array.ravel()):
                raise ConfigError(f"array {prefix}{key!r} holds Python objects; a bundle stores numbers and text only")
            array = array.astype(str)
        flat[prefix + key] = array
    return flat


def _unflatten(flat: Mapping[str, np.ndarray]) -> dict:
    tree: dict = {}
    for key, value in flat.items():
        node = tree
        *parents, leaf = key.split("/")
        for part in parents:
            node = node.setdefault(part, {})
        node[leaf] = value
    return tree


def _serialise(model: Any) -> tuple[str, bytes]:
    """``(payload_format, bytes)`` of a model: an array tree as ``.npz``, anything else with skops."""
    if _is_array_tree(model) and not isinstance(model, np.ndarray):
        buffer = io.BytesIO()
        # numpy's stub: a top-level array named allow_pickle would not be stored; tzsl's payloads name theirs
        # detectors/..., linear/..., rule/...
        np.savez_compressed(buffer, **_flatten(model))  # type: ignore[arg-type]
        return "npz", buffer.getvalue()
    return "skops", skops_payload(model)


def _deserialise(path: Path, payload_format: str, payload: bytes) -> Any:
    if payload_format == "skops":
        return read_skops_payload(path, payload)
    try:
        return _unflatten(read_npz(io.BytesIO(payload), name=path))
    except DataFileError as exc:
        raise ModelBundleError(f"{path}: model arrays unreadable: {exc.problem}") from None


# ----------------------------------------------------------------------------- reading
_HEADER_TYPES: dict[str, type | tuple[type, ...]] = {
    "format_version": int, "tzsl_version": str, "kind": str, "metadata": dict, "payload_sha256": str,
    "header_sha256": str,
}


def _read(path: Path) -> tuple[dict, bytes]:
    """Header and payload bytes of ``path``, with every check that needs no deserialising."""

    def fail(problem: str) -> ModelBundleError:
        return ModelBundleError(f"{path}: {problem}")

    try:
        with open(path, "rb") as fh:
            magic = fh.read(len(_MAGIC))
            if magic != _MAGIC:
                raise fail("not a tzsl model bundle (missing the TZSL-MODEL-BUNDLE line)")
            line = fh.readline(_MAX_HEADER)
            payload = fh.read()
    except FileNotFoundError:
        raise fail("model bundle not found") from None
    except IsADirectoryError:
        raise fail("is a folder, not a model bundle file") from None
    except OSError as exc:
        raise fail(f"cannot read the model bundle ({exc.strerror})") from None
    if not line.endswith(b"\n"):
        raise fail("bundle header is truncated or corrupt")
    try:
        header = json.loads(line.decode("ascii"))
    except (UnicodeDecodeError, json.JSONDecodeError, RecursionError):
        raise fail("bundle header is corrupt (not valid JSON)") from None
    if not isinstance(header, dict):
        raise fail("bundle header is not a JSON object")
    if header.get("format") != BUNDLE_FORMAT:
        raise fail(f"bundle header does not name the format {BUNDLE_FORMAT!r}")
    missing = [k for k in _HEADER_TYPES if k not in header]
    if missing:
        raise fail(f"bundle header lacks {missing}; the file is corrupt or not written by tzsl")
    for key, expected in _HEADER_TYPES.items():
        value = header[key]
        if not isinstance(value, expected) or (expected is int and isinstance(value, bool)):
            what = "a JSON object" if expected is dict else f"a JSON {'number' if expected is int else 'string'}"
            raise fail(f"bundle header field {key!r} is not {what}")
    if not _KIND.match(header["kind"]):
        raise fail(f"bundle kind {header['kind']!r} is not lower-case words joined by '-'")
    signed = _canonical(_signed_fields(header))
    if not hmac.compare_digest(hashlib.sha256(signed).hexdigest().encode(), header["header_sha256"].encode()):
        raise fail("bundle header checksum mismatch: the header was edited or is corrupt")
    if not hmac.compare_digest(hashlib.sha256(payload).hexdigest().encode(), header["payload_sha256"].encode()):
        raise fail(
            f"model payload checksum mismatch ({len(payload)} bytes read, {header.get('payload_bytes')} "
            "written): the file is corrupt, truncated or was tampered with"
        )
    secret = _key()
    if secret is not None:
        if "hmac_sha256" not in header:
            raise fail(f"bundle is not signed, but {BUNDLE_KEY_ENV} is set: refusing to load an unsigned bundle")
        expected_mac = hmac.new(secret, signed, hashlib.sha256).hexdigest()
        if not hmac.compare_digest(expected_mac.encode(), str(header["hmac_sha256"]).encode()):
            raise fail(f"bundle signature does not match {BUNDLE_KEY_ENV}: wrong key or tampered file")
    version = header["format_version"]
    if version not in (_PICKLE_VERSION, BUNDLE_FORMAT_VERSION):
        raise fail(f"bundle format version {version!r}; this tzsl reads version {BUNDLE_FORMAT_VERSION}")
    if version == BUNDLE_FORMAT_VERSION and header.get("payload_format") not in _PAYLOAD_FORMATS:
        raise fail(f"bundle payload format {header.get('payload_format')!r} is not one of {list(_PAYLOAD_FORMATS)}")
    return header, payload


def _header(path: Path, header: dict) -> BundleHeader:
    version = int(header["format_version"])
    return BundleHeader(
        path=path,
        kind=header["kind"],
        tzsl_version=header["tzsl_version"],
        format_version=version,
        created=str(header.get("created", "")),
        metadata=dict(header["metadata"]),
        payload_sha256=header["payload_sha256"],
        signed="hmac_sha256" in header,
        payload_format="pickle" if version == _PICKLE_VERSION else str(header["payload_format"]),
    )


def read_bundle_header(path: str | Path) -> BundleHeader:
    """The verified header of a bundle, without deserialising its model.

    Raises
    ------
    ModelBundleError
        Missing or unreadable file, not a bundle, corrupt/tampered header or payload, bad signature.
    """
    path = Path(path)
    header, _ = _read(path)
    return _header(path, header)


def load_bundle(path: str | Path, expected_kind: str | None = None, *, trust_pickle: bool = False) -> tuple[Any, dict]:
    """Load a bundle written by :func:`save_bundle` (no code is run; see the module docstring).

    Parameters
    ----------
    path : str or Path
    expected_kind : str, optional
        Refuse bundles of another kind.
    trust_pickle : bool, default False
        Also load bundles of format version 1, whose model is a pickle: **unpickling runs code
        chosen by whoever wrote the file**; only for files whose author you trust.

    Returns
    -------
    model : object
        The estimator, or for ``"npz"`` payloads the (nested) dict of arrays.
    metadata : dict
        The metadata saved with the model, plus ``"bundle"``: a dict with ``kind``,
        ``tzsl_version``, ``created``, ``payload_sha256``, ``payload_format``, ``signed`` and ``path``.

    Raises
    ------
    ModelBundleError
        Missing or unreadable file, not a bundle, checksum or signature mismatch, written by a
        tzsl of another ``major.minor`` version, of the wrong kind, an old pickle bundle (without
        ``trust_pickle``), a type tzsl does not trust, or deserialising failed.
    """
    path = Path(path)
    header, payload = _read(path)
    info = _header(path, header)
    ours = _tzsl_version()
    if _major_minor(info.tzsl_version) != _major_minor(ours):
        raise ModelBundleError(
            f"{path}: bundle written by tzsl {info.tzsl_version}, this is tzsl {ours}; "
            "models are only portable within the same major.minor version - retrain (or use that version)"
        )
    if expected_kind is not None and info.kind != expected_kind:
        raise ModelBundleError(f"{path}: bundle holds a {info.kind!r} model, expected a {expected_kind!r} model")
    if info.payload_format == "pickle":
        model = _load_pickle(path, payload, trust_pickle)
    else:
        model = _deserialise(path, info.payload_format, payload)
    metadata = dict(info.metadata)
    metadata["bundle"] = {
        "kind": info.kind,
        "tzsl_version": info.tzsl_version,
        "created": info.created,
        "payload_sha256": info.payload_sha256,
        "payload_format": info.payload_format,
        "signed": info.signed,
        "path": str(path),
    }
    return model, metadata


def _load_pickle(path: Path, payload: bytes, trust_pickle: bool) -> Any:
    if not trust_pickle:
        raise ModelBundleError(
            f"{path}: old bundle format (version 1) holding a pickle, which can run code when loaded; "
            "re-save the model with this tzsl (re-run the train command with --out), or, only if you trust "
            "whoever wrote the file, load it with 'tzsl predict --trust-pickle'")
    import joblib  # noqa: PLC0415 - only for explicitly trusted old bundles

    try:
        return joblib.load(io.BytesIO(payload))
    except Exception as exc:  # noqa: BLE001 - report any unpickling failure as a bundle error
        raise ModelBundleError(
            f"{path}: cannot load the model ({type(exc).__name__}: {exc}); a package it needs may be missing"
        ) from None
