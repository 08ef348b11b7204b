"""The fit store, and the seeding and parallel-execution helpers shared by the attribute models.

The fit store keeps fitted estimators on disk, one file per fit, under ``<cache folder>/fits/``
(:data:`tzsl.cache.FITS_FOLDER`; its size is capped and pruned with the study cache's, see :mod:`tzsl.cache`).
The key of a fit is what determines its result and nothing else:

* the estimator's class and its parameters, recursively through nested estimators, leaving out
  the ones that cannot change what is learned (:data:`NEUTRAL_PARAMS`: a label used in error
  messages, ``n_jobs``, ``backend``, the cache folder, progress bars);
* the training data: the bytes, dtype and shape of every array given to ``fit`` (features,
  targets, and the object of every trial, which fixes the training objects and their folds);
* the code: a digest of the sources of this module, :mod:`tzsl.models`, :mod:`tzsl.features` and
  :mod:`tzsl.evaluation` and the versions of numpy, scipy, scikit-learn and joblib, so a
  changed model never answers from an old fit.

Nothing about the study, table or command that asks is in the key, so the same fit asked for by
several tables, studies or method comparisons, in one run or in later runs, is computed once.
Warnings a fit raised are stored with it and raised again when it is read back, so a caller that
records them (a convergence flag) sees the same thing either way. A fit whose ``random_state``
is a ``RandomState`` / ``Generator`` instance is never stored (it advances the caller's
generator, which a stored fit would not).
"""

from __future__ import annotations

import hashlib
import os
import pickle
import time
import warnings
from collections import Counter
from contextlib import nullcontext
from functools import cache
from pathlib import Path

import joblib
import numpy as np
from sklearn.base import clone
from sklearn.utils import check_random_state

from tzsl._io import atomic_write
from tzsl._profile import count, timed
from tzsl.cache import FITS_FOLDER, env_cache_dir, mark_used
from tzsl.exceptions import ConfigError
from tzsl.value_lists import JOBLIB_BACKENDS

__all__ = [
    "FITS_FOLDER",
    "NEUTRAL_PARAMS",
    "FitStore",
    "array_digest",
    "code_sources",
    "count_fits",
    "fit_cached",
    "fit_clone",
    "fit_recorded",
    "fit_store_counts",
    "parallel_context",
    "resolve_store",
    "spawn_seeds",
    "stored_fit",
]

#: Parameters that do not change a fit's result, left out of its key.
NEUTRAL_PARAMS = frozenset({"name", "n_jobs", "backend", "memory", "progress", "verbose"})
#: Format of a stored fit (in every key): 2 = a pickle (protocol 5), read by the C unpickler; joblib's files
#: (1) were read by its pure-Python unpickler, the slowest part of a study whose fits are all stored.
_STORE_FORMAT = 2
#: Suffix of a stored fit's file.
STORE_SUFFIX = ".pkl"
_CODE_PACKAGES = ("models", "features", "evaluation")

#: This process's fit-store events: ``hit``, ``miss`` (fitted and stored), ``off`` (fitted, no store),
#: ``unstorable`` (fitted, not storable), ``repeat`` (a key asked for again in this process).
_COUNTS: Counter = Counter()
_SEEN: set[str] = set()


class _Unstorable(Exception):
    """A parameter value that makes a fit unrepeatable (a random generator instance)."""


def code_sources() -> list[Path]:
    """This store's source and every ``.py`` file of the model, feature and evaluation packages, sub-packages
    included (sorted): the code a stored fit depends on."""
    here = Path(__file__).resolve()
    return [here] + [path for package in _CODE_PACKAGES for path in sorted((here.parent / package).rglob("*.py"))]


