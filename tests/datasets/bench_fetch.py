"""A first-use fetch timed against a local mirror whose answers come late, as GitHub's do.

``python -m tests.datasets.bench_fetch [--delay 0.05] [--workers N]`` serves ``../shared/data``
(:mod:`tests.datasets.fetch_server`, in a process of its own so that its CPU is not counted),
fetches what ``make reproduce-tables`` reads on first use (the ``phac2-penn`` and ``fabric``
built-in datasets' registered files) into an empty temporary data home with
:func:`tzsl.datasets.fetch_missing`, and prints the files, wall seconds and this process's CPU
seconds (user + system, :func:`resource.getrusage`). Not a test: run it by hand. As a script
(``python tests/datasets/bench_fetch.py``) it times whichever tzsl ``PYTHONPATH`` holds.
"""

from __future__ import annotations

import argparse
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from tzsl.datasets import builtin_data_files, fetch_missing


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--delay", type=float, default=0.05, help="seconds each answer of the mirror waits")
    parser.add_argument("--workers", type=int, default=None, help="downloads at a time (default: tzsl's)")
    parser.add_argument("--data", type=Path, default=Path(__file__).resolve().parents[3] / "shared" / "data")
    args = parser.parse_args(argv)
    files = sorted(set(builtin_data_files("phac2-penn")) | set(builtin_data_files("fabric")))
    server = subprocess.Popen([sys.executable, str(Path(__file__).with_name("fetch_server.py")), str(args.data),
                               "--delay", str(args.delay)], stdout=subprocess.PIPE, text=True)
    try:
        base = server.stdout.readline().strip()  # type: ignore[union-attr]
        extra = {} if args.workers is None else {"workers": args.workers}
        with tempfile.TemporaryDirectory() as home:
            before = resource.getrusage(resource.RUSAGE_SELF)
            start = time.perf_counter()
            reports = fetch_missing(files, home, mirror=base, progress=False, **extra)
            wall = time.perf_counter() - start
            after = resource.getrusage(resource.RUSAGE_SELF)
        cpu = after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime
        got = sum(len(r.downloaded) + len(r.built) for r in reports)
        print(f"{got} of {len(files)} files, delay {args.delay:g} s, workers {args.workers or 'default'}: "
              f"{wall:.1f} s wall, {cpu:.1f} s CPU")
    finally:
        server.terminate()
        server.wait(timeout=10)


if __name__ == "__main__":
    main()
