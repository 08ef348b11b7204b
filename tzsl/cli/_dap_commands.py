"""PHAC-2 / DAP commands: ``splits``, ``train-attributes``, ``evaluate``, ``reproduce-tables``, ``bench``."""

from __future__ import annotations

import time
from pathlib import Path

import click

from tzsl.cli._main import (
    backend_option,
    cli,
    data_dir_option,
    force_option,
    n_jobs_option,
    scheduler_option,
    seed_option,
)
from tzsl.exceptions import ConfigError


def _source_options(func):
    """--dataset / --features / --plain / --path: where the features come from."""
    func = click.option("--path", type=click.Path(dir_okay=False, path_type=Path), default=None,
                        help="Input HDF5 file for --dataset phac2-h5.")(func)
    func = click.option("--plain", "plain_dir", type=click.Path(file_okay=False, path_type=Path), default=None,
                        help="A plain-file dataset folder (see 'tzsl formats') instead of a built-in dataset.")(func)
    func = click.option("--features", "features_file", type=click.Path(dir_okay=False, path_type=Path),
                        default=None, help="A feature table written by 'tzsl extract --out'.")(func)
    func = click.option("--dataset", type=click.Choice(["phac2-penn", "phac2-h5", "phac2-hold-mat"]),
                        default="phac2-penn", show_default=True, help="Built-in dataset.")(func)
    return func


def _study_options(func):
    """Options of the attribute-classifier fits shared by train/evaluate/reproduce (incl. seed and compute)."""
    for option in (scheduler_option, backend_option, n_jobs_option, seed_option):
        func = option(func)
    func = click.option("--undersampling", type=click.Choice(["select", "bagging", "none"]), default="select",
                        show_default=True, help="Class-0 under-sampling: keep the best draw (chosen on training "
                        "objects by grouped CV), bag all draws, or none.")(func)
    func = click.option("--cv", type=int, default=5, show_default=True,
                        help="Object-grouped, stratified CV folds for tuning C, gamma and the under-sampling "
                        "draw on training objects; 0 = leave-one-object-out as in the paper (about 7x slower, "
                        "same accuracy in our measurements).")(func)
    func = click.option("--no-progress", is_flag=True, help="Hide progress bars.")(func)
    func = click.option("--no-cache", is_flag=True, help="Do not cache fitted attribute models (default: cache "
                        "under $TZSL_CACHE_DIR or the user cache folder, so interrupted runs resume).")(func)
    return func


def _config(seed, n_jobs, backend, scheduler, undersampling, cv, no_progress, no_cache, **extra):
    from tzsl.experiments.phac2_dap import DapStudyConfig  # noqa: PLC0415

    if cv < 0 or cv == 1:
        raise ConfigError(f"--cv {cv}: use 0 (leave-one-object-out) or at least 2 folds")
    svm = {"cv": None if cv == 0 else cv}
    return DapStudyConfig(seed=seed, n_jobs=n_jobs, backend=backend, scheduler=scheduler,
                          undersampling=undersampling, svm_params=svm, progress=not no_progress,
                          cache=not no_cache, **extra)


@cli.command()
@click.option("--kind", type=click.Choice(["random", "challenging"]), default="random", show_default=True)
@click.option("--n-splits", type=int, default=5, show_default=True, help="Random splits to draw.")
@click.option("--n-test", type=int, default=10, show_default=True, help="Test objects per random split.")
@click.option("--out", type=click.Path(dir_okay=False, path_type=Path), required=True, help="Split CSV to write.")
@_source_options
@seed_option
@data_dir_option
@force_option
def splits(kind, n_splits, n_test, out, dataset, features_file, plain_dir, path, seed, data_dir, force):
    """Write object splits as CSV (split, object, role), usable with 'tzsl evaluate --splits'."""
    from tzsl.evaluation import write_splits_csv  # noqa: PLC0415
    from tzsl.experiments.phac2_dap import DapStudyConfig, make_splits  # noqa: PLC0415
    from tzsl.experiments.sources import load_study_features  # noqa: PLC0415

    if out.exists() and not force:
        raise ConfigError(f"{out} already exists; use --force to overwrite")
    features = load_study_features(dataset, features_file, plain_dir, data_dir, path)
    made, _ = make_splits(features, kind, DapStudyConfig(n_splits=n_splits, n_test=n_test, seed=seed))
    write_splits_csv(made, out)
    for s in made:
        excluded = ", ".join(a for a, _ in s.excluded_attributes) or "none"
        click.echo(f"{s.name}: {len(s.train_objects)} train / {s.n_test} test objects; excluded attributes: "
                   f"{excluded}")
    click.echo(f"wrote {out}")


