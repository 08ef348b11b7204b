"""The engine's commands: ``run`` (an experiment file or a built-in study), ``reproduce-tables``, ``evidence``,
``report``."""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from pathlib import Path

import click

from tzsl.cli._root import (
    backend_option,
    cli,
    data_dir_option,
    force_option,
    n_jobs_option,
    no_fetch_option,
    no_progress_option,
    scheduler_option,
    seed_option,
)
from tzsl.exceptions import PartialRunError
from tzsl.studies.reproduce import EVIDENCE_STUDIES, REPRODUCE_STUDIES  # light: the default lists for --help

#: ``--verbose`` of ``run``, ``reproduce-tables`` and ``evidence``.
verbose_option = click.option(
    "--verbose", is_flag=True,
    help="Also print every table the study writes (the CSVs) as it is computed, before the summary. Without it "
         "the run prints its notes and one screen: the dataset, what was relaxed, the most accurate methods against "
         "chance with their 95% intervals, the method to deploy and where the CSVs and the report are. The files "
         "are the same either way.")


def override_options(func):
    """--out, --n-jobs, --seed, --backend, --scheduler, --no-progress, --data-dir: override the file."""
    for option in (scheduler_option, backend_option(override=True), seed_option(override=True),
                   n_jobs_option(override=True)):
        func = option(func)
    func = click.option("--out", type=click.Path(file_okay=False, path_type=Path), default=None,
                        help="Results folder (default: [output] folder, relative to the current directory).")(func)
    return no_fetch_option(no_progress_option(data_dir_option(force_option(func))))


def _overrides(out, n_jobs, seed, backend, scheduler, no_progress, data_dir) -> dict:
    return {"out": out, "n_jobs": n_jobs, "seed": seed, "backend": backend, "scheduler": scheduler,
            "progress": False if no_progress else None, "data_dir": data_dir}


@cli.command()
@click.argument("experiment")
@override_options
@click.option("--check", is_flag=True, help="Only check everything a run would fail on (settings, paths, split "
              "file, Dask scheduler), before any fit.")
@click.option("--print-config", is_flag=True, help="Print the resolved experiment as TOML (every default filled in) "
              "and stop.")
@click.option("--profile", is_flag=True, help="Print where the time went: wall and CPU seconds per study and stage "
              "(always recorded in manifest.json).")
@verbose_option
def run(experiment: str, out, n_jobs, seed, backend, scheduler, no_progress, no_fetch, data_dir, force, check: bool,
        print_config: bool, profile: bool, verbose: bool) -> None:
    """Run a study: an experiment file (TOML) or a built-in study by NAME.

    Built-in studies: phac2-dap, phac2-evidence, phac2-gzsl, phac2-headlines, fabric, fabric-evidence,
    fabric-deep, hand-simulated, hand-evidence, active-touch (the files
    in tzsl/studies/builtin/; print one with 'tzsl run NAME --print-config'). Every
    unknown key, wrong type or bad value is reported as FILE: key.path: reason. Options
    override the file's settings. See experiments/README.md.

    A study on a built-in dataset first fetches the registered files it reads that are missing
    from the data home (one line says what, where to and how big; --no-fetch: stop instead).

    The run ends with one screen (at most 40 lines of at most 100 characters): the dataset, what
    was relaxed, per split kind the most accurate methods against chance with their 95% intervals
    and whether any interval clears chance, the method to deploy, and where the CSVs and the report
    are. --verbose also prints every table, before it. Progress bars show only on a terminal.
    """
    from tzsl.studies.config import get_study, load_experiment, to_toml  # noqa: PLC0415
    from tzsl.studies.engine import check_experiment, run_experiment  # noqa: PLC0415

    exp = load_experiment(experiment, options=_overrides(out, n_jobs, seed, backend, scheduler, no_progress, data_dir))
    if print_config:
        click.echo(to_toml(exp.config), nl=False)
        return
    if check:
        check_experiment(exp)
        notes = get_study(exp.study).hook("notes")
        for note in notes(exp) if notes is not None else []:  # may read the dataset and split file; no fit
            click.echo(f"note: {note}")
        click.echo(f"{exp.source}: valid ({exp.study}); 'tzsl run {experiment} --print-config' shows every value")
        return
    start = time.perf_counter()
    screen = _Screen(verbose)
    if not no_fetch:
        from tzsl.studies.reproduce import fetch_study_data  # noqa: PLC0415

        check_experiment(exp)
        fetch_study_data([exp], (experiment,), screen.echo, progress=not no_progress)
    try:
        results, done = run_experiment(exp, force=force, echo=screen.echo, study_echo=screen.study_echo())
    except PartialRunError as exc:  # everything is written: the summary, then the failures (exit 1)
        screen.summary(exc.results, exc.run)  # type: ignore[attr-defined]  # set by run_experiment
        raise
    screen.summary(results, done)
    click.echo(f"\nwrote {len(results.written)} files to {results.root} in {time.perf_counter() - start:.0f} s")
    if profile:
        _echo_profile(done.record["profile"])


class _Screen:
    """What a run prints: the study's ``note:`` lines (with --verbose every line of the study, its tables
    too), then the summary (:mod:`tzsl.reporting.terminal`), fitted into one screen with the lines
    printed before it (with --verbose: after the tables, in full)."""

    def __init__(self, verbose: bool) -> None:
        self.verbose = verbose
        self.lines = 0

    def echo(self, message: str) -> None:
        click.echo(message)
        self.lines += message.count("\n") + 1

    def study_echo(self) -> Callable[[str], None]:
        """Where the study's own lines go."""
        if self.verbose:
            return self.echo
        from tzsl.reporting.terminal import notes_only  # noqa: PLC0415

        return notes_only(self.echo)

    def summary(self, results, done) -> None:
        """The summary after a run (:func:`tzsl.reporting.terminal.run_summary`)."""
        from tzsl.reporting.terminal import run_summary  # noqa: PLC0415

        click.echo("")
        printed = 0 if self.verbose else self.lines  # --verbose: the screen holds the tables already
        for line in run_summary(done.tables, done.record, results.final_root, results.written, printed=printed):
            click.echo(line)


