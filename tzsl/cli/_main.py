"""The console script: the root group with every command registered.

Importing the command modules registers their commands on :data:`tzsl.cli._root.cli`; they
import only click at module level, so ``tzsl --help`` stays fast.
"""

from __future__ import annotations

import sys

from tzsl.cli import _commands  # noqa: F401 - every command module registers its commands on import
from tzsl.cli._root import EXIT_TZSL_ERROR, EXIT_USAGE, cli

__all__ = ["EXIT_TZSL_ERROR", "EXIT_USAGE", "cli", "main"]


def main(argv: list[str] | None = None) -> None:
    """Console-script entry point."""
    cli.main(args=argv if argv is not None else sys.argv[1:], prog_name="tzsl")
