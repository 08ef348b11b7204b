"""Bundle payloads stored with skops: fitted estimators, read without running code.

A zero-shot model that no array payload holds (:mod:`tzsl.inference.zero_shot_bundles`), a
per-EP model (:mod:`tzsl.inference.predict_active`) and the hand model are saved with
:mod:`skops.io`. Reading a payload refuses every type that is not on tzsl's trusted list *before*
anything is built (:func:`is_trusted_type`, naming the type): the types skops trusts by default
(builtins, numpy arrays and scalars), classes defined in ``sklearn`` and in ``tzsl.models`` /
``tzsl.features`` (each resolved and checked to be a class defined where its name says, so a name
cannot smuggle in a function or a module), and :data:`EXTRA_TRUSTED_TYPES`. pandas tables inside a
model (skops cannot store them) are written as plain columns and rebuilt on load. A payload saved before
``tzsl.models`` was split into subpackages names its classes by their old modules; reading renames those
modules by :data:`MOVED_MODULES` first, and the renamed types pass the same trust check.
"""

from __future__ import annotations

import copy
import importlib
import io
import json
import sys
import zipfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from tzsl.exceptions import ModelBundleError

__all__ = ["EXTRA_TRUSTED_TYPES", "MOVED_MODULES", "SKOPS_SKIPPED_LIBRARIES", "TRUSTED_MODULE_PREFIXES",
           "is_trusted_type", "read_skops_payload", "renamed_moved_modules", "skops_io", "skops_payload"]

_PANDAS = "__tzsl_pandas__"


#: Packages whose *classes* a skops payload may name (each checked to be a class defined there).
TRUSTED_MODULE_PREFIXES: tuple[str, ...] = ("sklearn.", "tzsl.models.", "tzsl.features.")
#: Further type names trusted in skops payloads (skops leaves them out of its defaults).
EXTRA_TRUSTED_TYPES: frozenset[str] = frozenset({"numpy.dtype"})

#: Modules of tzsl.models whose classes moved when the package was split into subpackages by role (issue 43):
#: the module a model file saved before the move names -> the module the class is defined in now. The one map of
#: moved class paths: a type ``old.Name`` of a payload is read as ``new.Name`` (:func:`renamed_moved_modules`),
#: and must then be trusted like any other (:func:`is_trusted_type`). Add a line when a class moves again.
MOVED_MODULES: dict[str, str] = {
    "tzsl.models._active_policy": "tzsl.models.active_touch._policy",
    "tzsl.models._active_suggest": "tzsl.models.active_touch._suggest",
    "tzsl.models._active_touch": "tzsl.models.active_touch._per_ep",
    "tzsl.models._attribute_bank": "tzsl.models.detectors._attribute_bank",
    "tzsl.models._attribute_search": "tzsl.models.detectors._attribute_search",
    "tzsl.models._attribute_svm": "tzsl.models.detectors._attribute_svm",
    "tzsl.models._attribute_training": "tzsl.models.detectors._attribute_training",
    "tzsl.models._compatibility": "tzsl.models.embedding._compatibility",
    "tzsl.models._decision": "tzsl.models.rules._decision",
    "tzsl.models._deep": "tzsl.models.embedding.deep._model",
    "tzsl.models._deep_backbones": "tzsl.models.embedding.deep._backbones",
    "tzsl.models._deep_bundle": "tzsl.models.embedding.deep._bundle",
    "tzsl.models._deep_input": "tzsl.models.embedding.deep._input",
    "tzsl.models._deep_training": "tzsl.models.embedding.deep._training",
    "tzsl.models._detectors": "tzsl.models.detectors._families",
    "tzsl.models._embedding": "tzsl.models.embedding._embedding",
    "tzsl.models._eszsl": "tzsl.models.embedding._eszsl",
    "tzsl.models._grouped_folds": "tzsl.models.detectors._grouped_folds",
    "tzsl.models._hand_dap": "tzsl.models.hand._hand_dap",
    "tzsl.models._iap": "tzsl.models.detectors._iap",
    "tzsl.models._linear_attribute": "tzsl.models.detectors._linear_attribute",
    "tzsl.models._logistic_attribute": "tzsl.models.detectors._logistic_attribute",
    "tzsl.models._multigrasp": "tzsl.models.hand._multigrasp",
    "tzsl.models._multilabel": "tzsl.models.detectors._multilabel",
    "tzsl.models._platt_binary": "tzsl.models.detectors._platt_binary",
    "tzsl.models._posterior_calibration": "tzsl.models.calibration._posterior_calibration",
    "tzsl.models._sae": "tzsl.models.embedding._sae",
    "tzsl.models._scalable_attribute": "tzsl.models.detectors._scalable_attribute",
    "tzsl.models._score_ensemble": "tzsl.models.ensemble._score_ensemble",
}

