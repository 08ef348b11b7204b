"""What the shipped benchmarks share: timing a child process, the rows of ``make bench``'s table, and the
command line's output handling."""

from __future__ import annotations

import argparse
import json
import numbers
import os
import resource
import statistics
import subprocess
import sys
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import TypedDict

import pandas as pd

__all__ = ["MEASURE_COLUMNS", "MeasureOptions", "add_output_options", "benchmark_main", "cold_and_warm",
           "manifest_rows", "measurement", "run_tzsl", "timed_process"]

#: Columns of one measurement of ``make bench`` (:mod:`tzsl.benchmarks.bench_goals` adds the goal columns):
#: ``part`` (``--only``), ``study``, ``stage`` (``total``: the whole study or, for study ``total``,
#: the whole process), ``run`` (``cold``, ``warm`` or ``api``), ``quantity`` (``wall``, ``cpu``,
#: ``per_grasp``, ``count``, ``ratio_to_split_fit``), ``unit``, ``value`` (the median of ``n``
#: repeats, with ``min`` and ``max``), ``simulated`` (True: measured on SIMULATED data), the run's
#: ``n_jobs``, the 1-minute load average before it and a ``note``.
MEASURE_COLUMNS = ("part", "study", "stage", "run", "quantity", "unit", "value", "min", "max", "n", "simulated",
                   "n_jobs", "load_1min", "note")

_CLI = "import sys; from tzsl.cli import main; main(sys.argv[1:])"


class MeasureOptions(TypedDict, total=False):
    """The keywords of :func:`measurement` that several of its rows share (passed as ``**common``)."""

    simulated: bool
    n_jobs: int | None
    load: float | None
    note: str