@cli.command("train-attributes")
@click.option("--splits", "splits_file", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Train on the training objects of one split of this CSV (see --split-name).")
@click.option("--split-name", default=None, help="Which split of --splits (default: the first).")
@click.option("--fusion", type=click.Choice(["avg", "max"]), default="avg", show_default=True,
              help="Sensor fusion stored in the bundle for 'tzsl predict'.")
@click.option("--prior", type=click.Choice(["uni", "train", "test"]), default="uni", show_default=True,
              help="Attribute prior stored in the bundle.")
@click.option("--save", type=click.Path(dir_okay=False, path_type=Path), required=True,
              help="Model bundle to write (e.g. model.tzsl).")
@_source_options
@_study_options
@data_dir_option
@force_option
def train_attributes(splits_file, split_name, fusion, prior, save, dataset, features_file, plain_dir, path,
                     undersampling, cv, no_progress, no_cache, seed, n_jobs, backend, scheduler, data_dir, force):
    """Fit the per-attribute, per-sensor SVMs and save them as a model bundle.

    Without --splits every object trains the classifiers (a model for recognising new objects);
    with --splits only that split's training objects do.
    """
    from tzsl.experiments.phac2_dap import train_attribute_model  # noqa: PLC0415
    from tzsl.experiments.sources import load_study_features  # noqa: PLC0415

    if save.exists() and not force:
        raise ConfigError(f"{save} already exists; use --force to overwrite")
    features = load_study_features(dataset, features_file, plain_dir, data_dir, path)
    config = _config(seed, n_jobs, backend, scheduler, undersampling, cv, no_progress, no_cache)
    start = time.perf_counter()
    summary = train_attribute_model(features, config, save, splits_file=splits_file, split_name=split_name,
                                    fusion=fusion, prior=prior, force=force)
    click.echo(summary.to_string(index=False, float_format=lambda v: f"{v:.3g}"))
    click.echo(f"fitted {len(summary)} attribute classifiers in {time.perf_counter() - start:.1f} s; wrote {save}")


@cli.command()
@click.option("--split", "kind", type=click.Choice(["random", "challenging", "both"]), default="random",
              show_default=True, help="Split family (paper Tables 1-2: random; Table 3: challenging).")
@click.option("--splits", "splits_file", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Use the splits of this CSV instead (see 'tzsl splits').")
@click.option("--n-splits", type=int, default=5, show_default=True)
@click.option("--n-test", type=int, default=10, show_default=True)
@click.option("--multilabel/--no-multilabel", default=False, show_default=True,
              help="Also fit the joint (multi-label) attribute model on the random splits.")
@click.option("--sweep/--no-sweep", default=False, show_default=True, help="Attribute-count sweep (F10).")
@click.option("--out", type=click.Path(file_okay=False, path_type=Path), default=Path("results"), show_default=True)
@_source_options
@_study_options
@data_dir_option
@force_option
def evaluate(kind, splits_file, n_splits, n_test, multilabel, sweep, out, dataset, features_file, plain_dir, path,
             undersampling, cv, no_progress, no_cache, seed, n_jobs, backend, scheduler, data_dir, force):
    """Zero-shot recognition with DAP per split and on average, beside the paper's numbers."""
    from tzsl.evaluation import read_splits_csv  # noqa: PLC0415
    from tzsl.experiments._outputs import ResultsDir  # noqa: PLC0415
    from tzsl.experiments.phac2_dap import run_dap_study  # noqa: PLC0415
    from tzsl.experiments.sources import load_study_features  # noqa: PLC0415

    features = load_study_features(dataset, features_file, plain_dir, data_dir, path)
    config = _config(seed, n_jobs, backend, scheduler, undersampling, cv, no_progress, no_cache, n_splits=n_splits,
                     n_test=n_test, multilabel=multilabel)
    results = ResultsDir(out, force=force)
    user_splits = None
    if splits_file is not None:
        user_splits = read_splits_csv(splits_file, features.attributes,
                                      min_train_positives=config.random_min_train_positives)
    kinds = ("random", "challenging") if kind == "both" else (kind,)
    run_dap_study(features, results, config, kinds=kinds, splits=user_splits, sweep=sweep, echo=click.echo)
    results.write_manifest({"study": "phac2-dap", "dataset": features.dataset, "kinds": list(kinds),
                            "splits_file": None if splits_file is None else str(splits_file),
                            **config.__dict__}, data_files=features.info.get("data_files", []),
                           name="manifest_evaluate.json")
    click.echo(f"\nwrote {len(results.written)} files to {out}")


@cli.command("reproduce-tables")
@click.option("--out", type=click.Path(file_okay=False, path_type=Path), default=Path("results"), show_default=True)
@click.option("--fabric-seeds", type=int, default=5, show_default=True, help="Seeds of the fabric embedding model.")
@click.option("--hand-seeds", type=int, default=5, show_default=True, help="Simulated hand data sets (seeds 0..N-1).")
@_study_options
@data_dir_option
@force_option
def reproduce_tables(out, fabric_seeds, hand_seeds, undersampling, cv, no_progress, no_cache, seed, n_jobs, backend, scheduler,
                     data_dir, force):
    """Every table (CSV) and figure (PNG) of both papers from the real data, paper numbers beside ours.

    PHAC-2 DAP study (Tables 1-3, multi-label, per-attribute accuracy, attribute sweep, DAP vs
    ESZSL vs embedding), fabric study (Table 1 analogue on the real depth images) and the hand
    study on simulated grasps (the paper's Shadow-hand data are not public). A manifest records
    configuration, seeds, data checksums and package versions.
    """
    from tzsl.experiments.reproduce import reproduce_tables as run  # noqa: PLC0415

    config = _config(seed, n_jobs, backend, scheduler, undersampling, cv, no_progress, no_cache, multilabel=True)
    start = time.perf_counter()
    results = run(out, data_dir=data_dir, config=config, force=force, hand_seeds=tuple(range(hand_seeds)),
                  fabric_seeds=fabric_seeds, echo=click.echo)
    click.echo(f"\nwrote {len(results.written)} files to {out} in {time.perf_counter() - start:.0f} s")


@cli.command()
@click.option("--split-index", type=int, default=0, show_default=True, help="Which random split to time.")
@click.option("--skip-literal", is_flag=True, help="Time only tzsl (the literal recipe takes tens of minutes).")
@click.option("--out", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Also write the timings as CSV.")
@seed_option
@data_dir_option
@force_option
def bench(split_index, skip_literal, out, seed, data_dir, force):
    """Time one random PHAC-2 split: the paper's literal recipe vs tzsl (n_jobs 1 and 2), with accuracies."""
    from tzsl.experiments.bench import run_bench  # noqa: PLC0415
    from tzsl.experiments.extract import extract_features  # noqa: PLC0415
    from tzsl.experiments.phac2_dap import DapStudyConfig  # noqa: PLC0415

    if out is not None and out.exists() and not force:
        raise ConfigError(f"{out} already exists; use --force to overwrite")
    features = extract_features("phac2-penn", data_dir=data_dir)
    table = run_bench(features, DapStudyConfig(seed=seed), split_index=split_index, skip_literal=skip_literal,
                      echo=click.echo)
    click.echo(table.to_string(index=False, float_format=lambda v: f"{v:.3f}"))
    if out is not None:
        from tzsl._io import atomic_write  # noqa: PLC0415

        atomic_write(out, lambda p: table.to_csv(p, index=False))
        click.echo(f"wrote {out}")
