"""Caching and parallel-execution helpers shared by the attribute models."""

from __future__ import annotations

import os
from contextlib import nullcontext
from pathlib import Path

import joblib
import numpy as np
from sklearn.base import clone
from sklearn.utils import check_random_state

from tzsl.exceptions import ConfigError

__all__ = ["CACHE_ENV", "fit_clone", "parallel_context", "resolve_memory", "spawn_seeds"]

CACHE_ENV = "TZSL_CACHE_DIR"
_BACKENDS = ("loky", "dask", "threading", "multiprocessing", "sequential")


def resolve_memory(memory) -> joblib.Memory:
    """Turn a ``memory`` parameter into a :class:`joblib.Memory`.

    Parameters
    ----------
    memory : None, str, Path or joblib.Memory
        ``None``: cache under ``$TZSL_CACHE_DIR`` when that variable is set, else no caching.
        A path: cache there. A Memory: used as is.

    Returns
    -------
    joblib.Memory
        ``joblib.Memory(None)`` (a pass-through) when caching is off.
    """
    if isinstance(memory, joblib.Memory):
        return memory
    if memory is None:
        env = os.environ.get(CACHE_ENV)
        return joblib.Memory(env or None, verbose=0)
    if isinstance(memory, (str, Path)):
        return joblib.Memory(str(memory), verbose=0)
    raise ConfigError(f"memory must be None, a folder path or a joblib.Memory, got {type(memory).__name__}")


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


def fit_clone(estimator, X: np.ndarray, y: np.ndarray, groups: np.ndarray | None):
    """Fit a clone of ``estimator`` on ``(X, y, groups)`` and return it (the cached unit of work)."""
    return clone(estimator).fit(X, y, groups)


def parallel_context(backend: str):
    """Context manager selecting the joblib backend; ``"dask"`` needs a running Client.

    Raises
    ------
    ConfigError
        Unknown backend, or ``"dask"`` without a ``dask.distributed.Client``.
    """
    if backend not in _BACKENDS:
        raise ConfigError(f"backend must be one of {_BACKENDS}, got {backend!r}")
    if backend == "dask":
        try:
            from distributed import get_client
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
