"""A restricted unpickler for pickles downloaded from the internet.

``pickle`` can run arbitrary code while loading (any importable callable can be named
and called). The Penn PHAC-2 feature pickles and the GelSight force/width pickles only
hold numpy arrays inside dicts, lists, tuples and ``collections.defaultdict``; this
unpickler admits exactly the globals needed to rebuild those and refuses everything
else *before* it is imported or called.
"""

from __future__ import annotations

import builtins
import codecs
import collections
import importlib
import io
import os
import pickle
from pathlib import Path
from typing import Any

import numpy as np

from tzsl.exceptions import DataFileError

# Python 2 pickles name builtins "__builtin__"; Python 3 ones "builtins".
_BUILTIN_MODULES = ("__builtin__", "builtins")
_SAFE_BUILTINS = frozenset({"dict", "list", "tuple", "set", "frozenset", "int", "float",
                            "complex", "bool", "str", "bytes", "unicode", "long"})
_PY2_BUILTIN_ALIASES = {"unicode": "str", "long": "int"}

# (module, name) -> importer; the numpy globals a pickled array / dtype / scalar needs
# under numpy 1.x ("numpy.core") and numpy 2.x ("numpy._core").
_SAFE_NUMPY: frozenset[tuple[str, str]] = frozenset(
    {
        ("numpy", "ndarray"),
        ("numpy", "dtype"),
        ("numpy.core.multiarray", "_reconstruct"),
        ("numpy._core.multiarray", "_reconstruct"),
        ("numpy.core.multiarray", "scalar"),
        ("numpy._core.multiarray", "scalar"),
        ("numpy.core.numeric", "_frombuffer"),
        ("numpy._core.numeric", "_frombuffer"),
    }
)


class _RestrictedUnpickler(pickle.Unpickler):
    """Unpickler whose ``find_class`` only resolves an allow-list of globals."""

    def __init__(self, file: io.BufferedIOBase, source: str) -> None:
        super().__init__(file, encoding="latin1")
        self._source = source

    def find_class(self, module: str, name: str) -> Any:
        if module in _BUILTIN_MODULES and name in _SAFE_BUILTINS:
            return getattr(builtins, _PY2_BUILTIN_ALIASES.get(name, name))
        if module == "_codecs" and name == "encode":
            # Python 3 writes bytes in protocol <= 2 as _codecs.encode(str, "latin1").
            return codecs.encode
        if module == "collections" and name == "defaultdict":
            return collections.defaultdict
        if (module, name) in _SAFE_NUMPY:
            return _import_numpy_global(module, name)
        raise _Forbidden(f"{module}.{name}")


class _Forbidden(Exception):
    """Raised inside the unpickler for a global outside the allow-list."""


def _import_numpy_global(module: str, name: str) -> Any:
    if module == "numpy":
        return getattr(np, name)
    # numpy 2 keeps numpy.core as a deprecated alias of numpy._core; import the real one.
    real = module.replace("numpy.core.", "numpy._core.", 1)
    try:
        mod = importlib.import_module(real)
    except ImportError:  # numpy 1.x has no numpy._core
        mod = importlib.import_module(module.replace("numpy._core.", "numpy.core.", 1))
    return getattr(mod, name)


def safe_load_pickle(path: str | os.PathLike) -> Any:
    """Load a (Python 2 or 3) pickle that may only hold numpy data and plain containers.

    Admitted: numpy arrays, dtypes and scalars; ``dict``, ``list``, ``tuple``, ``set``,
    ``collections.defaultdict``; plain builtin scalars. Python 2 ``str`` payloads are
    decoded as latin-1 (what numpy needs for array buffers).

    Parameters
    ----------
    path : str or path-like
        The pickle file.

    Returns
    -------
    object
        The unpickled object.

    Raises
    ------
    DataFileError
        The pickle names any other global (message names the file and the global;
        nothing from it is imported or called), or the file is missing, truncated or
        corrupt.
    """
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise DataFileError(path, f"cannot read pickle: {exc.strerror or exc}") from None
    if not data:
        raise DataFileError(path, "empty file (0 bytes); expected a pickle")
    try:
        return _RestrictedUnpickler(io.BytesIO(data), str(path)).load()
    except _Forbidden as exc:
        raise DataFileError(
            path,
            f"pickle refers to forbidden global {exc.args[0]!r}; only numpy arrays, "
            "dicts, lists, tuples and collections.defaultdict are allowed",
        ) from None
    except EOFError:
        raise DataFileError(path, "truncated pickle (ended before its STOP opcode)") from None
    except Exception as exc:  # noqa: BLE001 - pickle raises many types on corrupt input
        raise DataFileError(
            path, f"corrupt or unreadable pickle ({type(exc).__name__}: {exc})"
        ) from None
