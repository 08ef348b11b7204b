"""Root command group, the shared options (one vocabulary) and error handling.

Command modules register their commands on :data:`cli` by importing it from here;
:mod:`tzsl.cli._main` imports them all (so this module imports none of them: no cycle).

Exit codes: 0 success; 1 a run that failed for a reason outside the input (interrupted, out of
memory, a bug) or that completed with failed (split, method) fits (listed one per line at the end,
:class:`~tzsl.exceptions.PartialRunError`); 2 a usage error (an unknown option, a bad option value: one line
``tzsl: error: ...``); 3 bad input data or configuration (every
:class:`~tzsl.exceptions.TzslError`, printed as its message, never a traceback).

This module imports only click: ``tzsl --help`` must stay fast. Option defaults that belong to
the experiment schema (:mod:`tzsl.studies.config`) are read from it lazily, when a command
runs or shows its own help.
"""

from __future__ import annotations

import functools
import re
import warnings
from pathlib import Path
from typing import Any

import click

from tzsl import __version__
from tzsl._warnings import TerminalWarnings
from tzsl.exceptions import PartialRunError, TzslError
from tzsl.value_lists import STUDY_BACKENDS

#: Exit code of a usage error (click's own code).
EXIT_USAGE = 2
#: Exit code of a TzslError (bad input data, bad configuration, refused overwrite).
EXIT_TZSL_ERROR = 3
#: Seeds must lie in [0, SEED_LIMIT) (numpy / scikit-learn random states).
SEED_LIMIT = 2**32


def _echo_error_stream(text: str) -> None:
    click.echo(text, err=True)


class TzslGroup(click.Group):
    """A click group: TzslError -> one message, exit 3; usage errors -> one line, exit 2;
    warnings -> one line ``tzsl: warning: ...`` per kind, then one line counting the repeats
    (:class:`tzsl._warnings.TerminalWarnings`)."""

    def invoke(self, ctx: click.Context):
        printer = TerminalWarnings(_echo_error_stream)
        try:
            with warnings.catch_warnings():
                warnings.showwarning = printer.show
                try:
                    return super().invoke(ctx)
                finally:
                    closing = printer.summary()
                    if closing is not None:
                        click.echo(closing, err=True)
        except TzslError as exc:
            click.echo(f"tzsl: error: {exc}", err=True)
            ctx.exit(EXIT_TZSL_ERROR)
        except PartialRunError as exc:  # results written; some fits failed: list them, exit 1
            click.echo(f"tzsl: error: {exc}", err=True)
            ctx.exit(exc.exit_code)
        except click.UsageError as exc:
            if type(exc).__name__ == "NoArgsIsHelpError":
                raise
            where = exc.ctx.command_path if exc.ctx is not None else "tzsl"
            click.echo(f"tzsl: error: {exc.format_message()} (see '{where} --help')", err=True)
            ctx.exit(EXIT_USAGE)


# --------------------------------------------------------------------------- schema defaults


@functools.cache
def _study_defaults(study: str):
    from tzsl.studies.config import defaults  # noqa: PLC0415

    required = {"phac2-dap": {"dataset": {"builtin": "phac2-penn"}},
                "zero-shot": {"dataset": {"builtin": "phac2-penn"}},
                "hand": {"dataset": {"builtin": "hand-simulated"}}}.get(study, {})
    return defaults(study, **required)


def schema_default(study: str, key: str):
    """The default of ``key`` (``"table.name"``) in the schema of ``study``, read when needed
    (lists as ``"a,b,c"``, the form ``--seeds`` takes)."""

    def read():
        table, name = key.split(".")
        value = getattr(getattr(_study_defaults(study), table), name)
        return ",".join(map(str, value)) if isinstance(value, list) else value

    read.schema_key = key  # type: ignore[attr-defined]
    return read


class SchemaOption(click.Option):
    """An option whose default is read from the experiment schema only when it is needed."""

    def _resolve(self) -> None:
        if callable(self.default) and hasattr(self.default, "schema_key"):
            self.default = self.default()

    def get_default(self, ctx, call=True):
        self._resolve()
        return super().get_default(ctx, call=call)

    def get_help_record(self, ctx):
        self._resolve()
        return super().get_help_record(ctx)


def schema_option(*decls, study: str, key: str, **kwargs):
    """``click.option`` with ``default`` = the schema's default of ``key`` for ``study``."""
    kwargs.setdefault("show_default", True)
    return click.option(*decls, cls=SchemaOption, default=schema_default(study, key), **kwargs)


# --------------------------------------------------------------------------- validators


def _check_n_jobs(ctx, param, value):
    """``--n-jobs``: the schema's rule for ``[compute] n_jobs`` (:func:`tzsl.studies.config.check_n_jobs`)."""
    from tzsl.studies.config import check_n_jobs  # noqa: PLC0415

    try:
        return value if value is None else check_n_jobs(value)
    except ValueError as exc:
        raise click.BadParameter(str(exc)) from None


def _check_seed(ctx, param, value):
    if value is not None and not 0 <= value < SEED_LIMIT:
        raise click.BadParameter(f"{value}: a seed must be in 0 .. 2**32 - 1")
    return value


