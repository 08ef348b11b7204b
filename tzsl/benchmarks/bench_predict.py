"""``make bench-predict`` (and ``make bench``): a robot's side, ``tzsl predict`` cold and the load-once Python API.

On a SIMULATED five-finger dataset (every 0/1 row of 4 attributes is a class; 5 sensors of 10
features, a noisy linear image of the class's attributes; written to a temporary folder), it
trains each method of ``--methods`` with ``tzsl train-attributes`` (``eszsl``: stored as arrays;
``dap``: the default per-(attribute, sensor) SVMs, stored as arrays too) and measures:

* **cold**: ``tzsl predict`` of one grasp in a new Python process (start to exit, as a user
  sees it), the median of ``--repeats`` runs, against :data:`GOAL_COLD_S`; and ``tzsl --help``;
* **api**: :class:`tzsl.inference.Recogniser` in this process: ``load`` once, then per grasp
  ``rank`` (one grasp alone) and ``add`` (one more grasp, SC-MDAP decision), the median
  milliseconds over ``--grasps`` grasps, against :data:`GOAL_GRASP_MS`;
* whether a cold process imported torch or scikit-learn.

It prints a table and writes it as a CSV (:data:`BENCH_COLUMNS`, atomically). This is a
benchmark, not a test: the numbers depend on the machine and its load (the 1-minute load
average before each measure is written beside it).

Run::

    python -m tzsl.benchmarks.bench_predict --out bench/predict_bench.csv --force
    python -m tzsl.benchmarks.bench_predict --methods eszsl --repeats 3   # quick
"""

from __future__ import annotations

import argparse
import itertools
import os
import statistics
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from tzsl.benchmarks._common import add_output_options, benchmark_main, timed_process

__all__ = ["BENCH_COLUMNS", "GOAL_COLD_S", "GOAL_GRASP_MS", "METHODS", "api_times", "cold_times", "main",
           "run_bench", "simulated_dataset"]

#: Goal of issue 33 (item 6) for ``tzsl predict`` of one grasp from a cold process, seconds.
GOAL_COLD_S = 1.0
#: Goal of issue 33 (item 6) for one grasp through the Python API, milliseconds.
GOAL_GRASP_MS = 10.0
#: Methods the bench can train -> ``tzsl train-attributes`` options.
METHODS: dict[str, tuple[str, ...]] = {"eszsl": ("--method", "eszsl"), "dap": ("--cv", "2", "--no-cache")}
#: Columns of the bench CSV, one row per (method, measure).
BENCH_COLUMNS = ("method", "payload", "measure", "unit", "median", "min", "max", "n", "cpu_s", "goal", "meets_goal",
                 "imports", "load_1min")

_ATTRIBUTES = ("hard", "soft", "rough", "smooth")
_N_SENSORS, _N_FEATURES, _N_TRIALS = 5, 10, 6
_CLI = "import sys; from tzsl.cli import main; main(sys.argv[1:])"
_IMPORTS_PROBE = ("import sys\nfrom tzsl.cli import main\ntry:\n    main(sys.argv[1:])\nexcept SystemExit:\n    pass\n"
                  "print('IMPORTED', ' '.join(m for m in ('torch', 'sklearn', 'skops') if m in sys.modules))")


def simulated_dataset(folder: Path, seed: int = 0) -> tuple[Path, Path, np.ndarray]:
    """Write the SIMULATED five-finger plain dataset; returns the folder, one grasp's CSV and every grasp.

    Returns
    -------
    folder : Path
    one_grasp : Path
        A feature CSV of one trial (5 rows: ``trial_id``, ``sensor``, the features).
    grasps : ndarray of shape (n_trials, 5, 10)
        Every trial's features, sensors in order, as a robot would give them to the API.
    """
    from tzsl.datasets import write_plain_dataset  # noqa: PLC0415

    rng = np.random.default_rng(seed)
    classes = pd.DataFrame(list(itertools.product([0, 1], repeat=len(_ATTRIBUTES))), columns=list(_ATTRIBUTES),
                           index=pd.Index([f"c{i}" for i in range(2 ** len(_ATTRIBUTES))], name="class"))
    trials = pd.DataFrame([(f"{c}_{t}", c) for c in classes.index for t in range(_N_TRIALS)],
                          columns=["trial_id", "class"])
    A = classes.loc[trials["class"]].to_numpy(dtype=float)
    X = np.stack([A @ rng.normal(0, 1, (len(_ATTRIBUTES), _N_FEATURES)) * 2 for _ in range(_N_SENSORS)], axis=1)
    X += rng.normal(0, 0.3, X.shape)
    sensors = [f"finger_{i}" for i in range(_N_SENSORS)]
    names = [f"f{i}" for i in range(_N_FEATURES)]
    write_plain_dataset(folder, classes, trials, sensors=sensors, X=X, feature_names=names)
    one = folder.parent / "one_grasp.csv"
    pd.DataFrame([{"trial_id": "new_0", "sensor": s, **dict(zip(names, X[0, j], strict=True))}
                  for j, s in enumerate(sensors)]).to_csv(one, index=False)
    return folder, one, X


def _run_cli(args: Sequence[str], code: str = _CLI) -> tuple[float, float, str]:
    """Wall and CPU seconds of ``tzsl ARGS`` in a new process, and its output."""
    wall, cpu, done = timed_process([sys.executable, "-c", code, *map(str, args)])
    if done.returncode != 0:
        raise RuntimeError(f"tzsl {' '.join(map(str, args))} failed (exit {done.returncode}):\n{done.stderr[-2000:]}")
    return wall, cpu, done.stdout


