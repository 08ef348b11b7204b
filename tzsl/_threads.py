"""One BLAS / OpenMP thread for a block of many small dense problems, at the cost of an attribute look-up.

tzsl fits many small models (an attribute classifier per attribute and sensor, its CV folds, the
calibration folds, ESZSL's and SAE's closed forms). Threaded BLAS does not speed these up: on 2
cores OpenBLAS spends many times the CPU of one thread on them (the SVD of ESZSL's closed form
most of all), its extra threads spinning; with one thread the results no longer depend on the
machine's cores either (docs/user_guide/performance.md, one BLAS thread).

``threadpoolctl.threadpool_limits`` finds the loaded BLAS and OpenMP libraries every time it is
entered, which costs more than a small fit's arithmetic; :func:`one_blas_thread` finds them once per
process, at its first use, and then only sets and restores their thread counts. A library loaded
after that first use (e.g. torch's) is not limited by it: blocks that may load one use
``threadpool_limits``.
"""

from __future__ import annotations

import contextlib
import threading
from collections.abc import Iterator

from threadpoolctl import ThreadpoolController

__all__ = ["one_blas_thread"]

_LOCK = threading.Lock()
_CONTROLLER: list[ThreadpoolController] = []  # found once per process, at the first use


def _controller() -> ThreadpoolController:
    with _LOCK:
        if not _CONTROLLER:
            _CONTROLLER.append(ThreadpoolController())
        return _CONTROLLER[0]


@contextlib.contextmanager
def one_blas_thread() -> Iterator[None]:
    """Run the block with one thread in every BLAS / OpenMP library loaded at this function's first use."""
    with _controller().limit(limits=1):
        yield
