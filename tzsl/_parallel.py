"""Warnings raised in joblib workers, relayed to the parent process; one BLAS thread for small problems.

A loky worker is another process: a warning it raises is printed by that process (with its source
path) and never reaches the command line's one-line printer or the run's manifest
(:mod:`tzsl._warnings`). Wrap the job's function with :func:`relayed` and pass each result
through :func:`reissued`: the worker records its warnings and returns them beside its result,
and the parent raises them again, so they are shown and recorded like any other.
"""

from __future__ import annotations

import contextlib
import threading
import warnings
from collections.abc import Callable, Iterator
from typing import Any

__all__ = ["one_blas_thread", "reissued", "relayed"]

_CONTROLLER: list = []  # this process's threadpoolctl.ThreadpoolController, made at the first use
_CONTROLLER_LOCK = threading.Lock()


class _Relayed:
    """Picklable wrapper: calls ``func`` and returns ``(result, [(category, message), ...])``."""

    def __init__(self, func: Callable[..., Any]) -> None:
        self.func = func

    def __call__(self, *args: Any, **kwargs: Any) -> tuple[Any, list[tuple[type[Warning], str]]]:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("default")  # each distinct warning once per job, as Python shows them
            result = self.func(*args, **kwargs)
        return result, [(w.category, str(w.message)) for w in caught]


def relayed(func: Callable[..., Any]) -> Callable[..., tuple[Any, list[tuple[type[Warning], str]]]]:
    """``func`` made to return its warnings beside its result (for a process-based joblib job;
    not for thread-based jobs, whose warnings already reach the parent)."""
    return _Relayed(func)


def reissued(item: tuple[Any, list[tuple[type[Warning], str]]]) -> Any:
    """The result of a :func:`relayed` job, after raising its warnings again in this process."""
    result, caught = item
    for category, message in caught:
        warnings.warn(message, category, stacklevel=2)
    return result


@contextlib.contextmanager
def one_blas_thread() -> Iterator[None]:
    """Run the block with one BLAS thread (``threadpool_limits(limits=1)``), at a fraction of its cost.

    For the many small dense problems of the attribute fits and predictions: there a second BLAS thread
    only spins, and on a busy machine it spent three times the CPU of one (PHAC-2 posteriors); the
    numbers are the same. ``threadpoolctl.threadpool_limits`` looks up the process's BLAS libraries
    every time; the controller that lists them is made once per process, at the first
    use (after numpy and scipy have loaded theirs), and only its limit is set and restored per block.
    """
    with _CONTROLLER_LOCK:
        if not _CONTROLLER:
            from threadpoolctl import ThreadpoolController  # noqa: PLC0415

            _CONTROLLER.append(ThreadpoolController())
    with _CONTROLLER[0].limit(limits=1):
        yield
