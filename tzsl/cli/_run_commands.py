"""Config-driven commands: ``run`` (a whole study from a TOML file) and ``report`` (one HTML page)."""

from __future__ import annotations

import time
from pathlib import Path

import click

from tzsl.cli._main import cli, data_dir_option, force_option


@cli.command()
@click.argument("experiment", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--out", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Results folder (default: [output] folder of the file, relative to the current directory).")
@click.option("--n-jobs", type=int, default=None, help="Parallel fits; overrides [compute] n_jobs.")
@click.option("--no-progress", is_flag=True, help="Hide progress bars (overrides [compute] progress).")
@click.option("--check", is_flag=True, help="Only check the experiment file and print its resolved settings.")
@data_dir_option
@force_option
def run(experiment: Path, out: Path | None, n_jobs: int | None, no_progress: bool, check: bool,
        data_dir: Path | None, force: bool) -> None:
    """Run a whole study described by an experiment file (TOML).

    The file names the study (study = "phac2-dap", "fabric" or "hand"), the dataset (a
    built-in one, a feature table or a plain-file folder; paths relative to the file), the
    features, methods, splits, SVM grids and output folder. Every unknown key or wrong type
    is reported with the file name and key path. Copy one of experiments/*.toml to start
    (see experiments/README.md).
    """
    from tzsl.experiments.config_run import load_experiment, run_experiment  # noqa: PLC0415

    exp = load_experiment(experiment)
    if check:
        click.echo(f"{experiment}: valid ({exp.study})")
        for table, values in exp.settings.items():
            click.echo(f"[{table}]")
            for key, value in values.items():
                click.echo(f"  {key} = {value!r}")
        return
    start = time.perf_counter()
    results = run_experiment(exp, out=out, force=force, n_jobs=n_jobs, progress=False if no_progress else None,
                             data_dir=data_dir, echo=click.echo)
    click.echo(f"\nwrote {len(results.written)} files to {results.root} in {time.perf_counter() - start:.0f} s")


@cli.command()
@click.argument("results_dir", type=click.Path(file_okay=False, path_type=Path))
@click.option("--out", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="HTML file to write (default: RESULTS_DIR/report.html).")
@force_option
def report(results_dir: Path, out: Path | None, force: bool) -> None:
    """Write one self-contained HTML page of a results folder.

    Every CSV table (paper columns shaded), every PNG figure (embedded) and every manifest
    (collapsible), with the tzsl version and date. No other file is needed to view it.
    """
    from tzsl.experiments.report import write_report  # noqa: PLC0415

    path = write_report(results_dir, out=out, force=force)
    click.echo(f"wrote {path} ({path.stat().st_size / 1024:.0f} KiB)")