def timed_process(cmd: Sequence[str], *, env: Mapping[str, str] | None = None,
                  merge_stderr: bool = False) -> tuple[float, float, subprocess.CompletedProcess]:
    """Run ``cmd`` in a new process: its wall seconds, its CPU seconds (its own and its children's,
    from ``getrusage`` of the children) and the finished process (text output captured; stderr merged
    into stdout when ``merge_stderr``)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    done = subprocess.run(list(cmd), env=None if env is None else dict(env), stdout=subprocess.PIPE,
                          stderr=subprocess.STDOUT if merge_stderr else subprocess.PIPE, text=True, check=False)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime), done


def run_tzsl(args: Sequence[object], *, cache_dir: Path | None = None, log: Path | None = None,
             code: str = _CLI) -> tuple[float, float, str]:
    """Wall and CPU seconds of ``tzsl ARGS`` in a new process, and its output (stdout, stderr merged).

    Parameters
    ----------
    args : sequence
        The command line after ``tzsl`` (turned into strings).
    cache_dir : Path, optional
        ``TZSL_CACHE_DIR`` of the process (default: this process's environment).
    log : Path, optional
        Where the output also goes.
    code : str
        The Python code the process runs (default: ``tzsl``'s command line on ``sys.argv[1:]``).

    Raises
    ------
    RuntimeError
        The command failed (the message ends with its last output lines).
    """
    from tzsl.cache import CACHE_DIR_ENV  # noqa: PLC0415

    env = None if cache_dir is None else {**os.environ, CACHE_DIR_ENV: str(cache_dir)}
    wall, cpu, done = timed_process([sys.executable, "-c", code, *map(str, args)], env=env, merge_stderr=True)
    if log is not None:
        log.write_text(done.stdout, encoding="utf-8")
    if done.returncode != 0:
        tail = "\n".join(done.stdout.splitlines()[-20:])
        raise RuntimeError(f"tzsl {' '.join(map(str, args))} failed (exit {done.returncode}):\n{tail}")
    return wall, cpu, done.stdout


def measurement(part: str, study: str, stage: str, run: str, quantity: str, unit: str,
                values: float | Sequence[float], *, simulated: bool = False, n_jobs: int | None = None,
                load: float | None = None, note: str = "") -> dict:
    """One row of :data:`MEASURE_COLUMNS`; ``values``: one number, or repeats (their median, min and max).

    ``load``: the 1-minute load average before the measure (default: now).
    """
    # float named too (a no-op at run time): mypy does not see float as a numbers.Real, so would not narrow
    values = [float(values)] if isinstance(values, (float, numbers.Real)) else [float(v) for v in values]
    return {"part": part, "study": study, "stage": stage, "run": run, "quantity": quantity, "unit": unit,
            "value": statistics.median(values), "min": min(values), "max": max(values), "n": len(values),
            "simulated": bool(simulated), "n_jobs": n_jobs, "load_1min": os.getloadavg()[0] if load is None else load,
            "note": note}


def _simulated(record: Mapping) -> bool:
    """Whether a manifest's study record ran on a built-in dataset that tzsl simulates."""
    from tzsl.datasets import dataset_names, get_dataset  # noqa: PLC0415

    builtin = (record.get("settings") or {}).get("dataset", {}).get("builtin")
    # a registered dataset says whether it is simulated; the fabric study's builtin names a registry folder
    # of real recordings ("fabric"), not a registered dataset
    return builtin in dataset_names() and bool(get_dataset(builtin).simulated)


def manifest_rows(manifest: Mapping, **common) -> list[dict]:
    """A results folder's ``manifest.json`` as measurements: per study its wall time (when the
    manifest has it: study lists' ``timings_s``), then each stage of its profile (exclusive wall
    and CPU seconds; an event counter such as ``fit_store.hit`` as a ``count``).

    ``common``: :func:`measurement`'s ``part``, ``run`` and keywords; ``simulated`` is also set
    for the studies of a simulated built-in dataset. Reads both the manifest of a study list
    (``reproduce-tables``, ``evidence``: ``reproduce_studies``, ``timings_s``, ``profile``) and that
    of ``tzsl run`` (one study: ``config.profile``).
    """
    config = manifest.get("config") or {}
    records = config.get("studies") or {config.get("study", ""): config}
    profile = pd.DataFrame(manifest.get("profile") or config.get("profile") or [],
                           columns=["study", "stage", "wall_s", "cpu_s", "calls"])
    timings = manifest.get("timings_s") or {}
    part, run = common.pop("part"), common.pop("run")
    rows = []
    for study in dict.fromkeys(profile["study"]):
        record = records.get(study, {})
        keywords = {**common, "simulated": common.get("simulated", False) or _simulated(record)}
        if f"{study}_s" in timings:
            rows.append(measurement(part, study, "total", run, "wall", "s", timings[f"{study}_s"], **keywords))
        for r in profile[profile["study"] == study].itertuples(index=False):
            if r.wall_s == 0 and r.cpu_s == 0 and r.calls > 0:  # an event counter, not a timed stage
                rows.append(measurement(part, study, r.stage, run, "count", "events", r.calls, **keywords))
                continue
            rows.append(measurement(part, study, r.stage, run, "wall", "s", r.wall_s, **keywords))
            rows.append(measurement(part, study, r.stage, run, "cpu", "s", r.cpu_s, **keywords))
    return rows


def cold_and_warm(part: str, args: Sequence[object], work: Path, *, n_jobs: int, simulated: bool = False,
                  echo: Callable[[str], None] = print) -> list[dict]:
    """Time ``tzsl ARGS --out FOLDER --n-jobs N --force --no-progress`` twice, cold then warm.

    The cold run has ``TZSL_CACHE_DIR`` set to a new, empty folder ``work/<part>-cache`` (no fitted
    model, no extracted feature, no finished study in any cache); the warm run is the same
    command again with the cache the cold run filled. Each run's results go to
    ``work/<part>-<run>/`` and its output to ``work/<part>-<run>.log``.

    Returns
    -------
    list of dict
        Per run: the process's wall and CPU seconds (study ``total``, stage ``total``), then
        :func:`manifest_rows` of its manifest.

    Raises
    ------
    RuntimeError
        The cache folder is not empty, or a run failed.
    """
    cache = work / f"{part}-cache"
    if cache.exists() and any(cache.iterdir()):
        raise RuntimeError(f"{cache} is not empty: a cold run needs an empty cache folder")
    cache.mkdir(parents=True, exist_ok=True)
    rows = []
    for run in ("cold", "warm"):
        out = work / f"{part}-{run}"
        load = os.getloadavg()[0]
        echo(f"{part}, {run} run (TZSL_CACHE_DIR={cache}, n_jobs={n_jobs}, load average {load:.2f}) ...")
        wall, cpu, _ = run_tzsl([*args, "--out", out, "--n-jobs", n_jobs, "--force", "--no-progress"],
                                cache_dir=cache, log=work / f"{part}-{run}.log")
        echo(f"  {wall:.1f} s wall, {cpu:.1f} s CPU" + (" (SIMULATED data)" if simulated else ""))
        common: MeasureOptions = {"simulated": simulated, "n_jobs": n_jobs, "load": load}
        rows.append(measurement(part, "total", "total", run, "wall", "s", wall, **common))
        rows.append(measurement(part, "total", "total", run, "cpu", "s", cpu, **common))
        manifest = json.loads((out / "manifest.json").read_text(encoding="utf-8"))
        rows += manifest_rows(manifest, part=part, run=run, **common)
    return rows


def add_output_options(parser: argparse.ArgumentParser) -> None:
    """``--out`` (the table as CSV) and ``--force`` (overwrite it)."""
    parser.add_argument("--out", type=Path, default=None, help="also write the table as CSV here")
    parser.add_argument("--force", action="store_true", help="overwrite --out")


def benchmark_main(parser: argparse.ArgumentParser, args: argparse.Namespace, name: str,
                   run: Callable[[Callable[[str], None]], pd.DataFrame],
                   summary_lines: Callable[[pd.DataFrame], list[str]]) -> pd.DataFrame:
    """Refuse an existing ``--out`` without ``--force``, print the machine's load, ``run(echo)``, print
    its summary and write the table atomically to ``--out``. A run that fails (a command it times
    failed, a file it needs is missing) ends with ``NAME: error: ...`` and exit code 3, no table."""
    if args.out is not None and args.out.exists() and not args.force:
        parser.exit(2, f"{name}: error: {args.out} already exists; use --force to overwrite\n")
    print(f"{os.cpu_count()} cores; load average before: {os.getloadavg()}", flush=True)
    try:
        table = run(lambda line: print(line, flush=True))
    except (RuntimeError, FileNotFoundError) as exc:
        parser.exit(3, f"{name}: error: {exc}\n")
    print("\n" + "\n".join(summary_lines(table)))
    if args.out is not None:
        from tzsl._io import atomic_write  # noqa: PLC0415

        atomic_write(args.out, lambda p: table.to_csv(p, index=False))
        print(f"wrote {args.out}")
    return table
