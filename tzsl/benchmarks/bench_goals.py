"""``make bench``: every speed goal of issue 33 beside its measurement, cold and warm, per study and stage.

It times, each in child processes on this machine (``--only PART`` times one part; repeatable):

* ``reproduce``: ``tzsl reproduce-tables`` cold (an empty ``TZSL_CACHE_DIR``) and warm (the same
  command again), per study and stage (:mod:`tzsl.benchmarks.bench_reproduce`);
* ``template``: ``tzsl run`` of the generic study's template on a SIMULATED dataset of 41 objects,
  2,549 grasps and 3 fingers, cold and warm (:mod:`tzsl.benchmarks.bench_template`);
* ``predict``: ``tzsl predict`` of one grasp from a cold process and per grasp through
  :class:`tzsl.inference.Recogniser`, on SIMULATED data (:mod:`tzsl.benchmarks.bench_predict`);
* ``evidence`` (only when asked: tens of minutes): ``tzsl evidence`` cold and warm;

and, whenever a part of studies runs, one PHAC-2 split's attribute fits (``tzsl bench
--skip-literal``, part ``split-fit``), measured in the same run: every wall time of those parts is
also given as a ratio to them (quantity ``ratio_to_split_fit``), a unit that travels between
machines better than seconds.

Every goal of :data:`tzsl.benchmarks.goals.GOALS` is printed beside the measurement it is checked
on, met or not; a goal this run did not measure says which command does. The table
(:data:`BENCH_COLUMNS`, one row per measurement, goals attached) is written as one CSV,
atomically. Rows measured on SIMULATED data say so (column ``simulated``, and ``SIMULATED`` in the
printout). This is a benchmark, not a test: the numbers depend on the machine and its load.

Run::

    python -m tzsl.benchmarks.bench_goals --n-jobs 2 --out bench/bench.csv --force
    python -m tzsl.benchmarks.bench_goals --only predict --repeats 3      # one part
    python -m tzsl.benchmarks.bench_goals --only evidence --out bench/evidence_bench.csv
"""

from __future__ import annotations

import argparse
import math
import tempfile
from collections.abc import Callable, Sequence
from pathlib import Path

import pandas as pd

from tzsl.benchmarks._common import MEASURE_COLUMNS, add_output_options, benchmark_main
from tzsl.benchmarks.bench_predict import METHODS, run_predict
from tzsl.benchmarks.bench_reproduce import (
    SPLIT_FIT_PART,
    STUDY_LIST_PARTS,
    run_split_fit,
    run_study_list,
    split_fit_seconds,
    split_fit_stage,
)
from tzsl.benchmarks.bench_template import DEFAULT_TEMPLATE, run_template
from tzsl.benchmarks.goals import GOALS, PARTS

__all__ = ["BENCH_COLUMNS", "DEFAULT_PARTS", "attach_goals", "bench_table", "main", "run_bench", "summary_lines",
           "with_ratios"]

#: The parts ``make bench`` times without ``--only``.
DEFAULT_PARTS: tuple[str, ...] = ("reproduce", "template", "predict")
#: Columns of the bench CSV: a measurement (:data:`tzsl.benchmarks._common.MEASURE_COLUMNS`), then the
#: goal checked on it (name, limit, met), or for a goal this run did not measure a row of its own
#: with an empty ``value`` and the command that measures it in ``note``.
BENCH_COLUMNS = (*MEASURE_COLUMNS, "goal", "goal_limit", "meets_goal")
#: Parts whose wall times are also given over one split's attribute fits.
_RATIO_PARTS = ("reproduce", "template", "evidence")


def with_ratios(table: pd.DataFrame) -> pd.DataFrame:
    """Add a ``ratio_to_split_fit`` row (unit ``x``) after every wall-seconds row of a part of
    studies, dividing by the split fit of its ``n_jobs`` (:func:`split_fit_seconds`); none when
    the table holds no split fit."""
    rows = []
    for row in table.to_dict("records"):
        rows.append(row)
        if row["part"] in _RATIO_PARTS and row["quantity"] == "wall" and row["unit"] == "s":
            fit = split_fit_seconds(table, int(row["n_jobs"]))
            if math.isfinite(fit) and fit > 0:
                rows.append({**row, "quantity": "ratio_to_split_fit", "unit": "x", "value": row["value"] / fit,
                             "min": row["min"] / fit, "max": row["max"] / fit,
                             "note": f"over {SPLIT_FIT_PART} {split_fit_stage(int(row['n_jobs']))}"})
    return pd.DataFrame(rows, columns=list(MEASURE_COLUMNS))


