"""``make bench``'s paper data: ``tzsl reproduce-tables`` (and ``tzsl evidence``) cold and warm, and one split's fits.

* :func:`run_study_list`: ``tzsl reproduce-tables`` (part ``reproduce``) or ``tzsl evidence``
  (part ``evidence``) twice in a child process (:func:`tzsl.benchmarks._common.cold_and_warm`):
  **cold** with ``TZSL_CACHE_DIR`` set to a new, empty folder, **warm** the same command again
  with the cache the cold run filled (every study is restored from the study cache,
  :mod:`tzsl.studies.outputs.study_cache`; with ``TZSL_STUDY_CACHE=0`` in the environment only the fit
  store is warm). Each run gives the command's wall and CPU seconds (process start to exit;
  ``getrusage`` of the reaped children), every study's wall time and its stages (the run's own
  profile in ``manifest.json``, see :mod:`tzsl._profile`).
* :func:`run_split_fit`: ``tzsl bench --skip-literal`` (``make bench-fit`` without the literal
  recipe) in a child process: one random PHAC-2 split's attribute fits on the paper's grid, with
  one job and with two, the unit every wall time of ``make bench`` is divided by
  (:func:`split_fit_seconds`).

This is a benchmark, not a test: the numbers depend on the machine and its load (the 1-minute
load average before each run is written beside it). The goals are in :mod:`tzsl.benchmarks.goals`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path

import pandas as pd

from tzsl.benchmarks._common import MeasureOptions, cold_and_warm, measurement, run_tzsl
from tzsl.studies.reproduce import STUDY_LISTS

__all__ = ["SPLIT_FIT_PART", "STUDY_LIST_PARTS", "run_split_fit", "run_study_list", "split_fit_seconds",
           "split_fit_stage"]

#: ``make bench`` part -> the study-list command it times.
STUDY_LIST_PARTS: dict[str, str] = {"reproduce": "reproduce-tables", "evidence": "evidence"}
#: The part of the bench table that holds one split's attribute fits.
SPLIT_FIT_PART = "split-fit"


def run_study_list(part: str, work: Path, *, studies: Sequence[str] = (), n_jobs: int = 2,
                   data_dir: str | None = None, echo: Callable[[str], None] = print) -> list[dict]:
    """Time ``tzsl reproduce-tables`` or ``tzsl evidence`` (``part``: a key of :data:`STUDY_LIST_PARTS`) cold and warm.

    Parameters
    ----------
    part : str
    work : Path
        Folder of the runs' results, logs and cache.
    studies : sequence of str
        ``--study`` values (built-in names or experiment files); empty: the command's own list.
        The whole command of a subset is study ``total (subset)``, so no goal is checked on it.
    n_jobs : int
    data_dir : str, optional
        ``--data-dir``; default the environment's ``TZSL_DATA_DIR``.
    echo : callable

    Returns
    -------
    list of dict
        Measurements (:data:`tzsl.benchmarks._common.MEASURE_COLUMNS`).
    """
    command = STUDY_LIST_PARTS[part]
    args = [command, *(arg for study in studies for arg in ("--study", study))]
    args += [] if data_dir is None else ["--data-dir", data_dir]
    rows = cold_and_warm(part, args, work, n_jobs=n_jobs, echo=echo)
    default = STUDY_LISTS[command][0]
    if studies and tuple(studies) != default:  # not the command: no goal on its total
        for row in rows:
            row["study"] = "total (subset)" if row["study"] == "total" else row["study"]
    return rows


def split_fit_stage(n_jobs: int) -> str:
    """The stage of :func:`run_split_fit`'s table that a run with ``n_jobs`` jobs is divided by: the
    fits with one job for ``n_jobs == 1``, else those with two (``tzsl bench`` times those two)."""
    return f"n_jobs={1 if n_jobs == 1 else 2}"


def run_split_fit(work: Path, *, n_jobs: int = 2, data_dir: str | None = None,
                  echo: Callable[[str], None] = print) -> list[dict]:
    """Time one random PHAC-2 split's attribute fits: ``tzsl bench --skip-literal`` in a child process.

    Returns
    -------
    list of dict
        Measurements of part :data:`SPLIT_FIT_PART`: the fits' wall seconds with one and with two
        jobs (stages ``n_jobs=1``, ``n_jobs=2``, as ``tzsl bench`` times them: the fits alone, the
        cache off) and the process's wall and CPU seconds (loading the features included).
    """
    out = work / "split_fit.csv"
    args = ["bench", "--skip-literal", "--out", out, "--force"] + ([] if data_dir is None else ["--data-dir", data_dir])
    echo("one PHAC-2 split's attribute fits (tzsl bench --skip-literal) ...")
    wall, cpu, _ = run_tzsl(args, log=work / "split_fit.log")
    common: MeasureOptions = {"n_jobs": n_jobs, "note": "tzsl bench --skip-literal"}
    rows = [measurement(SPLIT_FIT_PART, "total", "total", "cold", "wall", "s", wall, **common),
            measurement(SPLIT_FIT_PART, "total", "total", "cold", "cpu", "s", cpu, **common)]
    for r in pd.read_csv(out).itertuples(index=False):
        stage = str(r.method).removeprefix("tzsl ")  # "tzsl n_jobs=2" -> "n_jobs=2"
        rows.append(measurement(SPLIT_FIT_PART, str(r.split), stage, "cold", "wall", "s", float(r.seconds), **common))
        echo(f"  {stage}: {r.seconds:.1f} s")
    return rows


def split_fit_seconds(table: pd.DataFrame, n_jobs: int) -> float:
    """Wall seconds of one split's fits in ``table`` (rows of :func:`run_split_fit`) for a run with
    ``n_jobs`` jobs (:func:`split_fit_stage`); NaN when the table has none."""
    rows = table[(table["part"] == SPLIT_FIT_PART) & (table["stage"] == split_fit_stage(n_jobs))
                 & (table["quantity"] == "wall")]
    return float(rows["value"].iloc[0]) if len(rows) else float("nan")
