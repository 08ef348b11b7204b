"""``make bench``'s predict part (``make bench-predict``): ``tzsl predict`` cold and the load-once Python API.

On a SIMULATED five-finger dataset (every 0/1 row of 4 attributes is a class; 5 sensors of 10
features, a noisy linear image of the class's attributes; written to a temporary folder), it
trains each method of ``methods`` with ``tzsl train-attributes`` (``eszsl``: stored as arrays;
``dap``: the default per-(attribute, sensor) SVMs, stored as arrays too) and measures (study: the
method; every number SIMULATED):

* run **cold**: ``tzsl predict`` of one grasp in a new Python process (stage ``predict``; start
  to exit, as a user sees it), the median of ``repeats`` runs, and ``tzsl --help`` (study ``-``,
  stage ``help``); the note says whether such a process imported torch, scikit-learn or skops;
* run **api**: :class:`tzsl.inference.Recogniser` in this process: ``load`` once, then per grasp
  ``rank`` (one grasp alone) and ``add`` (one more grasp, SC-MDAP decision), the median
  milliseconds over ``n_grasps`` grasps (quantity ``per_grasp``).

This is a benchmark, not a test: the numbers depend on the machine and its load (the 1-minute load
average before each measure is written beside it). The goals are in :mod:`tzsl.benchmarks.goals`.
"""

from __future__ import annotations

import itertools
import statistics
import tempfile
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from tzsl.benchmarks._common import measurement, run_tzsl

__all__ = ["METHODS", "api_times", "cold_times", "run_predict", "simulated_dataset"]

#: Methods the bench can train -> ``tzsl train-attributes`` options.
METHODS: dict[str, tuple[str, ...]] = {"eszsl": ("--method", "eszsl"), "dap": ("--cv", "2", "--no-cache")}

_ATTRIBUTES = ("hard", "soft", "rough", "smooth")
_N_SENSORS, _N_FEATURES, _N_TRIALS = 5, 10, 6
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


def cold_times(args: Sequence[object], repeats: int) -> tuple[list[float], list[float], str]:
    """Wall and CPU seconds of ``repeats`` cold runs of ``tzsl ARGS``, and what such a process imports."""
    walls, cpus = [], []
    for _ in range(repeats):
        wall, cpu, _ = run_tzsl(args)
        walls.append(wall)
        cpus.append(cpu)
    out = run_tzsl(args, code=_IMPORTS_PROBE)[2]
    imported = next((line[len("IMPORTED"):].strip() for line in out.splitlines() if line.startswith("IMPORTED")), "")
    return walls, cpus, imported


def api_times(model: Path, classes: Path, grasps: np.ndarray) -> dict[str, list[float]]:
    """Seconds of :meth:`Recogniser.load` (once, key ``load``) and of ``rank`` / ``add`` per grasp (this process)."""
    from tzsl.inference import Recogniser  # noqa: PLC0415

    start = time.perf_counter()
    recogniser = Recogniser.load(model, classes)
    times: dict[str, list[float]] = {"load": [time.perf_counter() - start], "rank": [], "add": []}
    for grasp in grasps:
        start = time.perf_counter()
        recogniser.rank(grasp)
        times["rank"].append(time.perf_counter() - start)
        start = time.perf_counter()
        recogniser.add(grasp)
        times["add"].append(time.perf_counter() - start)
    return times


def _cold_rows(study: str, stage: str, walls: list[float], cpus: list[float], imported: str, note: str) -> list[dict]:
    """A cold measure's wall and CPU rows (SIMULATED), the note saying what the process imported."""
    note = f"{note}; imports: {imported or 'neither torch nor scikit-learn'}"
    return [measurement("predict", study, stage, "cold", "wall", "s", walls, simulated=True, n_jobs=1, note=note),
            measurement("predict", study, stage, "cold", "cpu", "s", cpus, simulated=True, n_jobs=1, note=note)]


def run_predict(*, methods: Sequence[str] = tuple(METHODS), repeats: int = 5, n_grasps: int = 200,
                echo: Callable[[str], None] = print) -> list[dict]:
    """Train each method on the simulated dataset and time predict cold and through the API.

    Returns
    -------
    list of dict
        Measurements (:data:`tzsl.benchmarks._common.MEASURE_COLUMNS`) of part ``predict``, all
        SIMULATED; cold measures in seconds, API measures in milliseconds.

    Raises
    ------
    ValueError
        A method is not one of :data:`METHODS`.
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
        rows += _cold_rows("-", "help", walls, cpus, imported, "tzsl --help")
        echo(f"tzsl --help (cold): median {statistics.median(walls):.2f} s")
        for method in methods:
            model = Path(tmp) / f"{method}.tzsl"
            run_tzsl(["train-attributes", "--plain", folder, "--no-progress", *METHODS[method], "--out", model])
            payload = read_bundle_header(model).payload_format
            walls, cpus, imported = cold_times(["predict", "--model", model, "--classes", folder, one], repeats)
            rows += _cold_rows(method, "predict", walls, cpus, imported, f"{payload} bundle")
            echo(f"{method} ({payload}): tzsl predict one grasp, cold: median {statistics.median(walls):.2f} s wall, "
                 f"{statistics.median(cpus):.2f} s CPU; imports: {imported or 'neither torch nor scikit-learn'}")
            for stage, values in api_times(model, folder, grasps).items():
                ms = [1000.0 * v for v in values]
                rows.append(measurement("predict", method, stage, "api", "wall" if stage == "load" else "per_grasp",
                                        "ms", ms, simulated=True, n_jobs=1, note=f"{payload} bundle"))
                echo(f"{method} ({payload}): {stage}: median {statistics.median(ms):.3f} ms over {len(ms)}")
    return rows
