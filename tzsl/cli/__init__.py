"""The ``tzsl`` command line: thin click commands that parse options and call a study."""

from tzsl.cli._main import cli, main

__all__ = ["cli", "main"]
