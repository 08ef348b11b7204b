"""``make bench-scale``: cost of one DAP split against the number of trials, on SIMULATED data (issue 15).

For each size N it writes a synthetic plain-file dataset with
:func:`tzsl.datasets.write_synthetic_dataset` (60 classes, 30 attributes, 2 sensors, 32 features;
SIMULATED, see that module), then runs ``tzsl run`` on it in a child process - study phac2-dap,
one random split of 10 unseen classes, every other setting the schema's default - and prints

* wall time of the run (loading + fits + tables), its CPU time summed over the run's processes
  (``getrusage`` of the reaped children: robust to other load on the machine; on an otherwise idle
  machine wall is about CPU / n_jobs) and, from the manifest, the attribute solver chosen,
* peak memory: the largest sum of resident memory over the run's process tree (sampled every
  0.2 s with psutil) and the peak RSS of its largest single process (``getrusage``),
* AVGDAP zero-shot accuracy (uni-prior) on the split's test trials, with chance,
* the growth exponent: the least-squares slope of log(wall), log(CPU) and log(peak memory) against log(N)
  over the sizes >= 4,000.

This is a benchmark, not a test: the numbers depend on the machine and its load (printed). Run::

    python -m tzsl.benchmarks.bench_scale --sizes 1000,4000 --n-jobs 2 --work /tmp/bench-scale
"""

from __future__ import annotations

import argparse
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

_TOML = """# written by tzsl.benchmarks.bench_scale: SIMULATED data
study = "phac2-dap"
description = "scale benchmark, {n} SIMULATED trials"
[dataset]
plain = "{plain}"
[splits]
kinds = ["random"]
n_splits = 1
n_test = 10
seed = {seed}
[compute]
n_jobs = {n_jobs}
backend = "{backend}"
cache = false
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


def run_one(n: int, work: Path, *, n_jobs: int, backend: str, table_format: str, seed: int,
            extra_args: tuple[str, ...] = ()) -> dict:
    """Write the N-trial dataset (kept for reuse) and time ``tzsl run`` on it in a child process."""
    import psutil  # noqa: PLC0415

    from tzsl.datasets import write_synthetic_dataset  # noqa: PLC0415

    plain = work / f"synthetic_{n}_{table_format}"
    if not plain.exists():
        start = time.perf_counter()
        write_synthetic_dataset(plain, n, table_format=table_format, seed=seed)
        print(f"  wrote {plain} in {time.perf_counter() - start:.1f} s", flush=True)
    out = work / f"results_{n}_{table_format}_{backend}"
    toml = work / f"bench_{n}.toml"
    toml.write_text(_TOML.format(n=n, plain=plain, seed=seed, n_jobs=n_jobs, backend=backend, out=out))
    cmd = [sys.executable, "-c", "from tzsl.cli import main; main()", "run", str(toml), "--force", *extra_args]
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    before, cpu_before = usage.ru_maxrss, usage.ru_utime + usage.ru_stime
    start = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    ps, peak = psutil.Process(proc.pid), 0
    while proc.poll() is None:
        peak = max(peak, _tree_rss(ps))
        time.sleep(0.2)
    wall = time.perf_counter() - start
    log = proc.stdout.read()
    if proc.returncode != 0:
        raise RuntimeError(f"tzsl run failed for N={n} (exit {proc.returncode}):\n{log[-3000:]}")
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    single = usage.ru_maxrss  # KiB, max over reaped descendants
    cpu = usage.ru_utime + usage.ru_stime - cpu_before  # the run and its workers, all cores
    t1 = pd.read_csv(out / "table1_fusion.csv")
    row = t1[t1["split"].astype(str) == "1"].iloc[0]
    manifest = json.loads((out / "manifest.json").read_text())
    solver = manifest["config"].get("attribute_solver", [{}])[0].get("solver", "?")
    return {"trials": n, "wall_s": wall, "cpu_s": cpu, "peak_tree_gb": peak / 1e9,
            "peak_process_gb": (single * 1024 / 1e9) if single > before else float("nan"),
            "avgdap": float(row["avgdap"]), "chance": float(row["chance"]), "solver": solver}


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
    args = parser.parse_args(argv)
    sizes = [int(s) for s in args.sizes.split(",") if s.strip()]
    args.work.mkdir(parents=True, exist_ok=True)
    print(f"SIMULATED data; {os.cpu_count()} cores; load average before: {os.getloadavg()}", flush=True)
    rows = []
    for n in sizes:
        print(f"N = {n:,} trials ...", flush=True)
        rows.append(run_one(n, args.work.resolve(), n_jobs=args.n_jobs, backend=args.backend,
                            table_format=args.table_format, seed=args.seed))
        r = rows[-1]
        print(f"  wall {r['wall_s']:.1f} s, CPU {r['cpu_s']:.1f} s, peak {r['peak_tree_gb']:.2f} GB (tree) / "
              f"{r['peak_process_gb']:.2f} GB (one process), AVGDAP {r['avgdap']:.3f} (chance {r['chance']:.3f}), "
              f"solver {r['solver']}; load average {os.getloadavg()[0]:.2f}", flush=True)
    table = pd.DataFrame(rows)
    print("\n" + table.to_string(index=False, float_format=lambda v: f"{v:.3f}"))
    print(f"growth exponent above 4k trials: wall {growth_exponent(table.trials, table.wall_s):.2f}, "
          f"CPU {growth_exponent(table.trials, table.cpu_s):.2f}, memory {growth_exponent(table.trials, table.peak_tree_gb):.2f}")
    if args.out is not None:
        table.to_csv(args.out, index=False)
    return table


if __name__ == "__main__":
    main()