def attach_goals(table: pd.DataFrame, parts: Sequence[str]) -> pd.DataFrame:
    """The measurements with the goal each is checked on, and a row per goal of :data:`GOALS` that
    ``table`` has no measurement for (its ``note`` says why and which command measures it).

    Raises
    ------
    ValueError
        Two goals match one measurement (the goal table is ambiguous).
    """
    rows, checked = [], set()
    for row in table.to_dict("records"):
        goals = [goal for goal in GOALS if goal.matches(row)]
        if len(goals) > 1:
            raise ValueError(f"goals {[g.name for g in goals]} all match one measurement: {row}")
        goal = goals[0] if goals else None
        if goal is not None:
            checked.add(goal.name)
        rows.append({**row, "goal": goal.name if goal else "", "goal_limit": goal.limit if goal else math.nan,
                     "meets_goal": bool(row["value"] <= goal.limit) if goal else None})
    for goal in GOALS:
        if goal.name in checked:
            continue
        why = (f"not measured here: {goal.measured_by}" if goal.measured_by != "make bench"
               else "not measured in this run" + ("" if goal.part in parts else f" (--only {goal.part})"))
        rows.append({"part": goal.part or "-", "study": goal.study or "", "stage": goal.stage or "",
                     "run": goal.run or "", "quantity": goal.quantity or "", "unit": goal.unit, "value": math.nan,
                     "min": math.nan, "max": math.nan, "n": 0, "simulated": False, "n_jobs": None,
                     "load_1min": math.nan, "note": why, "goal": goal.name, "goal_limit": goal.limit,
                     "meets_goal": None})
    result = pd.DataFrame(rows, columns=list(BENCH_COLUMNS))
    result["n_jobs"] = result["n_jobs"].astype("Int64")  # an integer column with blanks
    return result


def bench_table(rows: Sequence[dict], parts: Sequence[str]) -> pd.DataFrame:
    """The bench CSV (:data:`BENCH_COLUMNS`) of measurements: ratios added (:func:`with_ratios`),
    goals attached (:func:`attach_goals`)."""
    return attach_goals(with_ratios(pd.DataFrame(list(rows), columns=list(MEASURE_COLUMNS))), parts)


def _value(value: float, unit: str) -> str:
    return "-" if not math.isfinite(value) else f"{value:.4g} {unit}" if unit != "x" else f"{value:.2f}x"


def summary_lines(table: pd.DataFrame) -> list[str]:
    """People's view of :func:`bench_table`: every goal beside its measurement, then per part the
    measurements (studies and stages down, runs across)."""
    texts = {goal.name: goal.text for goal in GOALS}
    order = {goal.name: i for i, goal in enumerate(GOALS)}
    lines = ["goals (issue 33, on 2 cores)"]
    goal_rows = table[table["goal"] != ""]
    for r in goal_rows.iloc[goal_rows["goal"].map(order).argsort(kind="stable")].itertuples(index=False):
        target = f"<= {_value(r.goal_limit, r.unit)}"
        which = "" if r.study in ("total", "") else f" [{r.study}{'' if r.stage in ('predict', '') else ' ' + r.stage}]"
        simulated = " SIMULATED" if r.simulated else ""
        if r.meets_goal is None or (isinstance(r.meets_goal, float) and math.isnan(r.meets_goal)):
            outcome = f"{r.note}"
        else:
            outcome = f"{_value(r.value, r.unit)} -> {'met' if r.meets_goal else 'NOT MET'}"
        lines.append(f"  {texts[r.goal]}{which}{simulated}: goal {target}; {outcome}")
    measured = table[table["value"].notna()]
    for part in dict.fromkeys(measured["part"]):
        rows = measured[measured["part"] == part]
        runs = list(dict.fromkeys(rows["run"]))
        grid = rows.pivot_table(index=["study", "stage", "quantity", "unit", "simulated"], columns="run",
                                values="value", sort=False, aggfunc="first")
        lines += ["", f"{part}" + (" (SIMULATED data)" if rows["simulated"].all() else ""),
                  f"  {'study':<16} {'stage':<22} {'quantity':<19}" + "".join(f" {run:>10}" for run in runs)]
        for (study, stage, quantity, unit, simulated), values in grid.iterrows():
            cells = "".join(f" {_value(values.get(run, math.nan), unit):>10}" for run in runs)
            mark = "  SIMULATED" if simulated and not rows["simulated"].all() else ""
            lines.append(f"  {study:<16} {stage:<22} {quantity:<19}{cells}{mark}")
    return lines


