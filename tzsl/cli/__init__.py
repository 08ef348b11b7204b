"""The ``tzsl`` command line: thin click commands that parse options and call a study."""

import os

#: Idle OpenBLAS threads of a ``tzsl`` process wait 2**4 cycles before they sleep, not OpenBLAS's default
#: 2**28 cycles of spinning: the command's own process calls BLAS on small arrays between stretches of
#: Python (the attribute posteriors), and on 2 busy cores the spinning thread cost more CPU than the
#: posteriors themselves (measured in the commit that set it), with the same threads and numbers. Set
#: before numpy loads OpenBLAS (``import tzsl`` loads no numpy); a user's own setting wins.
OPENBLAS_THREAD_TIMEOUT = "4"
os.environ.setdefault("OPENBLAS_THREAD_TIMEOUT", OPENBLAS_THREAD_TIMEOUT)

from tzsl.cli._main import EXIT_TZSL_ERROR, EXIT_USAGE, cli, main  # noqa: E402 - after the BLAS setting

__all__ = ["EXIT_TZSL_ERROR", "EXIT_USAGE", "OPENBLAS_THREAD_TIMEOUT", "cli", "main"]
