"""Small file helpers shared by every layer: atomic writes, checksums and safe ``.npz`` reading."""

from __future__ import annotations

import hashlib
import os
import tempfile
import zipfile
from collections.abc import Callable
from pathlib import Path
from tokenize import TokenError
from typing import IO

import numpy as np

from tzsl.exceptions import ConfigError, DataFileError

#: Environment variable raising (or lowering) the largest ``.npz`` content tzsl reads, in bytes.
MAX_NPZ_BYTES_ENV = "TZSL_MAX_NPZ_BYTES"
#: Default of :data:`MAX_NPZ_BYTES_ENV`: 2 GiB of declared array data per file.
DEFAULT_MAX_NPZ_BYTES = 2 * 1024**3


def _umask() -> int:
    """The process umask (read without changing it where the OS allows)."""
    try:  # Linux: no race with other threads
        with open("/proc/self/status", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def ensure_folder(folder: str | Path, what: str = "output folder") -> Path:
    """Create ``folder`` (and parents); one-line :class:`ConfigError` when that is impossible."""
    folder = Path(folder)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except FileExistsError:
        raise ConfigError(f"{folder}: cannot create the {what}: a file of that name (or of a parent) exists") from None
    except NotADirectoryError:
        raise ConfigError(f"{folder}: cannot create the {what}: a parent is a file, not a folder") from None
    except PermissionError:
        raise ConfigError(f"{folder}: cannot create the {what}: permission denied") from None
    except OSError as exc:
        raise ConfigError(f"{folder}: cannot create the {what}: {exc.strerror or exc}") from None
    return folder


def atomic_write(path: str | Path, write: Callable[[Path], object]) -> Path:
    """Call ``write(tmp_path)`` and move the result to ``path`` atomically.

    The file gets the permissions a plain ``open(path, "w")`` would give (``0o666`` minus the
    umask, so ``0o644`` by default), not the ``0o600`` of a temporary file.

    Parameters
    ----------
    path : str or Path
        Final destination; its folder is created if needed.
    write : callable
        Receives a temporary path in the same folder and writes the full content there.
        If it raises, the destination is left untouched and the temporary file removed.

    Raises
    ------
    ConfigError
        The folder cannot be created or written to (one line naming it).
    """
    path = Path(path)
    ensure_folder(path.parent)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    except PermissionError:
        raise ConfigError(f"{path}: cannot write here: permission denied in {path.parent}") from None
    except OSError as exc:
        raise ConfigError(f"{path}: cannot write here: {exc.strerror or exc}") from None
    os.close(fd)
    tmp_path = Path(tmp)
    try:
        write(tmp_path)
        os.chmod(tmp_path, 0o666 & ~_umask())
        os.replace(tmp_path, path)
    finally:
        if tmp_path.exists():
            tmp_path.unlink()
    return path


def atomic_write_bytes(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically (:func:`atomic_write`)."""
    return atomic_write(path, lambda tmp: Path(tmp).write_bytes(data))


def file_sha256(path: str | os.PathLike[str]) -> str:
    """Hex sha256 of a file's bytes."""
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def looks_binary(path: str | Path, probe: int = 8192) -> bool:
    """Whether the first ``probe`` bytes of ``path`` hold a NUL byte or are not UTF-8 text."""
    with open(path, "rb") as fh:
        head = fh.read(probe)
    if b"\0" in head:
        return True
    try:
        head.decode("utf-8")
    except UnicodeDecodeError as exc:
        return exc.start < len(head) - 4  # a multi-byte character cut by the probe is fine
    return False


def max_npz_bytes() -> int:
    """The largest declared ``.npz`` content read, from :data:`MAX_NPZ_BYTES_ENV` (default 2 GiB)."""
    text = os.environ.get(MAX_NPZ_BYTES_ENV, "").strip()
    if not text:
        return DEFAULT_MAX_NPZ_BYTES
    try:
        value = int(float(text))
    except ValueError:
        raise ConfigError(f"{MAX_NPZ_BYTES_ENV}={text!r} is not a number of bytes") from None
    if value <= 0:
        raise ConfigError(f"{MAX_NPZ_BYTES_ENV}={text!r} must be a positive number of bytes")
    return value


def _declared(fh: IO[bytes]) -> tuple[tuple[int, ...], bool, np.dtype, int]:
    """Shape, Fortran order, dtype and header size that one open ``.npy`` member declares (reads its header)."""
    version = np.lib.format.read_magic(fh)
    if version == (1, 0):
        shape, fortran, dtype = np.lib.format.read_array_header_1_0(fh)
    elif version == (2, 0):
        shape, fortran, dtype = np.lib.format.read_array_header_2_0(fh)
    else:
        raise ValueError(f"unsupported .npy format version {version}")
    return shape, fortran, dtype, fh.tell()


def _read_member(fh: IO[bytes], info: zipfile.ZipInfo, where: str | Path, before: int,
                 limit: int) -> tuple[str, np.ndarray, int]:
    """Key, array and byte size of one open ``.npz`` member, its header checked before any allocation.

    ``before``: bytes of the members already read (the ``limit`` is on the total).
    """
    shape, fortran, dtype, header_size = _declared(fh)
    if dtype.hasobject:
        raise DataFileError(where, f"array {info.filename!r} holds Python objects (a pickle); "
                            "tzsl only reads numeric and text arrays")
    nbytes = int(np.prod(shape, dtype=object)) * dtype.itemsize
    if before + nbytes > limit:
        raise DataFileError(where, f"arrays declare {before + nbytes:,} bytes (array {info.filename!r} has shape "
                            f"{tuple(shape)} of {dtype}), more than the limit of {limit:,}; "
                            f"raise it with the environment variable {MAX_NPZ_BYTES_ENV} if the "
                            "file is genuine")
    if info.file_size < header_size + nbytes:
        raise DataFileError(where, f"array {info.filename!r} declares shape {tuple(shape)} of {dtype} "
                            f"({nbytes:,} bytes) but holds {info.file_size - header_size:,}: the file "
                            "is truncated or corrupt")
    data = bytearray(nbytes)  # writable, like np.load's arrays
    if fh.readinto(data) != nbytes:  # type: ignore[attr-defined]  # buffered readers; typeshed's IO lacks it
        raise EOFError(f"array {info.filename!r} ends before its {nbytes:,} bytes")
    key = info.filename[: -len(".npy")] if info.filename.endswith(".npy") else info.filename
    return key, np.frombuffer(data, dtype=dtype).reshape(shape, order="F" if fortran else "C"), nbytes


def read_npz(source: str | Path | IO[bytes], *, name: str | Path | None = None,
             limit: int | None = None) -> dict[str, np.ndarray]:
    """Every array of an ``.npz`` archive, checked before anything large is allocated.

    Reads each member's ``.npy`` header first: the declared shapes and dtypes must add up to at
    most ``limit`` bytes, each member must hold as many bytes as its header declares (a
    truncated or lying file is refused before numpy allocates the array), and object arrays
    (pickles) are refused.

    Parameters
    ----------
    source : path or binary file object
    name : path, optional
        Name for messages (default: ``source``).
    limit : int, optional
        Largest total declared array size in bytes; default :func:`max_npz_bytes`
        (environment variable ``TZSL_MAX_NPZ_BYTES``).

    Returns
    -------
    dict name -> ndarray
        In archive order (``.npy`` suffix removed).

    Raises
    ------
    DataFileError
        Missing, not a zip archive, truncated, corrupt, pickled or too large (one line).
    """
    # a file object has no path: messages name it as str() shows it (what DataFileError prints)
    where = name if name is not None else source if isinstance(source, (str, Path)) else str(source)
    limit = max_npz_bytes() if limit is None else limit
    try:
        arrays, total = {}, 0
        with zipfile.ZipFile(source) as zf:
            for info in zf.infolist():  # each member opened once: its header checked, then its data read
                if not info.is_dir():
                    with zf.open(info) as fh:
                        key, arrays[key], nbytes = _read_member(fh, info, where, total, limit)
                    total += nbytes
        return arrays
    except DataFileError:
        raise
    except FileNotFoundError:
        raise DataFileError(where, "file not found") from None
    except IsADirectoryError:
        raise DataFileError(where, "is a folder, not an .npz file") from None
    except zipfile.BadZipFile as exc:
        raise DataFileError(where, f"not a readable .npz archive (truncated or not a zip file: {exc})") from None
    except (OSError, ValueError, EOFError, KeyError, zipfile.LargeZipFile, NotImplementedError, SyntaxError,
            TokenError) as exc:  # numpy parses a header with the tokenizer: a damaged one raises its errors
        raise DataFileError(where, f"not a readable .npz archive ({type(exc).__name__}: {exc})") from None


def read_npy(path: str | Path, *, limit: int | None = None) -> np.ndarray:
    """The array of one ``.npy`` file, its header checked before anything large is allocated.

    The same checks as one member of :func:`read_npz`: the declared shape and dtype must come to
    at most ``limit`` bytes (default :func:`max_npz_bytes`, environment variable
    ``TZSL_MAX_NPZ_BYTES``), the file must hold as many bytes as its header declares (a
    zero-byte, truncated or lying file is refused before numpy allocates the array), and object
    arrays (pickles) are refused.

    Raises
    ------
    DataFileError
        Missing, not an ``.npy`` file, truncated, pickled or too large (one line).
    """
    limit = max_npz_bytes() if limit is None else limit
    try:
        info = zipfile.ZipInfo(Path(path).name)  # the name and size _read_member reports
        info.file_size = os.path.getsize(path)
        with open(path, "rb") as fh:
            return _read_member(fh, info, path, 0, limit)[1]
    except DataFileError:
        raise
    except FileNotFoundError:
        raise DataFileError(path, "file not found") from None
    except IsADirectoryError:
        raise DataFileError(path, "is a folder, not an .npy file") from None
    except (OSError, ValueError, EOFError, SyntaxError, TokenError) as exc:  # header parsing: see read_npz
        text = str(exc).strip().splitlines()
        raise DataFileError(path, f"not a readable .npy array ({type(exc).__name__}: "
                            f"{text[0] if text else 'empty or truncated'})") from None
