"""The ``tzsl`` command line: thin click commands that parse options and call a study."""

from tzsl.cli._main import EXIT_TZSL_ERROR, EXIT_USAGE, cli, main

__all__ = ["EXIT_TZSL_ERROR", "EXIT_USAGE", "cli", "main"]