#: Optional array libraries that importing skops would import for nothing: skops lists every
#: scikit-learn estimator when it is first imported (``sklearn.utils.all_estimators``), which walks
#: every scikit-learn package, ``sklearn.externals.array_api_compat.torch`` and ``.dask`` included,
#: and so imports torch and dask when they are installed (seconds). A model payload never holds
#: their arrays, so :func:`skops_io` hides them while skops builds its list.
SKOPS_SKIPPED_LIBRARIES: tuple[str, ...] = ("torch", "dask")


# ----------------------------------------------------------------------------- trusted types
def _resolve(name: str) -> Any:
    """The object a dotted type name designates (imports only modules under the trusted prefixes)."""
    parts = name.split(".")
    for i in range(len(parts) - 1, 0, -1):
        module_name = ".".join(parts[:i])
        if not (module_name + ".").startswith(TRUSTED_MODULE_PREFIXES) and module_name not in ("sklearn",):
            continue
        try:
            obj: Any = importlib.import_module(module_name)
        except ImportError:
            continue
        try:
            for attr in parts[i:]:
                obj = getattr(obj, attr)
        except AttributeError:
            return None
        return obj
    return None


def is_trusted_type(name: str) -> bool:
    """Whether a skops payload may name the type ``name`` (``"module.QualName"``).

    True for :data:`EXTRA_TRUSTED_TYPES` and for classes defined in a module under
    :data:`TRUSTED_MODULE_PREFIXES` (every class of ``tzsl.models``, present and future, and every
    scikit-learn class). The name is resolved and must be a class whose ``__module__`` and
    ``__qualname__`` give back ``name``: a function, a module or a name imported from elsewhere
    (``tzsl.models._x.os``) is not trusted.
    """
    if name in EXTRA_TRUSTED_TYPES:
        return True
    if not name.startswith(TRUSTED_MODULE_PREFIXES):
        return False
    obj = _resolve(name)
    return isinstance(obj, type) and f"{obj.__module__}.{obj.__qualname__}" == name


def _renamed(node: Any) -> Any:
    """A skops schema node with every ``__module__`` of :data:`MOVED_MODULES` renamed, recursively."""
    if isinstance(node, dict):
        out = {k: _renamed(v) for k, v in node.items()}
        if isinstance(out.get("__module__"), str) and out["__module__"] in MOVED_MODULES:
            out["__module__"] = MOVED_MODULES[out["__module__"]]
        return out
    if isinstance(node, list):
        return [_renamed(v) for v in node]
    return node


def renamed_moved_modules(payload: bytes) -> bytes:
    """A skops payload whose types name their modules as they are now (:data:`MOVED_MODULES`).

    A payload naming no moved module is returned as it is (the same bytes); otherwise its ``schema.json``
    is rewritten and every other member copied unchanged. Anything that is not a readable skops archive
    is returned as it is, for :func:`read_skops_payload` to refuse.
    """
    try:
        with zipfile.ZipFile(io.BytesIO(payload)) as archive:
            schema = json.loads(archive.read("schema.json"))
            renamed = _renamed(schema)
            if renamed == schema:
                return payload
            out = io.BytesIO()
            with zipfile.ZipFile(out, "w", compression=zipfile.ZIP_DEFLATED) as copy_to:
                for info in archive.infolist():
                    data = json.dumps(renamed).encode() if info.filename == "schema.json" else archive.read(info)
                    copy_to.writestr(info, data)
            return out.getvalue()
    except (zipfile.BadZipFile, KeyError, ValueError):
        return payload


# ----------------------------------------------------------------------------- skops
class _HiddenLibraries:
    """An import finder under which the top-level packages ``names`` are not installed."""

    def __init__(self, names: Sequence[str]) -> None:
        self.names = frozenset(names)

    def find_spec(self, fullname: str, path: Any = None, target: Any = None) -> None:
        if fullname.partition(".")[0] in self.names:
            raise ModuleNotFoundError(f"No module named {fullname!r} (hidden while skops is imported)", name=fullname)


