"""``make bench``: ``tzsl reproduce-tables`` cold and warm, per study and stage, against issue 22's numbers.

Runs ``tzsl reproduce-tables`` twice in a child process, into a temporary results folder:

* **cold**: with ``TZSL_CACHE_DIR`` set to a new, empty temporary folder (no fitted model, no
  extracted feature in any cache);
* **warm**: the same command again, with the cache the cold run filled: every study is restored
  from the study cache (:mod:`tzsl.studies.study_cache`); with ``TZSL_STUDY_CACHE=0`` in the
  environment only the fit store is warm.

For each run it prints (and writes as one CSV, atomically) the run's wall time as the user sees
it (process start to exit), the CPU seconds of the run and its workers (``getrusage`` of the
reaped children), every study's wall time and its stages (``load``, ``fit``, ``bootstrap``, ...)
from the run's own profile in ``manifest.json`` (key ``profile``, see :mod:`tzsl._profile`),
and the ratio to the reference numbers of issue 22 (:data:`REFERENCE_S`) and to its goal
(:data:`GOAL_S`). This is a benchmark, not a test: the numbers depend on the machine and its
load (the 1-minute load average before each run is printed and written).

Run::

    python -m tzsl.benchmarks.bench_reproduce --n-jobs 2 --out bench/reproduce_bench.csv
    python -m tzsl.benchmarks.bench_reproduce --study hand-simulated   # one study only
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from tzsl.benchmarks._common import add_output_options, benchmark_main, timed_process
from tzsl.datasets import CACHE_DIR_ENV
from tzsl.studies.reproduce import REPRODUCE_STUDIES

__all__ = ["BENCH_COLUMNS", "GOAL_S", "REFERENCE_S", "bench_table", "main", "run_reproduce"]

#: The wall seconds issue 22 ("Speed of the whole") reports for ``make reproduce-tables`` on a fresh
#: clone of main on 2 cores (shared machine; cold: a new ``TZSL_CACHE_DIR``), as the issue states them:
#: the whole command cold and warm, and each study cold. Keyed (study, run); ``"total"`` is the command.
REFERENCE_S: dict[tuple[str, str], float] = {
    ("total", "cold"): 184.0,
    ("total", "warm"): 90.0,
    ("phac2-dap", "cold"): 91.0,
    ("fabric", "cold"): 114.0,
    ("hand-simulated", "cold"): 30.0,
    ("active-touch", "cold"): 86.0,
}
#: Issue 22's goal for the whole command on 2 cores, cold and warm (everything cached), in seconds.
GOAL_S: dict[str, float] = {"cold": 60.0, "warm": 10.0}
#: Columns of the bench CSV, one row per (run, study, stage); stage ``"total"`` is the study's (or,
#: for study ``"total"``, the command's) wall time.
BENCH_COLUMNS = ("run", "study", "stage", "wall_s", "cpu_s", "reference_s", "ratio_to_reference", "goal_s",
                 "n_jobs", "load_1min")

_CLI = "from tzsl.cli import main; main()"


def run_reproduce(out: Path, cache_dir: Path, *, studies: Sequence[str] = (), n_jobs: int = 2,
                  data_dir: str | None = None, log: Path | None = None) -> tuple[float, float, dict]:
    """Run ``tzsl reproduce-tables`` once in a child process with ``TZSL_CACHE_DIR=cache_dir``.

    Parameters
    ----------
    out : Path
        Results folder (replaced: ``--force``).
    cache_dir : Path
        The run's cache folder (an empty one for a cold run).
    studies : sequence of str
        ``--study`` values (built-in names or experiment files); empty: every study of the command.
    n_jobs : int
    data_dir : str, optional
        ``--data-dir``; default the environment's ``TZSL_DATA_DIR``.
    log : Path, optional
        Where the child's output goes (default: discarded unless the run fails).

    Returns
    -------
    wall_s : float
        Seconds from process start to exit.
    cpu_s : float
        User + system CPU seconds of the child and its workers.
    manifest : dict
        The run's ``manifest.json``.

    Raises
    ------
    RuntimeError
        The command failed (the message ends with its last output lines).
    """
    cmd = [sys.executable, "-c", _CLI, "reproduce-tables", "--out", str(out), "--n-jobs", str(n_jobs),
           "--force", "--no-progress"]
    cmd += [arg for study in studies for arg in ("--study", str(study))]
    if data_dir is not None:
        cmd += ["--data-dir", str(data_dir)]
    env = {**os.environ, CACHE_DIR_ENV: str(cache_dir)}
    wall, cpu, done = timed_process(cmd, env=env, merge_stderr=True)
    if log is not None:
        log.write_text(done.stdout, encoding="utf-8")
    if done.returncode != 0:
        tail = "\n".join(done.stdout.splitlines()[-20:])
        raise RuntimeError(f"tzsl reproduce-tables failed (exit {done.returncode}):\n{tail}")
    return wall, cpu, json.loads((Path(out) / "manifest.json").read_text(encoding="utf-8"))


def _reference(study: str, run: str) -> float:
    return REFERENCE_S.get((study, run), float("nan"))


def bench_table(runs: dict[str, tuple[float, float, dict]], n_jobs: int, loads: dict[str, float]) -> pd.DataFrame:
    """The bench CSV (:data:`BENCH_COLUMNS`) of the runs ``{"cold": (wall_s, cpu_s, manifest), "warm": ...}``.

    One ``total`` row per run (the command; reference and goal only when it ran every study of
    :data:`~tzsl.studies.reproduce.REPRODUCE_STUDIES`), one ``total`` row per study
    (``timings_s`` of the manifest) with the reference where issue 22 has one, then the study's
    stages (its profile).
    """
    rows = []
    for run, (wall, cpu, manifest) in runs.items():
        common = {"run": run, "n_jobs": n_jobs, "load_1min": loads.get(run, float("nan"))}
        every = list(manifest.get("reproduce_studies", [])) == list(REPRODUCE_STUDIES)  # the command
        rows.append({**common, "study": "total", "stage": "total", "wall_s": wall, "cpu_s": cpu,
                     "reference_s": _reference("total", run) if every else float("nan"),
                     "goal_s": GOAL_S.get(run, float("nan")) if every else float("nan")})
        profile = pd.DataFrame(manifest.get("profile", []), columns=["study", "stage", "wall_s", "cpu_s", "calls"])
        for study in manifest.get("reproduce_studies", []):
            rows.append({**common, "study": study, "stage": "total",
                         "wall_s": float(manifest["timings_s"][f"{study}_s"]), "cpu_s": float("nan"),
                         "reference_s": _reference(study, run), "goal_s": float("nan")})
            for r in profile[profile["study"] == study].itertuples(index=False):
                rows.append({**common, "study": study, "stage": r.stage, "wall_s": float(r.wall_s),
                             "cpu_s": float(r.cpu_s), "reference_s": float("nan"), "goal_s": float("nan")})
    table = pd.DataFrame(rows)
    table["ratio_to_reference"] = table["wall_s"] / table["reference_s"]
    return table[list(BENCH_COLUMNS)]


def summary_lines(table: pd.DataFrame) -> list[str]:
    """People's view of :func:`bench_table`: per study cold / warm seconds and ratios, then the stages."""
    totals = table[table["stage"] == "total"].pivot(index="study", columns="run", values="wall_s")
    refs = table[table["stage"] == "total"].pivot(index="study", columns="run", values="reference_s")
    order = ["total"] + [s for s in dict.fromkeys(table["study"]) if s != "total"]
    runs = [r for r in ("cold", "warm") if r in totals.columns]
    head = f"{'study':<16}" + "".join(f" {run + ' s':>9} {'ref s':>7} {'x ref':>6}" for run in runs)
    lines = [head]
    for study in order:
        cells = ""
        for run in runs:
            wall, ref = totals.at[study, run], refs.at[study, run]
            cells += f" {wall:>9.1f} {ref:>7.0f} {wall / ref:>6.2f}" if np.isfinite(ref) else f" {wall:>9.1f} {'-':>7} {'-':>6}"
        lines.append(f"{study:<16}{cells}")
    goals = table[(table["study"] == "total") & table["goal_s"].notna()]
    for run, wall, goal in zip(goals["run"], goals["wall_s"], goals["goal_s"], strict=True):
        lines.append(f"goal ({run}): under {goal:.0f} s -> {'met' if wall < goal else 'not met'} "
                     f"({wall:.1f} s, {wall / goal:.2f}x the goal)")
    stages = table[(table["stage"] != "total")].pivot_table(index=["study", "stage"], columns="run", values="wall_s",
                                                              sort=False)
    lines += ["", "stages (exclusive wall seconds, from each run's manifest profile)",
              f"{'study':<16} {'stage':<10}" + "".join(f" {run + ' s':>9}" for run in runs)]
    for (study, stage), row in stages.iterrows():
        lines.append(f"{study:<16} {stage:<10}" + "".join(f" {row.get(run, float('nan')):>9.1f}" for run in runs))
    return lines