def cold_times(args: Sequence[str], repeats: int) -> tuple[list[float], list[float], str]:
    """Wall and CPU seconds of ``repeats`` cold runs of ``tzsl ARGS``, and what such a process imports."""
    walls, cpus = [], []
    for _ in range(repeats):
        wall, cpu, _ = _run_cli(args)
        walls.append(wall)
        cpus.append(cpu)
    out = _run_cli(args, _IMPORTS_PROBE)[2]
    imported = next((line[len("IMPORTED"):].strip() for line in out.splitlines() if line.startswith("IMPORTED")), "")
    return walls, cpus, imported


def api_times(model: Path, classes: Path, grasps: np.ndarray) -> dict[str, list[float]]:
    """Seconds of :meth:`Recogniser.load` (once) and of ``rank`` / ``add`` per grasp (this process)."""
    from tzsl.inference import Recogniser  # noqa: PLC0415

    start = time.perf_counter()
    recogniser = Recogniser.load(model, classes)
    times: dict[str, list[float]] = {"api_load": [time.perf_counter() - start], "api_rank": [], "api_add": []}
    for grasp in grasps:
        start = time.perf_counter()
        recogniser.rank(grasp)
        times["api_rank"].append(time.perf_counter() - start)
        start = time.perf_counter()
        recogniser.add(grasp)
        times["api_add"].append(time.perf_counter() - start)
    return times


def _row(method: str, payload: str, measure: str, unit: str, values: Sequence[float], goal: float,
         cpu: float = float("nan"), imports: str = "") -> dict:
    median = statistics.median(values)
    return {"method": method, "payload": payload, "measure": measure, "unit": unit, "median": median,
            "min": min(values), "max": max(values), "n": len(values), "cpu_s": cpu, "goal": goal,
            "meets_goal": bool(median <= goal) if np.isfinite(goal) else None, "imports": imports,
            "load_1min": os.getloadavg()[0]}


def run_bench(*, methods: Sequence[str] = tuple(METHODS), repeats: int = 5, n_grasps: int = 200,
              echo: Callable[[str], None] = print) -> pd.DataFrame:
    """Train each method on the simulated dataset and time predict cold and through the API.

    Returns
    -------
    DataFrame
        :data:`BENCH_COLUMNS`; cold measures in seconds, API measures in milliseconds.
    """
    from tzsl.inference.bundle import read_bundle_header  # noqa: PLC0415

    unknown = [m for m in methods if m not in METHODS]
    if unknown:
        raise ValueError(f"unknown method(s) {unknown}; known: {list(METHODS)}")
    rows = []
    with tempfile.TemporaryDirectory(prefix="tzsl-bench-predict-") as tmp:
        folder, one, X = simulated_dataset(Path(tmp) / "five_fingers")
        grasps = X[np.resize(np.arange(len(X)), n_grasps)]
        walls, cpus, imported = cold_times(["--help"], repeats)
        rows.append(_row("-", "-", "cold_help", "s", walls, float("nan"), statistics.median(cpus), imported))
        echo(f"tzsl --help (cold): median {rows[-1]['median']:.2f} s")
        for method in methods:
            model = Path(tmp) / f"{method}.tzsl"
            _run_cli(["train-attributes", "--plain", folder, "--no-progress", *METHODS[method], "--out", model])
            payload = read_bundle_header(model).payload_format
            walls, cpus, imported = cold_times(["predict", "--model", model, "--classes", folder, one], repeats)
            rows.append(_row(method, payload, "cold_predict", "s", walls, GOAL_COLD_S, statistics.median(cpus),
                             imported))
            echo(f"{method} ({payload}): tzsl predict one grasp, cold: median {rows[-1]['median']:.2f} s wall, "
                 f"{rows[-1]['cpu_s']:.2f} s CPU; imports: {imported or 'neither torch nor scikit-learn'}")
            times = api_times(model, folder, grasps)
            for measure, values in times.items():
                ms = [1000.0 * v for v in values]
                rows.append(_row(method, payload, measure, "ms", ms, float("nan") if measure == "api_load"
                                 else GOAL_GRASP_MS))
                echo(f"{method} ({payload}): {measure}: median {rows[-1]['median']:.3f} ms over {len(ms)}")
    return pd.DataFrame(rows, columns=list(BENCH_COLUMNS))


def summary_lines(table: pd.DataFrame) -> list[str]:
    """People's view of :func:`run_bench`'s table, with each goal met or not."""
    lines = [f"{'method':<7} {'payload':<7} {'measure':<13} {'median':>10} {'min':>10} {'max':>10} {'goal':>7}  met"]
    for r in table.itertuples(index=False):
        goal = "-" if not np.isfinite(r.goal) else f"{r.goal:g} {r.unit}"
        met = "-" if r.meets_goal is None else ("yes" if r.meets_goal else "NO")
        lines.append(f"{r.method:<7} {r.payload:<7} {r.measure:<13} {r.median:>8.3f} {r.unit:<1} {r.min:>8.3f} "
                     f"{r.unit:<1} {r.max:>8.3f} {r.unit:<1} {goal:>7}  {met}")
    return lines


def main(argv: list[str] | None = None) -> pd.DataFrame:
    """Command line of ``make bench-predict`` (``--help``)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--methods", default=",".join(METHODS), help=f"comma-separated, of {', '.join(METHODS)}")
    parser.add_argument("--repeats", type=int, default=5, help="cold runs per measure (median)")
    parser.add_argument("--grasps", type=int, default=200, help="grasps through the API (median)")
    add_output_options(parser)
    args = parser.parse_args(argv)
    methods = [m.strip() for m in args.methods.split(",") if m.strip()]
    return benchmark_main(parser, args, "bench_predict", lambda echo: run_bench(
        methods=methods, repeats=args.repeats, n_grasps=args.grasps, echo=echo), summary_lines)


if __name__ == "__main__":
    main()
