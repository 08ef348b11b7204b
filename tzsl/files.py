"""Writing result files safely, for scripts and plug-ins: the helpers every tzsl output goes through.

:func:`atomic_write` writes to a temporary file beside the target and moves it into place, so a
reader (or an interrupted run) never sees half a file, and the file gets the permissions a plain
``open(path, "w")`` would give; :func:`atomic_write_bytes` does the same for bytes, and
:func:`ensure_folder` creates an output folder or says in one line why it cannot. Benchmark
scripts in ``experiments/`` and user code write their CSVs with these, as tzsl's own tables do.
The implementation is the private ``tzsl._io``.
"""

from tzsl._io import atomic_write, atomic_write_bytes, ensure_folder

__all__ = ["atomic_write", "atomic_write_bytes", "ensure_folder"]
