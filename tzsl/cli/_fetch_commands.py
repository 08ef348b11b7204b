"""``tzsl data fetch``: get the papers' data (:mod:`tzsl.datasets` registry, pooch)."""

from __future__ import annotations

import click

from tzsl.cli._root import cli, data_dir_option, no_progress_option


class TimeoutOption(click.Option):
    """``--timeout``: its default (``$TZSL_FETCH_TIMEOUT``, else tzsl's) is resolved by
    :func:`tzsl.datasets.fetch_datasets`; the help reads the default, the stall limit and the
    attempts from :mod:`tzsl.datasets` only when shown (``--help`` of other commands stays fast)."""

    def get_help_record(self, ctx):
        from tzsl.datasets import (  # noqa: PLC0415
            DEFAULT_FETCH_TIMEOUT_S,
            FETCH_ATTEMPTS,
            FETCH_STALL_S,
            FETCH_TIMEOUT_ENV,
        )

        self.help = self.help.format(stall=f"{FETCH_STALL_S:g}", attempts=FETCH_ATTEMPTS)
        self.show_default = f"${FETCH_TIMEOUT_ENV}, else {DEFAULT_FETCH_TIMEOUT_S:g}"
        return super().get_help_record(ctx)


class WorkersOption(click.Option):
    """``--workers``: its default (``$TZSL_FETCH_WORKERS``, else tzsl's) is resolved by
    :func:`tzsl.datasets.fetch_datasets`; the help reads it from :mod:`tzsl.datasets` only when shown."""

    def get_help_record(self, ctx):
        from tzsl.datasets import DEFAULT_FETCH_WORKERS, FETCH_WORKERS_ENV, MAX_FETCH_WORKERS  # noqa: PLC0415

        self.help = self.help.format(most=MAX_FETCH_WORKERS)
        self.show_default = f"${FETCH_WORKERS_ENV}, else {DEFAULT_FETCH_WORKERS}"
        return super().get_help_record(ctx)


@cli.group()
def data() -> None:
    """The papers' datasets: fetch them into the data home."""


@data.command()
@click.argument("names", nargs=-1)
@click.option("--mirror", default=None, metavar="URL",
              help="Base URL laid out like the data home (MIRROR/phac2/...), used for every file instead of "
                   "the registry's public URLs; default $TZSL_DATA_MIRROR.")
@click.option("--timeout", cls=TimeoutOption, type=click.FloatRange(min=0, min_open=True), default=None,
              metavar="SECONDS",
              help="Deadline per file: a file not completely downloaded within SECONDS (retries included) "
                   "stops the fetch with one line. Within it, an attempt that receives no byte for {stall} s, "
                   "is cut short or gets an HTTP 5xx answer is retried ({attempts} attempts at most).")
@click.option("--workers", cls=WorkersOption, type=int, default=None, metavar="N",
              help="Files downloaded at a time (1 to {most}); the first file that fails stops the others.")
@data_dir_option
@no_progress_option
def fetch(names: tuple[str, ...], mirror: str | None, timeout: float | None, workers: int | None, data_dir,
          no_progress: bool) -> None:
    """Download and verify every registered file of NAMES (default: every dataset).

    Files already present with the registered sha256 are kept, so an interrupted fetch goes on
    where it stopped; a download is checked before it is moved into place, and temporary files
    a killed fetch left behind are removed. Names: the registry's datasets (phac2, fabric,
    gelsight_press, and the catalog's public datasets such as biotac-slide).
    """
    from tzsl.datasets import fetch_datasets, get_data_home  # noqa: PLC0415
    from tzsl.exceptions import DataMissingError  # noqa: PLC0415

    home = get_data_home(data_dir)
    reports = fetch_datasets(names, data_dir, mirror=mirror, progress=not no_progress, timeout=timeout,
                             workers=workers, echo=click.echo)
    missing = [path for r in reports for path in r.missing]
    if missing:
        raise DataMissingError(home / missing[0], f"{len(missing)} registered file(s) have no public URL and were "
                                                  "not fetched; give --mirror, or see data/README.md")
    click.echo(f"data home {home}: complete for {', '.join(r.name for r in reports)}")
