"""Root command group, shared options and error handling.

Every :class:`~tzsl.exceptions.TzslError` raised below a command is printed as one line
``tzsl: error: <message>`` on standard error with exit code 2; no traceback.
"""

from __future__ import annotations

import sys
from pathlib import Path

import click

from tzsl import __version__
from tzsl.exceptions import TzslError

#: Exit code for a TzslError (bad input, bad configuration, refused overwrite).
EXIT_TZSL_ERROR = 2


class TzslGroup(click.Group):
    """A click group that turns TzslError into a one-line message and exit code 2."""

    def invoke(self, ctx: click.Context):  # noqa: D401 - click API
        try:
            return super().invoke(ctx)
        except TzslError as exc:
            click.echo(f"tzsl: error: {exc}", err=True)
            ctx.exit(EXIT_TZSL_ERROR)


data_dir_option = click.option(
    "--data-dir",
    type=click.Path(file_okay=False, path_type=Path),
    default=None,
    help="Folder holding the datasets (default: $TZSL_DATA_DIR, else the user cache folder).",
)
force_option = click.option("--force", is_flag=True, help="Overwrite existing results.")
n_jobs_option = click.option(
    "--n-jobs", type=int, default=1, show_default=True, help="Parallel fits (joblib); -1 uses every core."
)
backend_option = click.option(
    "--backend",
    type=click.Choice(["loky", "dask"]),
    default="loky",
    show_default=True,
    help="joblib backend; 'dask' runs the fits on a Dask cluster (see --scheduler).",
)
scheduler_option = click.option(
    "--scheduler",
    default=None,
    help="Dask scheduler address (tcp://host:port) for --backend dask; default: a local cluster.",
)
seed_option = click.option("--seed", type=int, default=0, show_default=True, help="Random seed.")


@click.group(cls=TzslGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="tzsl")
def cli() -> None:
    """tzsl: tactile zero-shot learning.

    Learn attribute detectors ("hard", "porous", ...) from touch data of known objects,
    then recognise objects never touched from their attribute description alone.
    """


def _register_commands() -> None:
    from tzsl.cli import _commands  # noqa: F401, PLC0415 - registers commands on import


def main(argv: list[str] | None = None) -> None:
    """Console-script entry point."""
    _register_commands()
    cli.main(args=argv if argv is not None else sys.argv[1:], prog_name="tzsl")
