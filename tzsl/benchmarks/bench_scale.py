"""``make bench-scale``: cost of one DAP split against the number of trials, on SIMULATED data (issue 15).

For each size N it writes a synthetic plain-file dataset with
:func:`tzsl.datasets.write_synthetic_dataset` (60 classes, 30 attributes, 2 sensors, 32 features;
SIMULATED, see that module), then runs ``tzsl run`` on it in a child process - study phac2-dap,
one random split of 10 unseen classes, DAP and ESZSL (the method comparison, with both methods'
posteriors calibrated on pseudo-unseen training classes; ``--dap-only`` leaves ESZSL and the
comparison out), every other setting the schema's default - and prints

* wall time of the run (loading + fits + tables), its CPU time summed over the run's processes
  (``getrusage`` of the reaped children: robust to other load on the machine; on an otherwise idle
  machine wall is about CPU / n_jobs) and, from the manifest, the attribute solver chosen,
* peak memory: the largest sum of resident memory over the run's process tree (sampled every
  0.2 s with psutil) and the peak RSS of its largest single process (``getrusage``),
* AVGDAP zero-shot accuracy (uni-prior) on the split's test trials, with chance,
* with ``--backend dask``: the benchmark starts a Dask ``LocalCluster`` of ``--n-jobs`` worker
  processes (one thread each) and runs ``tzsl run`` on it (``--scheduler``); it also prints the
  peak resident memory of each worker (sampled like the process tree) beside :data:`WORKER_MEMORY_GOAL_GB`,
  and the peak of the run's own process tree (loading, tables),
* the growth exponent: the least-squares slope of log(wall), log(CPU) and log(peak memory) against log(N)
  over the sizes >= 4,000.

This is a benchmark, not a test: the numbers depend on the machine and its load (printed). Run::

    python -m tzsl.benchmarks.bench_scale --sizes 1000,4000 --n-jobs 2 --work /tmp/bench-scale
    python -m tzsl.benchmarks.bench_scale --sizes 1000000 --backend dask --n-jobs 2 --work /tmp/bench-scale
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

#: The sizes of ``make bench-scale`` (trials).
DEFAULT_SIZES = (1_000, 4_000, 16_000, 64_000, 100_000)
#: Issue 22's goal for ``--backend dask``: peak resident memory of each worker (GB) ...
WORKER_MEMORY_GOAL_GB = 4.0
#: ... and wall time of a 1,000,000-trial run on 2 workers (s).
WALL_GOAL_S = 600.0

_TOML = """# written by tzsl.benchmarks.bench_scale: SIMULATED data
study = "phac2-dap"
description = "scale benchmark, {n} SIMULATED trials"
[dataset]
plain = "{plain}"
[methods]
eszsl = {eszsl}
[splits]
kinds = ["random"]
n_splits = 1
n_test = 10
seed = {seed}
[compute]
n_jobs = {n_jobs}
backend = "{backend}"
{scheduler}cache = false
progress = false
[output]
folder = "{out}"
"""


def _tree_rss(proc) -> int:
    """Resident bytes of ``proc`` and all its descendants (0 for processes that are gone)."""
    import psutil  # noqa: PLC0415 - a dependency of distributed; only this benchmark samples memory

    total = 0
    try:
        procs = [proc, *proc.children(recursive=True)]
    except psutil.Error:
        return 0
    for p in procs:
        try:
            total += p.memory_info().rss
        except psutil.Error:
            pass
    return total


def _rss(pid: int) -> int:
    """Resident bytes of process ``pid`` (0 once it is gone)."""
    import psutil  # noqa: PLC0415

    try:
        return psutil.Process(pid).memory_info().rss
    except psutil.Error:
        return 0


@contextlib.contextmanager
def _cluster(backend: str, n_workers: int):
    """``(scheduler address, worker pids)`` of a fresh local Dask cluster for ``backend="dask"``, else
    ``(None, [])``."""
    if backend != "dask":
        yield None, []
        return
    from distributed import Client, LocalCluster  # noqa: PLC0415 - only the dask benchmark needs it

    with LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, \
            Client(cluster) as client:
        yield cluster.scheduler_address, sorted(client.run(os.getpid).values())


def run_one(n: int, work: Path, *, n_jobs: int, backend: str, table_format: str, seed: int,
            extra_args: tuple[str, ...] = (), eszsl: bool = True) -> dict:
    """Write the N-trial dataset (kept for reuse) and time ``tzsl run`` on it in a child process.

    With ``backend="dask"`` the run goes to a fresh local cluster of ``n_jobs`` worker processes,
    whose peak resident memory is sampled too (``peak_worker_gb``: the largest of them).
    ``eszsl``: also run ESZSL and the method comparison (calibrated DAP and ESZSL posteriors).
    """
    import psutil  # noqa: PLC0415

    from tzsl.datasets import write_synthetic_dataset  # noqa: PLC0415

    plain = work / f"synthetic_{n}_{table_format}"
    if not plain.exists():
        start = time.perf_counter()
        write_synthetic_dataset(plain, n, table_format=table_format, seed=seed)
        print(f"  wrote {plain} in {time.perf_counter() - start:.1f} s", flush=True)
    out = work / f"results_{n}_{table_format}_{backend}"
    toml = work / f"bench_{n}.toml"
    cmd = [sys.executable, "-c", "from tzsl.cli import main; main()", "run", str(toml), "--force", *extra_args]
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    before, cpu_before = usage.ru_maxrss, usage.ru_utime + usage.ru_stime
    with _cluster(backend, n_jobs) as (address, workers):
        scheduler = "" if address is None else f'scheduler = "{address}"\n'
        toml.write_text(_TOML.format(n=n, plain=plain, seed=seed, n_jobs=n_jobs, backend=backend, out=out,
                                     scheduler=scheduler, eszsl=str(eszsl).lower()))
        start = time.perf_counter()
        proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        ps, peak, worker_peak = psutil.Process(proc.pid), 0, dict.fromkeys(workers, 0)
        while proc.poll() is None:
            peak = max(peak, _tree_rss(ps))
            for pid in workers:
                worker_peak[pid] = max(worker_peak[pid], _rss(pid))
            time.sleep(0.2)
        wall = time.perf_counter() - start
    assert proc.stdout is not None  # stdout=subprocess.PIPE
    log = proc.stdout.read()
    if proc.returncode != 0:
        raise RuntimeError(f"tzsl run failed for N={n} (exit {proc.returncode}):\n{log[-3000:]}")
    if "--profile" in extra_args:
        print(log[log.find("profile"):] if "profile" in log else log[-3000:], flush=True)
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    single = usage.ru_maxrss  # KiB, max over reaped descendants
    cpu = usage.ru_utime + usage.ru_stime - cpu_before  # the run and its workers, all cores
    t1 = pd.read_csv(out / "table1_fusion.csv")
    row = t1[t1["split"].astype(str) == "1"].iloc[0]
    manifest = json.loads((out / "manifest.json").read_text())
    solver = manifest["config"].get("attribute_solver", [{}])[0].get("solver", "?")
    return {"trials": n, "wall_s": wall, "cpu_s": cpu, "peak_tree_gb": peak / 1e9,
            "peak_process_gb": (single * 1024 / 1e9) if single > before else float("nan"),
            "peak_worker_gb": max(worker_peak.values()) / 1e9 if workers else float("nan"),
            "worker_peaks_gb": [v / 1e9 for v in worker_peak.values()],
            "avgdap": float(row["avgdap"]), "chance": float(row["chance"]), "solver": solver}


def goal_line(trials: int, wall_s: float, worker_peaks_gb: list[float]) -> str:
    """One line on a Dask run against issue 22's goals.

    Each worker's peak resident memory (GB) against :data:`WORKER_MEMORY_GOAL_GB`, and for
    1,000,000 trials on 2 workers the wall time (s) against :data:`WALL_GOAL_S`.
    """
    met = {True: "met", False: "NOT met"}
    peaks = ", ".join(f"{v:.2f}" for v in worker_peaks_gb)
    line = (f"Dask, {len(worker_peaks_gb)} workers: peak memory per worker {peaks} GB "
            f"(goal < {WORKER_MEMORY_GOAL_GB:g} GB: {met[max(worker_peaks_gb) < WORKER_MEMORY_GOAL_GB]})")
    if trials == 1_000_000 and len(worker_peaks_gb) == 2:
        line += f"; wall {wall_s:.0f} s (goal < {WALL_GOAL_S:g} s: {met[wall_s < WALL_GOAL_S]})"
    return line + " - SIMULATED data"


def growth_exponent(sizes, values, above: int = 4_000) -> float:
    """Least-squares slope of log(values) on log(sizes) over sizes >= ``above`` (NaN if < 2 sizes)."""
    sizes, values = np.asarray(sizes, float), np.asarray(values, float)
    keep = sizes >= above
    if keep.sum() < 2:
        return float("nan")
    return float(np.polyfit(np.log(sizes[keep]), np.log(values[keep]), 1)[0])


def main(argv: list[str] | None = None) -> pd.DataFrame:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default=",".join(str(s) for s in DEFAULT_SIZES),
                        help="comma-separated trial counts (default: %(default)s)")
    parser.add_argument("--work", type=Path, default=Path("bench_scale"),
                        help="folder for the datasets (reused across runs) and results")
    parser.add_argument("--n-jobs", type=int, default=2)
    parser.add_argument("--backend", default="loky", choices=("loky", "dask"))
    parser.add_argument("--table-format", default="parquet", choices=("csv", "parquet"))
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=None, help="also write the table as CSV here")
    parser.add_argument("--profile", action="store_true", help="run tzsl run --profile and print where its time went")
    parser.add_argument("--dap-only", action="store_true",
                        help="DAP alone: no ESZSL, no method comparison (and no calibration of the DAP rows)")
    args = parser.parse_args(argv)
    sizes = [int(s) for s in args.sizes.split(",") if s.strip()]
    args.work.mkdir(parents=True, exist_ok=True)
    print(f"SIMULATED data; {os.cpu_count()} cores; load average before: {os.getloadavg()}", flush=True)
    rows = []
    for n in sizes:
        print(f"N = {n:,} trials ...", flush=True)
        rows.append(run_one(n, args.work.resolve(), n_jobs=args.n_jobs, backend=args.backend,
                            table_format=args.table_format, seed=args.seed,
                            extra_args=("--profile",) if args.profile else (), eszsl=not args.dap_only))
        r = rows[-1]
        print(f"  SIMULATED: wall {r['wall_s']:.1f} s, CPU {r['cpu_s']:.1f} s, peak {r['peak_tree_gb']:.2f} GB (run's "
              f"process tree) / {r['peak_process_gb']:.2f} GB (one process), AVGDAP {r['avgdap']:.3f} "
              f"(chance {r['chance']:.3f}), solver {r['solver']}; load average {os.getloadavg()}", flush=True)
        worker_peaks = r.pop("worker_peaks_gb")  # the table keeps the largest (peak_worker_gb)
        if worker_peaks:
            print(f"  {goal_line(r['trials'], r['wall_s'], worker_peaks)}", flush=True)
    table = pd.DataFrame(rows)
    print("\n" + table.to_string(index=False, float_format=lambda v: f"{v:.3f}"))
    print(f"growth exponent above 4k trials: wall {growth_exponent(table.trials, table.wall_s):.2f}, "
          f"CPU {growth_exponent(table.trials, table.cpu_s):.2f}, "
          f"memory {growth_exponent(table.trials, table.peak_tree_gb):.2f}")
    if args.out is not None:
        table.to_csv(args.out, index=False)
    return table


if __name__ == "__main__":
    main()
