"""``tzsl benchmark``: every registered method on every benchmark dataset's standard splits, compared across."""

from __future__ import annotations

from pathlib import Path

import click

from tzsl.cli._root import cli, data_dir_option, force_option, n_jobs_option


@cli.command()
@click.option("--dataset", "datasets", multiple=True, metavar="NAME",
              help="A benchmark dataset to run (repeat for several) [default: every one: 'tzsl benchmark --list'].")
@click.option("--add", "added", multiple=True, type=click.Path(file_okay=False, path_type=Path), metavar="FOLDER",
              help="Also run a lab's plain-file dataset folder (tzsl formats) on the same methods, metrics and "
                   "split recipe, beside the catalog's (repeat for several).")
@click.option("--no-catalog", is_flag=True,
              help="Run only the --add datasets (with the benchmark's methods, metrics and split recipe).")
@click.option("--method", "methods", multiple=True, metavar="NAME",
              help="Run only these registered methods ('tzsl methods'; repeat) [default: every registered method, "
                   "and DAP with the rbf-svm detector beside the study's; with --defaults also the auto one].")
@click.option("--detector", "detectors", multiple=True, metavar="FAMILY",
              help="Also run DAP with this detector family (e.g. robust-logistic; repeat for several).")
@click.option("--purpose", type=click.Choice(["select", "confirm"]), default="confirm", show_default=True,
              help="The standard splits to run: confirmation (to report, the leaderboard's) or selection (to "
                   "choose a default on).")
@click.option("--out", type=click.Path(file_okay=False, path_type=Path), default=Path("results/benchmark"),
              show_default=True, help="Folder of the benchmark's tables, figures, experiment files and studies.")
@click.option("--max-splits", type=click.IntRange(min=1), default=None, metavar="N",
              help="Run only the first N standard splits of each dataset: a quick look (said so on the terminal and "
                   "in the manifest), not the benchmark's numbers.")
@click.option("--defaults", "defaults_from", type=click.Path(file_okay=False, path_type=Path), default=None,
              metavar="SELECT_FOLDER",
              help="Also choose the defaults across datasets: on the selection scores of SELECT_FOLDER (a --purpose "
                   "select benchmark) with each dataset left out, scored on this run's confirmation splits "
                   "(defaults.csv), beside DAP with detector auto, which such a run adds.")
@click.option("--list", "list_only", is_flag=True, help="List the benchmark's datasets and their standard splits.")
@n_jobs_option(study="zero-shot")
@data_dir_option
@force_option
def benchmark(datasets, added, no_catalog, methods, detectors, purpose, out, max_splits, defaults_from, list_only,
              n_jobs, data_dir, force) -> None:
    """Run the tactile zero-shot benchmark: every registered method on every catalog dataset.

    Each dataset is one zero-shot study on its standard splits (tzsl splits v1), run through the same
    engine as 'tzsl run' (its experiment file is written to OUT/experiments, so it can be run alone);
    the study cache restores a dataset whose settings, code and data did not change, so a rerun (with
    --force) takes seconds and a new method or dataset costs only its own fits. Writes per dataset a
    results table with intervals and chance, and across datasets the mean rank, a Friedman test with
    its critical-difference diagram and every pair of methods' paired effect meta-analysed across
    datasets (docs: benchmark).
    """
    from tzsl.studies.benchmark.command import list_benchmark, run_benchmark_command  # noqa: PLC0415

    if list_only:
        for line in list_benchmark():
            click.echo(line)
        return
    run_benchmark_command(datasets=datasets, added=added, catalog=not no_catalog, methods=methods,
                          detectors=detectors, purpose=purpose,
                          out=out, n_jobs=n_jobs, data_dir=data_dir, force=force, max_splits=max_splits,
                          defaults_from=defaults_from, echo=click.echo)