def _study_list_options(default_out: Path, studies: tuple[str, ...]):
    """The options of a study-list command (``reproduce-tables``, ``evidence``): written once for both."""
    def decorate(func):
        for option in (
            click.option("--study", "studies", multiple=True, metavar="NAME",
                         help="Run only this study (a built-in name or an experiment file); repeatable. Default: "
                         f"{', '.join(studies)}."),
            click.option("--profile", is_flag=True, help="Print where the time went: wall and CPU seconds per study "
                         "and stage (always recorded in manifest.json)."),
            verbose_option, force_option, data_dir_option, no_fetch_option, no_progress_option, scheduler_option,
            backend_option(override=True),
            n_jobs_option(override=True),
            click.option("--out", type=click.Path(file_okay=False, path_type=Path), default=default_out,
                         show_default=True, help="Results folder."),
        ):
            func = option(func)
        return func
    return decorate


def _echo_study_lines(name: str, done) -> None:
    """A few lines after each study of a study list (:func:`tzsl.reporting.terminal.study_lines`)."""
    from tzsl.reporting.terminal import study_lines  # noqa: PLC0415

    for line in study_lines(done.tables):
        click.echo(line)


def _run_study_list(command: str, out, n_jobs, backend, scheduler, no_progress, no_fetch, data_dir, force, profile,
                    studies, verbose: bool) -> None:
    from tzsl.studies.reproduce import run_studies  # noqa: PLC0415

    start = time.perf_counter()
    screen = _Screen(verbose)
    results = run_studies(command, out, force=force, echo=click.echo, studies=tuple(studies) or None,
                          fetch=not no_fetch, n_jobs=n_jobs, backend=backend, scheduler=scheduler,
                          progress=False if no_progress else None, data_dir=data_dir,
                          study_echo=screen.study_echo(), on_study=_echo_study_lines)
    click.echo(f"\nwrote {len(results.written)} files to {out} in {time.perf_counter() - start:.0f} s")
    hint = "" if verbose else "; --verbose prints every table"
    click.echo(f"report: tzsl report {out} (writes report.html there){hint}")
    if profile:
        _echo_profile(json.loads((Path(out) / "manifest.json").read_text())["profile"])


@cli.command("reproduce-tables")
@_study_list_options(Path("results"), REPRODUCE_STUDIES)
def reproduce_tables(out, n_jobs, backend, scheduler, no_progress, no_fetch, data_dir, force, profile, studies,
                     verbose):
    """Every table (CSV) and figure (PNG) the two papers report, from the real data, paper numbers beside ours.

    Runs the built-in studies of the papers (the default of --study), in that order, exactly as
    'tzsl run NAME' does, into one folder with one manifest.json: what the papers report, with
    our intervals, chance, baselines and controls, and nothing else ('tzsl evidence' runs the
    rest). The hand study runs on SIMULATED grasps (the paper's Shadow-hand data are not public).

    On first use, before the first study, it fetches the registered data files the studies read
    that are missing from the data home (one line says what, where to and how big; then the
    registry's URLs, hash checks and progress bars of 'tzsl data fetch'). --no-fetch: stop instead.
    """
    _run_study_list("reproduce-tables", out, n_jobs, backend, scheduler, no_progress, no_fetch, data_dir, force,
                    profile, studies, verbose)


@cli.command("evidence")
@_study_list_options(Path("results") / "evidence", EVIDENCE_STUDIES)
def evidence(out, n_jobs, backend, scheduler, no_progress, no_fetch, data_dir, force, profile, studies, verbose):
    """The evidence beyond the papers: every method on every dataset, GZSL, calibration, active touch, headlines.

    Runs the built-in studies beyond the papers (the default of --study), in that order, exactly as
    'tzsl run NAME' does, into one folder with one manifest.json and method_comparison.csv (every
    registered method x study). Tens of minutes cold on two cores; the fit store (TZSL_CACHE_DIR)
    reads back what reproduce-tables fitted. Missing data files are fetched first, as by
    reproduce-tables (--no-fetch: stop instead).
    """
    _run_study_list("evidence", out, n_jobs, backend, scheduler, no_progress, no_fetch, data_dir, force, profile,
                    studies, verbose)


def _echo_profile(rows: list[dict]) -> None:
    from tzsl._profile import profile_lines  # noqa: PLC0415

    click.echo("\nwhere the time went (exclusive seconds per stage; 'other': no stage claimed it)")
    for line in profile_lines(rows):
        click.echo(line)


@cli.command()
@click.argument("results_dir", type=click.Path(file_okay=False, path_type=Path))
@click.option("--out", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="HTML file to write (default: RESULTS_DIR/report.html).")
@force_option
def report(results_dir: Path, out: Path | None, force: bool) -> None:
    """Write one self-contained HTML page of a results folder.

    A study of your own dataset opens with the dataset's card and a summary (the best method
    against chance and the trivial baseline, with intervals; what was relaxed), then sections
    named for what they show; the papers' presets keep the papers' headings and deviations. Wide
    tables show their key columns (the rest behind 'show'), every PNG figure is embedded and
    every manifest collapsible, with the tzsl version and date. No other file is needed to view it.
    """
    from tzsl.reporting.report import write_report  # noqa: PLC0415

    path = write_report(results_dir, out=out, force=force)
    click.echo(f"wrote {path} ({path.stat().st_size / 1024:.0f} KiB)")
