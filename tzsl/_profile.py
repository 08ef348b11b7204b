"""Where a run's time goes: wall and CPU seconds per (study, stage), recorded by the run itself.

Code marks its stages with ``with stage("fit"): ...`` (load, features, simulate, splits, fit,
predict, tables, sweep, bootstrap, figures, write; docs/user_guide/performance.md); a run wraps each
study in ``with profiling("phac2-dap") as profile:`` and records ``profile.rows()`` in its manifest.
Time is counted once: a stage opened inside another pauses it (so a bootstrap inside table building
counts as bootstrap), and what no stage claims is ``other``. Outside :func:`profiling` a stage costs
one attribute look-up. CPU seconds are this process's (:func:`time.process_time`); work in joblib
worker processes shows as wall time of the stage that waits for it.
"""

from __future__ import annotations

import contextlib
import functools
import threading
import time
from collections.abc import Iterator

__all__ = ["Profile", "count", "profile_lines", "profiling", "stage", "timed"]

_STATE = threading.local()


class Profile:
    """Exclusive wall / CPU seconds and call counts per stage of one study."""

    def __init__(self, study: str) -> None:
        self.study = study
        self.totals: dict[str, list[float]] = {}  # stage -> [wall s, cpu s, calls]
        self._stack: list[list] = []  # [stage, wall start, cpu start]

    def _charge(self, name: str, wall: float, cpu: float, calls: int = 0) -> None:
        entry = self.totals.setdefault(name, [0.0, 0.0, 0])
        entry[0] += wall
        entry[1] += cpu
        entry[2] += calls

    def _enter(self, name: str) -> None:
        now, cpu = time.perf_counter(), time.process_time()
        if self._stack:  # pause the enclosing stage
            top = self._stack[-1]
            self._charge(top[0], now - top[1], cpu - top[2])
        self._stack.append([name, now, cpu])

    def _exit(self) -> None:
        now, cpu = time.perf_counter(), time.process_time()
        name, wall0, cpu0 = self._stack.pop()
        self._charge(name, now - wall0, cpu - cpu0, 1)
        if self._stack:  # resume the enclosing stage
            self._stack[-1][1:] = [now, cpu]

    def rows(self) -> list[dict]:
        """``[{"study", "stage", "wall_s", "cpu_s", "calls"}, ...]``, longest wall time first."""
        return [{"study": self.study, "stage": name, "wall_s": round(v[0], 3), "cpu_s": round(v[1], 3),
                 "calls": int(v[2])} for name, v in sorted(self.totals.items(), key=lambda kv: -kv[1][0])]


@contextlib.contextmanager
def profiling(study: str) -> Iterator[Profile]:
    """Profile the block as study ``study``; what no :func:`stage` claims is ``other``."""
    profile = Profile(study)
    previous = getattr(_STATE, "profile", None)
    _STATE.profile = profile
    profile._enter("other")
    try:
        yield profile
    finally:
        while profile._stack:
            profile._exit()
        profile.totals["other"][2] = 0
        _STATE.profile = previous


@contextlib.contextmanager
def stage(name: str) -> Iterator[None]:
    """Count the block's time as stage ``name`` of the study being profiled (if any)."""
    profile = getattr(_STATE, "profile", None)
    if profile is None:
        yield
        return
    profile._enter(name)
    try:
        yield
    finally:
        profile._exit()


def timed(name: str):
    """Decorator: every call of the function is stage ``name`` (see :func:`stage`)."""
    def wrap(func):
        @functools.wraps(func)
        def inner(*args, **kwargs):
            with stage(name):
                return func(*args, **kwargs)
        return inner
    return wrap


def count(name: str, n: int = 1) -> None:
    """Add ``n`` events ``name`` (e.g. ``fit_store.hit``) to the study being profiled, if any: a row
    of :meth:`Profile.rows` with no time and ``calls`` = the count."""
    profile = getattr(_STATE, "profile", None)
    if profile is not None:
        profile._charge(name, 0.0, 0.0, int(n))


def profile_lines(rows: list[dict]) -> list[str]:
    """The rows of :meth:`Profile.rows` (one or several studies) as an aligned table for people."""
    lines = [f"{'study':<16} {'stage':<10} {'wall s':>8} {'cpu s':>8} {'calls':>6}"]
    lines += [f"{r['study']:<16} {r['stage']:<10} {r['wall_s']:>8.1f} {r['cpu_s']:>8.1f} {r['calls']:>6}" for r in rows]
    return lines
