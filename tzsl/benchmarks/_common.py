"""What the shipped benchmarks share: timing a child process, and their command line's output handling."""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

import pandas as pd

__all__ = ["add_output_options", "benchmark_main", "timed_process"]


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


def add_output_options(parser: argparse.ArgumentParser) -> None:
    """``--out`` (the table as CSV) and ``--force`` (overwrite it)."""
    parser.add_argument("--out", type=Path, default=None, help="also write the table as CSV here")
    parser.add_argument("--force", action="store_true", help="overwrite --out")


def benchmark_main(parser: argparse.ArgumentParser, args: argparse.Namespace, name: str,
                   run: Callable[[Callable[[str], None]], pd.DataFrame],
                   summary_lines: Callable[[pd.DataFrame], list[str]]) -> pd.DataFrame:
    """Refuse an existing ``--out`` without ``--force``, print the machine's load, ``run(echo)``, print
    its summary and write the table atomically to ``--out``."""
    if args.out is not None and args.out.exists() and not args.force:
        parser.exit(2, f"{name}: error: {args.out} already exists; use --force to overwrite\n")
    print(f"{os.cpu_count()} cores; load average before: {os.getloadavg()}", flush=True)
    table = run(lambda line: print(line, flush=True))
    print("\n" + "\n".join(summary_lines(table)))
    if args.out is not None:
        from tzsl._io import atomic_write  # noqa: PLC0415

        atomic_write(args.out, lambda p: table.to_csv(p, index=False))
        print(f"wrote {args.out}")
    return table
