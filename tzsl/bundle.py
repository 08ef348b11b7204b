"""Saved model bundles: one file holding a fitted model, what it needs at predict time, and checks.

A bundle (by convention ``*.tzsl``) is written by :func:`save_bundle` and read by
:func:`load_bundle`. Layout, in this order::

    TZSL-MODEL-BUNDLE\\n           # magic line
    {"format": ..., ...}\\n         # header: one line of JSON (UTF-8)
    <payload bytes>               # the model, serialised by joblib (zlib-compressed pickle)

The header records the bundle format and its version, the tzsl version that wrote it, the model
``kind`` (``"hand-dap"``, ``"phac2-dap"``, ``"deep"``, ...), the creation time, the user's
``metadata`` (JSON: attribute names, feature layout, fusion, ...), ``payload_sha256`` (sha256 of
the payload bytes), ``header_sha256`` (sha256 of the canonical JSON of every other header field,
so metadata edits are caught too) and, when the key is set, ``hmac_sha256`` (see below).

:func:`load_bundle` checks, *before* unpickling anything: the magic line, the header, both
checksums, the signature (when ``TZSL_BUNDLE_KEY`` is set), the format version, the tzsl
``major.minor`` version (models are not portable across minor versions: estimator internals and
the feature layout may change) and the expected kind. Any failure raises
:class:`~tzsl.exceptions.ModelBundleError` with the file and the reason.

Security
--------
The payload is a pickle: **loading a bundle runs code chosen by whoever wrote the file. Only load
bundles you trust.** The sha256 checksums detect corruption (a truncated copy, a flipped byte, a
hand-edited header); they do not stop an attacker, who can recompute them. For that, set the
environment variable ``TZSL_BUNDLE_KEY`` to a secret shared by the machines that write and read
bundles: :func:`save_bundle` then signs the header (which holds the payload's sha256) with
HMAC-SHA256, and :func:`load_bundle` refuses any bundle whose signature is missing or wrong
*before* unpickling it. Without the key, signatures are neither made nor checked.
"""

from __future__ import annotations

import hashlib
import hmac
import io
import json
import os
import re
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import joblib
import numpy as np

from tzsl._io import atomic_write
from tzsl.exceptions import ConfigError, ModelBundleError

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
#: Version of the file layout described in the module docstring.
BUNDLE_FORMAT_VERSION = 1
#: Environment variable holding the HMAC key (any non-empty text).
BUNDLE_KEY_ENV = "TZSL_BUNDLE_KEY"

_MAGIC = b"TZSL-MODEL-BUNDLE\n"
_KIND = re.compile(r"^[a-z0-9][a-z0-9-]*$")
_MAX_HEADER = 16 * 1024 * 1024  # a header line longer than this is not ours


@dataclass(frozen=True)
class BundleHeader:
    """What a bundle says about itself (readable without unpickling the model).

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
    """

    path: Path
    kind: str
    tzsl_version: str
    format_version: int
    created: str
    metadata: dict
    payload_sha256: str
    signed: bool


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
        A fitted model; anything joblib can pickle.
    kind : str
        Model kind, lower-case words joined by ``-`` (``"hand-dap"``, ``"phac2-dap"``, ``"deep"``).
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
        The model cannot be pickled.
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
    buffer = io.BytesIO()
    try:
        joblib.dump(model, buffer, compress=3)
    except Exception as exc:  # noqa: BLE001 - any pickling failure is reported the same way
        raise ModelBundleError(f"{path}: cannot serialise the model ({type(exc).__name__}: {exc})") from None
    payload = buffer.getvalue()
    header: dict[str, Any] = {
        "format": BUNDLE_FORMAT,
        "format_version": BUNDLE_FORMAT_VERSION,
        "tzsl_version": _tzsl_version(),
        "kind": kind,
        "created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "metadata": metadata,
        "payload_bytes": len(payload),
        "payload_sha256": hashlib.sha256(payload).hexdigest(),
    }
    signed = _canonical(header)
    header["header_sha256"] = hashlib.sha256(signed).hexdigest()
    key = _key()
    if key is not None:
        header["hmac_sha256"] = hmac.new(key, signed, hashlib.sha256).hexdigest()
    line = json.dumps(header, sort_keys=True, ensure_ascii=True).encode("ascii") + b"\n"

    def _write(tmp: Path) -> None:
        with open(tmp, "wb") as fh:
            fh.write(_MAGIC)
            fh.write(line)
            fh.write(payload)

    return atomic_write(path, _write)