def run_bench(*, studies: Sequence[str] = (), n_jobs: int = 2, data_dir: str | None = None,
              keep: Path | None = None, echo=print) -> pd.DataFrame:
    """Cold then warm ``tzsl reproduce-tables`` in a temporary folder; the table of :func:`bench_table`.

    ``keep``: also keep the results folders, logs and cache there (default: all removed).
    """
    with tempfile.TemporaryDirectory(prefix="tzsl-bench-") as tmp:
        work = Path(keep) if keep is not None else Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        cache = work / "cache"
        if cache.exists() and any(cache.iterdir()):
            raise RuntimeError(f"{cache} is not empty: a cold run needs an empty cache folder")
        cache.mkdir(exist_ok=True)
        runs, loads = {}, {}
        for run in ("cold", "warm"):
            loads[run] = os.getloadavg()[0]
            echo(f"{run} run (TZSL_CACHE_DIR={cache}, n_jobs={n_jobs}, load average {loads[run]:.2f}) ...")
            runs[run] = run_reproduce(work / f"results_{run}", cache, studies=studies, n_jobs=n_jobs,
                                      data_dir=data_dir, log=work / f"{run}.log")
            echo(f"  {runs[run][0]:.1f} s wall, {runs[run][1]:.1f} s CPU")
    return bench_table(runs, n_jobs, loads)


def main(argv: list[str] | None = None) -> pd.DataFrame:
    """Command line of ``make bench`` (``--help``)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--study", action="append", default=[], metavar="NAME",
                        help=f"only this study (repeatable; default: all of {', '.join(REPRODUCE_STUDIES)})")
    parser.add_argument("--n-jobs", type=int, default=2)
    parser.add_argument("--data-dir", default=None, help="data home (default: $TZSL_DATA_DIR)")
    add_output_options(parser)
    parser.add_argument("--keep", type=Path, default=None,
                        help="keep the results folders, logs and cache in this folder (default: a temporary one)")
    args = parser.parse_args(argv)
    return benchmark_main(parser, args, "bench_reproduce", lambda echo: run_bench(
        studies=args.study, n_jobs=args.n_jobs, data_dir=args.data_dir, keep=args.keep, echo=echo), summary_lines)


if __name__ == "__main__":
    main()