def parse_seeds(ctx: click.Context | None, param: click.Parameter | None, text: object) -> list[int] | None:
    """'0,1,2' or '0-4' (or a mix) -> distinct seeds in 0 .. 2**32 - 1."""
    if text is None or isinstance(text, list | tuple):
        return None if text is None else list(text)
    seeds: list[int] = []
    for part in str(text).split(","):
        m = re.fullmatch(r"\s*(\d+)\s*(?:-\s*(\d+)\s*)?", part)
        if m is None:
            raise click.BadParameter(f"{text!r}: use non-negative integers separated by commas, or a range "
                                     "like 0-4")
        lo, hi = int(m.group(1)), int(m.group(2) or m.group(1))
        seeds += list(range(lo, hi + 1))
    if not seeds or len(set(seeds)) != len(seeds) or max(seeds) >= SEED_LIMIT:
        raise click.BadParameter(f"{text!r}: give distinct seeds in 0 .. 2**32 - 1")
    return seeds


# --------------------------------------------------------------------------- shared options

class RegistryName(click.ParamType):
    """A name checked against a registry of :mod:`tzsl.datasets` when given, so ``--help`` reads no data
    library: the built-in datasets (``"dataset"``, ``"convertible"``: those ``tzsl convert --dataset``
    writes) or the lab formats of ``tzsl convert --from`` (``"lab-format"``)."""

    name = "name"

    def __init__(self, registry: str) -> None:
        self.registry = registry

    def get_metavar(self, param, ctx=None) -> str:
        return "KIND" if self.registry == "lab-format" else "NAME"

    def convert(self, value, param, ctx):
        from tzsl.datasets import LAB_FORMATS, dataset_names  # noqa: PLC0415 (keep --help fast)

        names = {"dataset": dataset_names(), "convertible": dataset_names(convertible=True),
                 "lab-format": LAB_FORMATS}[self.registry]
        if value not in names:
            hint = "" if self.registry == "lab-format" else " ('tzsl datasets' lists them)"
            self.fail(f"{value!r}: expected one of {', '.join(names)}{hint}", param, ctx)
        return value


data_dir_option = click.option(
    "--data-dir",
    type=click.Path(file_okay=False, path_type=Path),
    default=None,
    help="Folder holding the datasets (default: $TZSL_DATA_DIR, else the user data folder).",
)
force_option = click.option("--force", is_flag=True, help="Overwrite existing results.")
no_progress_option = click.option("--no-progress", is_flag=True, help="Hide progress bars.")
no_fetch_option = click.option(
    "--no-fetch", is_flag=True,
    help="Do not download anything: a data file missing from the data home stops its study with one line "
         "(default: the registered files the studies read that are missing are fetched first, as 'tzsl data "
         "fetch' does; files present are not touched).")


def n_jobs_option(func=None, *, study: str | None = "phac2-dap", override: bool = False):
    """``--n-jobs``: parallel fits; never 0. ``override=True``: default None (= as in the file)."""
    extra = ({"default": None, "help": "Parallel fits (joblib); -1 = every core. Overrides [compute] n_jobs."}
             if override or study is None else
             {"cls": SchemaOption, "default": schema_default(study, "compute.n_jobs"), "show_default": True,
              "help": "Parallel fits (joblib); -1 = every core."})
    option = click.option("--n-jobs", type=int, callback=_check_n_jobs, **extra)
    return option(func) if func is not None else option


def seed_option(func=None, *, study: str | None = "phac2-dap", override: bool = False, help: str = "Random seed."):
    """``--seed``: one integer in 0 .. 2**32 - 1 (``override``: default None = as in the file)."""
    extra: dict[str, Any]  # click.option's keywords
    if override:
        extra = {"default": None, "help": help + " Overrides [splits] seed."}
    elif study is None:  # a command outside the studies (simulator, single model fit)
        extra = {"default": 0, "show_default": True, "help": help}
    else:
        extra = {"cls": SchemaOption, "default": schema_default(study, "splits.seed"), "show_default": True,
                 "help": help}
    option = click.option("--seed", type=int, callback=_check_seed, **extra)
    return option(func) if func is not None else option


def backend_option(func=None, *, override: bool = False):
    extra = ({"default": None, "help": "joblib backend (overrides [compute] backend)."} if override else
             {"cls": SchemaOption, "default": schema_default("phac2-dap", "compute.backend"), "show_default": True,
              "help": "joblib backend; 'dask' runs the fits on a Dask cluster (see --scheduler)."})
    option = click.option("--backend", type=click.Choice(STUDY_BACKENDS), **extra)
    return option(func) if func is not None else option


scheduler_option = click.option(
    "--scheduler",
    default=None,
    help="Dask scheduler address (tcp://host:port) for --backend dask; default: a local cluster.",
)


@click.group(cls=TzslGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="tzsl")
def cli() -> None:
    """tzsl: tactile zero-shot learning.

    Learn attribute detectors ("hard", "porous", ...) from touch data of known objects,
    then recognise objects never touched from their attribute description alone.

    Exit codes: 0 success, 1 failure outside the input (interrupted, out of memory),
    2 usage error, 3 bad input data or configuration.
    """