def run_bench(parts: Sequence[str] = DEFAULT_PARTS, *, n_jobs: int = 2, data_dir: str | None = None,
              studies: Sequence[str] = (), template: Path = DEFAULT_TEMPLATE,
              methods: Sequence[str] = tuple(METHODS), repeats: int = 5, n_grasps: int = 200,
              keep: Path | None = None, echo: Callable[[str], None] = print) -> pd.DataFrame:
    """Time ``parts`` (of :data:`tzsl.benchmarks.goals.PARTS`) and one split's fits when a part of
    studies is among them; the table of :func:`bench_table`.

    ``studies``: ``--study`` values of the ``reproduce`` part; ``keep``: keep the results folders,
    logs and caches there (default: a temporary folder, removed).
    """
    unknown = [part for part in parts if part not in PARTS]
    if unknown:
        raise ValueError(f"unknown part(s) {unknown}; known: {list(PARTS)}")
    rows: list[dict] = []
    with tempfile.TemporaryDirectory(prefix="tzsl-bench-") as tmp:
        work = Path(keep) if keep is not None else Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        if any(part in _RATIO_PARTS for part in parts):
            rows += run_split_fit(work, n_jobs=n_jobs, data_dir=data_dir, echo=echo)
        for part in (p for p in PARTS if p in parts):
            if part in STUDY_LIST_PARTS:
                rows += run_study_list(part, work, studies=studies if part == "reproduce" else (), n_jobs=n_jobs,
                                       data_dir=data_dir, echo=echo)
            elif part == "template":
                rows += run_template(work, template=template, n_jobs=n_jobs, echo=echo)
            else:
                rows += run_predict(methods=methods, repeats=repeats, n_grasps=n_grasps, echo=echo)
    return bench_table(rows, parts)


def main(argv: list[str] | None = None) -> pd.DataFrame:
    """Command line of ``make bench`` (``--help``)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", action="append", choices=PARTS, default=None, metavar="PART",
                        help=f"time only this part (repeatable; one of {', '.join(PARTS)}; "
                             f"default: {', '.join(DEFAULT_PARTS)})")
    parser.add_argument("--n-jobs", type=int, default=2)
    parser.add_argument("--data-dir", default=None, help="data home (default: $TZSL_DATA_DIR)")
    parser.add_argument("--study", action="append", default=[], metavar="NAME",
                        help="reproduce: only this study (repeatable; a subset is checked against no goal)")
    parser.add_argument("--template", type=Path, default=DEFAULT_TEMPLATE, help="template: the experiment file")
    parser.add_argument("--methods", default=",".join(METHODS), help=f"predict: of {', '.join(METHODS)}")
    parser.add_argument("--repeats", type=int, default=5, help="predict: cold runs per measure (median)")
    parser.add_argument("--grasps", type=int, default=200, help="predict: grasps through the API (median)")
    parser.add_argument("--keep", type=Path, default=None,
                        help="keep the results folders, logs and caches in this folder (default: a temporary one)")
    add_output_options(parser)
    args = parser.parse_args(argv)
    methods = [m.strip() for m in args.methods.split(",") if m.strip()]
    if unknown := [m for m in methods if m not in METHODS]:
        parser.error(f"--methods: unknown {', '.join(unknown)}; known: {', '.join(METHODS)}")
    return benchmark_main(parser, args, "bench", lambda echo: run_bench(
        args.only or DEFAULT_PARTS, n_jobs=args.n_jobs, data_dir=args.data_dir, studies=args.study,
        template=args.template, methods=methods, repeats=args.repeats, n_grasps=args.grasps, keep=args.keep,
        echo=echo), summary_lines)


if __name__ == "__main__":
    main()