def _read(path: Path) -> tuple[dict, bytes]:
    """Header and payload bytes of ``path``, with every check that needs no unpickling."""

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
    except (UnicodeDecodeError, json.JSONDecodeError):
        raise fail("bundle header is corrupt (not valid JSON)") from None
    if not isinstance(header, dict) or header.get("format") != BUNDLE_FORMAT:
        raise fail(f"bundle header does not name the format {BUNDLE_FORMAT!r}")
    required = ("format_version", "tzsl_version", "kind", "metadata", "payload_sha256", "header_sha256")
    missing = [k for k in required if k not in header]
    if missing:
        raise fail(f"bundle header lacks {missing}; the file is corrupt or not written by tzsl")
    signed = _canonical(_signed_fields(header))
    if not hmac.compare_digest(hashlib.sha256(signed).hexdigest(), str(header["header_sha256"])):
        raise fail("bundle header checksum mismatch: the header was edited or is corrupt")
    if not hmac.compare_digest(hashlib.sha256(payload).hexdigest(), str(header["payload_sha256"])):
        raise fail(
            f"model payload checksum mismatch ({len(payload)} bytes read, {header.get('payload_bytes')} "
            "written): the file is corrupt, truncated or was tampered with"
        )
    key = _key()
    if key is not None:
        if "hmac_sha256" not in header:
            raise fail(f"bundle is not signed, but {BUNDLE_KEY_ENV} is set: refusing to load an unsigned bundle")
        expected = hmac.new(key, signed, hashlib.sha256).hexdigest()
        if not hmac.compare_digest(expected, str(header["hmac_sha256"])):
            raise fail(f"bundle signature does not match {BUNDLE_KEY_ENV}: wrong key or tampered file")
    if header["format_version"] != BUNDLE_FORMAT_VERSION:
        raise fail(
            f"bundle format version {header['format_version']!r}; this tzsl reads version {BUNDLE_FORMAT_VERSION}"
        )
    return header, payload


def _header(path: Path, header: dict) -> BundleHeader:
    return BundleHeader(
        path=path,
        kind=str(header["kind"]),
        tzsl_version=str(header["tzsl_version"]),
        format_version=int(header["format_version"]),
        created=str(header.get("created", "")),
        metadata=dict(header["metadata"]),
        payload_sha256=str(header["payload_sha256"]),
        signed="hmac_sha256" in header,
    )


def read_bundle_header(path: str | Path) -> BundleHeader:
    """The verified header of a bundle, without unpickling its model (safe on untrusted files).

    Raises
    ------
    ModelBundleError
        Missing or unreadable file, not a bundle, corrupt/tampered header or payload, bad signature.
    """
    path = Path(path)
    header, _ = _read(path)
    return _header(path, header)


def load_bundle(path: str | Path, expected_kind: str | None = None) -> tuple[Any, dict]:
    """Load a bundle written by :func:`save_bundle`.

    **Unpickles the model: only load bundles you trust** (see the module docstring).

    Parameters
    ----------
    path : str or Path
    expected_kind : str, optional
        Refuse bundles of another kind.

    Returns
    -------
    model : object
    metadata : dict
        The metadata saved with the model, plus ``"bundle"``: a dict with ``kind``,
        ``tzsl_version``, ``created``, ``payload_sha256``, ``signed`` and ``path``.

    Raises
    ------
    ModelBundleError
        Missing or unreadable file, not a bundle, checksum or signature mismatch, written by a
        tzsl of another ``major.minor`` version, of the wrong kind, or unpickling failed.
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
    try:
        model = joblib.load(io.BytesIO(payload))
    except Exception as exc:  # noqa: BLE001 - report any unpickling failure as a bundle error
        raise ModelBundleError(
            f"{path}: cannot load the model ({type(exc).__name__}: {exc}); a package it needs may be missing"
        ) from None
    metadata = dict(info.metadata)
    metadata["bundle"] = {
        "kind": info.kind,
        "tzsl_version": info.tzsl_version,
        "created": info.created,
        "payload_sha256": info.payload_sha256,
        "signed": info.signed,
        "path": str(path),
    }
    return model, metadata