def skops_io() -> Any:
    """The module :mod:`skops.io`, imported without importing :data:`SKOPS_SKIPPED_LIBRARIES`.

    While skops is first imported, the libraries of :data:`SKOPS_SKIPPED_LIBRARIES` that are not
    imported yet cannot be imported (an import finder placed first raises ImportError, which the
    package walk of ``all_estimators`` skips); the finder is removed afterwards, so they import
    normally later. Already imported libraries are left alone.
    """
    if "skops.io" in sys.modules:
        return sys.modules["skops.io"]
    finder = _HiddenLibraries([name for name in SKOPS_SKIPPED_LIBRARIES if name not in sys.modules])
    sys.meta_path.insert(0, finder)
    try:
        import skops.io as sio  # noqa: PLC0415 - imported when a model is saved or loaded
    finally:
        sys.meta_path.remove(finder)
    return sio


# ----------------------------------------------------------------------------- payloads
def _walkable(obj: Any) -> bool:
    module = type(obj).__module__ or ""
    return hasattr(obj, "__dict__") and not isinstance(obj, type) and module.startswith(("tzsl.", "sklearn."))


def _encode(obj: Any) -> Any:
    """``obj`` with every pandas table replaced by plain columns (skops cannot store pandas)."""
    if isinstance(obj, pd.DataFrame):
        return {_PANDAS: "DataFrame", "columns": [_plain(obj.columns)], "names": [obj.index.name, obj.columns.name],
                "index": _plain(obj.index), "data": [_plain(obj[c]) for c in obj.columns]}
    if isinstance(obj, pd.Series):
        return {_PANDAS: "Series", "index": _plain(obj.index), "names": [obj.index.name, obj.name],
                "data": _plain(obj)}
    if isinstance(obj, dict):
        return {k: _encode(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_encode(v) for v in obj]
    if isinstance(obj, tuple) and type(obj) is tuple:
        return tuple(_encode(v) for v in obj)
    if _walkable(obj):
        clone = copy.copy(obj)
        clone.__dict__.update({k: _encode(v) for k, v in vars(obj).items()})
        return clone
    return obj


def _plain(values: Any) -> Any:
    """A pandas column or index as a numpy array (numbers) or a list (text, mixed)."""
    array = np.asarray(values)
    return array.tolist() if array.dtype.kind in "OSUM" else array.copy()


def _decode(obj: Any) -> Any:
    if isinstance(obj, dict):
        if obj.get(_PANDAS) == "DataFrame":
            index = pd.Index(obj["index"], name=obj["names"][0])
            columns = pd.Index(obj["columns"][0], name=obj["names"][1])
            return pd.DataFrame({i: np.asarray(col) if not isinstance(col, list) else col
                                 for i, col in enumerate(obj["data"])}, index=index).set_axis(columns, axis=1)
        if obj.get(_PANDAS) == "Series":
            return pd.Series(obj["data"], index=pd.Index(obj["index"], name=obj["names"][0]), name=obj["names"][1])
        return {k: _decode(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_decode(v) for v in obj]
    if isinstance(obj, tuple) and type(obj) is tuple:
        return tuple(_decode(v) for v in obj)
    if _walkable(obj):
        obj.__dict__.update({k: _decode(v) for k, v in vars(obj).items()})
    return obj


def skops_payload(model: Any) -> bytes:
    """The skops bytes of a fitted estimator (pandas tables inside it stored as plain columns)."""
    return skops_io().dumps(_encode(model), compression=zipfile.ZIP_DEFLATED)


def read_skops_payload(path: Path, payload: bytes) -> Any:
    """The estimator of a skops payload; refuses untrusted types by name before building anything.

    Raises
    ------
    ModelBundleError
        Not a readable skops file, a type tzsl does not trust, or deserialising failed (one line
        naming ``path``).

    Notes
    -----
    Types of modules that moved (:data:`MOVED_MODULES`) are renamed first, so a model file saved before
    the move loads; a renamed type is trusted or refused like any other.
    """
    sio = skops_io()
    payload = renamed_moved_modules(payload)
    try:
        untrusted = sio.get_untrusted_types(data=payload)
    except Exception as exc:  # noqa: BLE001 - a corrupt skops archive raises many types
        raise ModelBundleError(f"{path}: the model is not a readable skops file ({type(exc).__name__})") from None
    refused = sorted(t for t in untrusted if not is_trusted_type(t))
    if refused:
        raise ModelBundleError(
            f"{path}: the model names type(s) tzsl does not trust: {', '.join(refused)}; refusing to load it "
            "(a tzsl model holds only scikit-learn, numpy and tzsl.models classes)")
    try:
        return _decode(sio.loads(payload, trusted=list(untrusted)))
    except Exception as exc:  # noqa: BLE001 - report any deserialisation failure as a bundle error
        raise ModelBundleError(f"{path}: cannot load the model ({type(exc).__name__}: "
                               f"{str(exc).splitlines()[0] if str(exc) else ''})") from None