@cache
def code_digest() -> str:
    """Digest of :func:`code_sources` (their paths inside the package and bytes) and of the numeric libraries'
    versions."""
    import scipy  # noqa: PLC0415
    import sklearn  # noqa: PLC0415

    digest = hashlib.sha256(f"{_STORE_FORMAT} {np.__version__} {scipy.__version__} {sklearn.__version__} "
                            f"{joblib.__version__}".encode())
    root = Path(__file__).resolve().parent
    for path in code_sources():
        digest.update(path.relative_to(root).as_posix().encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


def array_digest(a) -> str:
    """Hex sha256 of an array's dtype, shape and bytes (object arrays: of their pickled values)."""
    if hasattr(a, "columns") or hasattr(a, "index"):  # pandas: the labels count too
        return "p" + joblib.hash(a)
    a = np.asarray(a)
    if a.dtype.hasobject:
        return "o" + joblib.hash(a)
    a = np.ascontiguousarray(a)
    digest = hashlib.sha256(f"{a.dtype.str} {a.shape}".encode())
    digest.update(a.view(np.uint8).reshape(-1).data if a.size else b"")
    return digest.hexdigest()


def _describe(value):
    """A canonical, hashable description of a parameter value (estimators by class and parameters)."""
    if hasattr(value, "get_params") and not isinstance(value, type):
        kind = type(value)
        params = value.get_params(deep=False)
        return ("estimator", f"{kind.__module__}.{kind.__qualname__}",
                tuple((k, _describe(v)) for k, v in sorted(params.items()) if k not in NEUTRAL_PARAMS))
    if isinstance(value, (np.random.RandomState, np.random.Generator)):
        raise _Unstorable
    if value is None or isinstance(value, (bool, int, str)):
        return value
    if isinstance(value, float):
        return ("float", value.hex())
    if isinstance(value, np.generic):
        return _describe(value.item())
    if isinstance(value, np.ndarray):
        return ("array", array_digest(value))
    if isinstance(value, (list, tuple)):
        return (type(value).__name__, tuple(_describe(v) for v in value))
    if isinstance(value, dict):
        return ("dict", tuple(sorted((str(k), _describe(v)) for k, v in value.items())))
    if callable(value) and hasattr(value, "__qualname__"):
        return ("callable", getattr(value, "__module__", ""), value.__qualname__)
    return ("object", joblib.hash(value))


def fit_store_counts(since: dict[str, int] | None = None) -> dict[str, int]:
    """This process's fit-store events: ``hit``, ``miss``, ``off``, ``unstorable``, ``repeat``.

    ``since``: an earlier result; the events after it are returned (what a joblib job did, to be
    handed back to the parent process and added there with :func:`count_fits`).
    """
    now = dict(_COUNTS)
    if since is None:
        return now
    return {k: v - since.get(k, 0) for k, v in now.items() if v != since.get(k, 0)}


def count_fits(name: str, n: int = 1) -> None:
    """Count ``n`` fit-store events ``name`` (this process and the run's profile)."""
    _COUNTS[name] += n
    count(f"fit_store.{name}", n)


class FitStore:
    """Fitted estimators on disk, keyed by estimator parameters, training data and code.

    Parameters
    ----------
    folder : path-like or None
        Folder of the store (``<cache folder>/fits``); None: no store (every fit is computed).
    """

    def __init__(self, folder: str | os.PathLike | None) -> None:
        self.folder = None if folder is None else Path(folder)

    @property
    def enabled(self) -> bool:
        return self.folder is not None

    def key(self, estimator, *data_digests: str) -> str | None:
        """The key of fitting ``estimator`` on data with these :func:`array_digest` values.

        Returns None when the fit cannot be stored (a random generator instance as a parameter).
        """
        try:
            described = _describe(estimator)
        except _Unstorable:
            return None
        text = repr((code_digest(), described, data_digests))
        return hashlib.sha256(text.encode()).hexdigest()

    @staticmethod
    def _path(folder: Path, key: str) -> Path:
        return folder / key[:2] / f"{key}{STORE_SUFFIX}"

    def load(self, key: str | None, template=None):
        """The stored fit of ``key`` (its warnings raised again), or None when there is none.

        ``template``: its neutral parameters (labels, ``n_jobs``) are set on the returned fit.
        """
        if key is None or self.folder is None:
            return None
        path = self._path(self.folder, key)
        try:
            with open(path, "rb") as fh:
                entry = pickle.load(fh)
        except FileNotFoundError:
            return None
        except Exception as exc:  # noqa: BLE001 - a damaged entry is refitted and overwritten, loudly
            warnings.warn(f"{path}: unreadable fit-store entry ({type(exc).__name__}); fitting again", stacklevel=2)
            return None
        mark_used(path)  # pruning (tzsl.cache) removes the least recently used fits first
        _replay(entry["warnings"])
        fitted = entry["estimator"]
        if template is not None:
            _copy_neutral_params(template, fitted)
        return fitted

    def save(self, key: str | None, fitted, caught: list, seconds: float) -> None:
        """Store ``fitted`` (with the warnings its fit raised and its wall seconds) under ``key``."""
        if key is None or self.folder is None:
            return
        entry = {"estimator": fitted, "warnings": caught, "seconds": float(seconds)}
        atomic_write(self._path(self.folder, key), lambda p: p.write_bytes(pickle.dumps(entry, protocol=5)))


def resolve_store(memory=None) -> FitStore:
    """The fit store of a ``memory`` parameter.

    Parameters
    ----------
    memory : None, False, str, Path or joblib.Memory
        ``None``: ``$TZSL_CACHE_DIR/fits`` when that variable is set (non-empty), else no store.
        ``False``: no store.
        A folder: ``folder/fits``. A ``joblib.Memory``: ``fits`` beside its location (none if
        it has no location).

    Returns
    -------
    FitStore
    """
    if memory is False:
        location = None
    elif isinstance(memory, joblib.Memory):
        location = memory.location
    elif memory is None:
        location = env_cache_dir()
    elif isinstance(memory, (str, os.PathLike)):
        location = os.fspath(memory)
    else:
        raise ConfigError(f"memory must be None, False, a folder path or a joblib.Memory, got {type(memory).__name__}")
    return FitStore(None if location is None else Path(location).expanduser() / FITS_FOLDER)


def _replay(caught: list) -> None:
    for category, message, filename, lineno in caught:
        warnings.warn_explicit(message, category, filename, lineno)


def _copy_neutral_params(template, fitted) -> None:
    neutral = {k: v for k, v in template.get_params(deep=True).items() if k.rsplit("__", 1)[-1] in NEUTRAL_PARAMS}
    if neutral:
        fitted.set_params(**neutral)


def fit_clone(estimator, *args):
    """Fit a clone of ``estimator`` on ``args`` (``X, y`` or ``X, y, groups``) and return it."""
    return clone(estimator).fit(*args)


def fit_recorded(estimator, *args) -> tuple[object, list, float]:
    """:func:`fit_clone` recording the fit's warnings (re-raised after) and wall seconds."""
    start = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        fitted = fit_clone(estimator, *args)
    seconds = time.perf_counter() - start
    records = [(w.category, str(w.message), w.filename, w.lineno) for w in caught]
    _replay(records)
    return fitted, records, seconds


def stored_fit(store: FitStore, key: str | None, template):
    """The stored fit of ``key`` or None, counting the event (``hit``, ``miss``, ``unstorable``,
    ``repeat``) for this process and the run's profile. ``template``: the estimator asked for."""
    if key is None:
        count_fits("unstorable")
        return None
    if key in _SEEN:
        count_fits("repeat")
    _SEEN.add(key)
    fitted = store.load(key, template)
    count_fits("hit" if fitted is not None else "miss")
    return fitted


@timed("fit")
def fit_cached(estimator, *args, store: FitStore | None = None):
    """A fitted clone of ``estimator`` on ``args``, read from the fit store when it holds it.

    Parameters
    ----------
    estimator : estimator
        Left unfitted.
    *args : array-like
        What ``fit`` takes: ``X, y`` or ``X, y, groups``.
    store : FitStore, optional
        Default :func:`resolve_store` ``(None)`` (``$TZSL_CACHE_DIR``).

    Returns
    -------
    estimator
        The same fit as ``clone(estimator).fit(*args)``: computed and stored on a miss, read
        back on a hit.
    """
    store = resolve_store(None) if store is None else store
    if not store.enabled:
        count_fits("off")
        return fit_clone(estimator, *args)
    key = store.key(estimator, *(array_digest(a) for a in args))
    fitted = stored_fit(store, key, estimator)
    if fitted is not None:
        return fitted
    fitted, caught, seconds = fit_recorded(estimator, *args)
    store.save(key, fitted, caught, seconds)
    return fitted


def spawn_seeds(random_state, n: int) -> list[int]:
    """``n`` independent integer seeds derived deterministically from ``random_state``.

    Parameters
    ----------
    random_state : int, RandomState or None
        ``None`` draws fresh entropy (non-reproducible), as scikit-learn does.
    n : int

    Returns
    -------
    list of int
        Seeds in [0, 2**31 - 1), from ``np.random.SeedSequence(entropy).spawn(n)``.
    """
    if random_state is None:
        entropy = None
    elif isinstance(random_state, (int, np.integer)):
        entropy = int(random_state)
    else:
        entropy = int(check_random_state(random_state).randint(np.iinfo(np.int32).max))
    children = np.random.SeedSequence(entropy).spawn(n)
    return [int(c.generate_state(1, dtype=np.uint32)[0] >> 1) for c in children]


def parallel_context(backend: str):
    """Context manager selecting the joblib backend; ``"dask"`` needs a running Client.

    Raises
    ------
    ConfigError
        Unknown backend, or ``"dask"`` without a ``dask.distributed.Client``.
    """
    if backend not in JOBLIB_BACKENDS:
        raise ConfigError(f"backend must be one of {JOBLIB_BACKENDS}, got {backend!r}")
    if backend == "dask":
        try:
            from distributed import get_client  # noqa: PLC0415  # optional: the dask extra
        except ImportError as exc:  # pragma: no cover - optional dependency
            raise ConfigError("backend='dask' needs the 'dask[distributed]' package") from exc
        try:
            get_client()
        except ValueError as exc:
            raise ConfigError(
                "backend='dask' needs a running dask.distributed Client: create one first, e.g. "
                "Client('tcp://scheduler:8786') or Client(LocalCluster())"
            ) from exc
        return joblib.parallel_backend("dask")
    if backend == "loky":
        return nullcontext()
    return joblib.parallel_backend(backend)
