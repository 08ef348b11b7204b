"""PHAC-2 / DAP commands: ``splits``, ``train-attributes``, ``evaluate``, ``bench``.

``evaluate`` is a front-end of the engine: its options become a ``study = "phac2-dap"``
experiment (:func:`tzsl.studies.config.config_from_options`) run by
:func:`tzsl.studies.engine.run_experiment`, so it writes exactly what the matching TOML
file writes. Option defaults come from the schema.
"""

from __future__ import annotations

import time
from pathlib import Path

import click

from tzsl.cli._root import (
    RegistryName,
    backend_option,
    cli,
    data_dir_option,
    force_option,
    n_jobs_option,
    no_progress_option,
    scheduler_option,
    schema_option,
    seed_option,
)
from tzsl.exceptions import ConfigError
from tzsl.value_lists import FUSIONS, PRIORS, SPLIT_KINDS

STUDY = "phac2-dap"


def _source_options(func):
    """--dataset / --features / --plain / --path: where the features come from."""
    func = click.option("--path", type=click.Path(dir_okay=False, path_type=Path), default=None,
                        help="Input HDF5 file for --dataset phac2-h5.")(func)
    func = click.option("--plain", "plain_dir", type=click.Path(file_okay=False, path_type=Path), default=None,
                        help="A plain-file dataset folder (see 'tzsl formats') instead of a built-in dataset.")(func)
    func = click.option("--features", "features_file", type=click.Path(dir_okay=False, path_type=Path),
                        default=None, help="A feature table written by 'tzsl extract --out'.")(func)
    func = click.option("--dataset", type=RegistryName("dataset"), default=None,
                        help="Built-in dataset ('tzsl datasets' lists them) [default: phac2-penn unless --plain or "
                             "--features].")(func)
    return func


def _study_options(func):
    """Options of the attribute-classifier fits shared by train-attributes and evaluate."""
    for option in (scheduler_option, backend_option, n_jobs_option, seed_option):
        func = option(func)
    func = schema_option("--undersampling", study=STUDY, key="svm.undersampling",
                         type=click.Choice(["select", "bagging", "none"]),
                         help="Class-0 under-sampling: keep the best draw (chosen on training objects by grouped "
                              "CV), bag all draws, or none.")(func)
    func = schema_option("--cv", study=STUDY, key="svm.cv", type=click.IntRange(min=0),
                         help="Object-grouped, stratified CV folds for tuning C, gamma and the under-sampling draw "
                              "on training objects; 0 = leave-one-object-out as in the paper (about 7x slower, same "
                              "accuracy in our measurements).")(func)
    func = schema_option("--grid", study=STUDY, key="svm.grid", type=click.Choice(["paper", "extended", "adaptive"]),
                         help="Gamma grid of the attribute SVMs: the paper's, tzsl's extended one (two decades "
                              "below the paper's lower edge, where most fits choose the edge), or adaptive (the "
                              "extended grid, widened by log steps at whichever end of C or gamma is chosen).")(func)
    func = no_progress_option(func)
    func = click.option("--no-cache", is_flag=True, help="Do not cache fitted attribute models (default: cache "
                        "under $TZSL_CACHE_DIR or the user cache folder, so interrupted runs resume).")(func)
    return func


def _dataset_values(dataset, features_file, plain_dir, path, data_dir) -> dict:
    if dataset is None and features_file is None and plain_dir is None:
        dataset = "phac2-penn"
    from tzsl.studies.config import option_values  # noqa: PLC0415

    values = {"dataset.builtin": dataset, "dataset.features": features_file, "dataset.plain": plain_dir,
              "dataset.path": path}
    return {**{k: None if v is None else str(v) for k, v in values.items()},
            **option_values(STUDY, {"data_dir": data_dir})}


def _study_values(seed, n_jobs, backend, scheduler, undersampling, cv, grid, no_progress, no_cache) -> dict:
    from tzsl.studies.config import option_values  # noqa: PLC0415

    shared = option_values(STUDY, {"seed": seed, "n_jobs": n_jobs, "backend": backend, "scheduler": scheduler,
                                   "progress": not no_progress})
    return {**shared, "svm.undersampling": undersampling, "svm.cv": cv, "svm.grid": grid,
            "compute.cache": not no_cache}


def _experiment(values: dict):
    from tzsl.studies.config import config_from_options  # noqa: PLC0415

    return config_from_options(STUDY, values)


#: ``--purpose`` of ``tzsl splits`` and ``tzsl evaluate`` (``[splits] purpose``).
purpose_option = schema_option(
    "--purpose", study=STUDY, key="splits.purpose", type=click.Choice(["select", "confirm"]),
    help="Selection splits (to make a choice) or confirmation splits (to report it); no seed of one draws a "
         "random split of the other.")


@cli.command()
@click.option("--split", "kind", type=click.Choice(SPLIT_KINDS), default="random", show_default=True,
              help="Split family.")
@schema_option("--n-splits", study=STUDY, key="splits.n_splits", type=click.IntRange(min=1),
               help="Random splits to draw.")
@schema_option("--n-test", study=STUDY, key="splits.n_test", type=click.IntRange(min=1),
               help="Test objects per random split.")
@purpose_option
@click.option("--out", type=click.Path(dir_okay=False, path_type=Path), required=True, help="Split CSV to write.")
@click.option("--standard", metavar="VERSION", default=None,
              help="Write the standard splits VERSION (v1) shipped for the built-in --dataset, those of --purpose, "
                   "instead of drawing: the same test objects for everyone who names them ('tzsl benchmark "
                   "--list' lists the datasets; docs: benchmark).")
@_source_options
@seed_option
@data_dir_option
@force_option
def splits(kind, n_splits, n_test, purpose, out, standard, dataset, features_file, plain_dir, path, seed, data_dir,
           force):
    """Write object splits as CSV (split, object, role), usable with 'tzsl evaluate --splits'."""
    from tzsl.evaluation import write_splits_csv  # noqa: PLC0415
    from tzsl.studies.zero_shot.runner import load_study_features  # noqa: PLC0415
    from tzsl.studies.zero_shot.study import make_splits  # noqa: PLC0415

    if out.exists() and not force:
        raise ConfigError(f"{out} already exists; use --force to overwrite")
    exp = _experiment({**_dataset_values(dataset, features_file, plain_dir, path, data_dir),
                       "splits.n_splits": n_splits, "splits.n_test": n_test, "splits.seed": seed,
                       "splits.purpose": purpose})
    if standard is not None:
        from tzsl.studies.benchmark.splits import read_standard_splits, standard_split_file  # noqa: PLC0415

        if exp.config.dataset.builtin is None:
            raise ConfigError("--standard needs a built-in --dataset: standard splits exist for the benchmark's "
                              "datasets ('tzsl benchmark --list')")
        standard_split_file(exp.config.dataset.builtin, standard)  # an unknown version or dataset before any read
        made = read_standard_splits(exp.config.dataset.builtin, load_study_features(exp).attributes, purpose,
                                    standard)
    else:
        made, _ = make_splits(load_study_features(exp), kind, exp.config)
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
@click.option("--fusion", type=click.Choice(FUSIONS), default=None,
              help="Sensor fusion of the default DAP model's rule [default: the default method's].")
@click.option("--prior", type=click.Choice(PRIORS), default=None,
              help="Attribute prior of the default DAP model's rule [default: the default method's].")
@click.option("--out", type=click.Path(dir_okay=False, path_type=Path), required=True,
              help="Model bundle to write (e.g. model.tzsl).")
@click.option("--method", default=None,
              help="A registered attribute model + decision rule method ('tzsl methods'), fitted with its defaults "
                   "[default: tzsl.models.choices.DEFAULT_METHOD, the generic zero-shot study's default; a DAP "
                   "method takes --cv, --grid, --undersampling, --fusion and --prior].")
@click.option("--from-results", "from_results", type=click.Path(path_type=Path), default=None,
              help="Train the method a zero-shot study chose (FOLDER/deployment.json of 'tzsl run'): that method "
                   "and configuration, on every object of the study's dataset, with the study's seed.")
@click.option("--per-ep", is_flag=True,
              help="Fit one attribute model per exploratory procedure (PHAC-2 features '<ep>:<name>') and the EPs' "
                   "confusion, for 'tzsl predict --eps-done ... --suggest-next' (active touch).")
@click.option("--min-objects", type=click.IntRange(min=1), default=None,
              help="Keep only attributes present in at least this many objects ([dataset] min_objects of a study) "
                   "[default: the study's: the extractor's filter for built-in datasets, every attribute of a "
                   "plain folder]. Whatever the filter, an attribute with too few positive or negative training "
                   "objects to learn (the zero-shot study's rule for a split) is left out, with a 'note:' line, "
                   "and the bundle records it.")
@_source_options
@_study_options
@data_dir_option
@force_option
def train_attributes(splits_file, split_name, fusion, prior, out, method, from_results, per_ep, min_objects, dataset,
                     features_file, plain_dir, path, undersampling, cv, grid, no_progress, no_cache, seed, n_jobs,
                     backend, scheduler, data_dir, force):
    """Fit a zero-shot model and save it as a model bundle for 'tzsl predict'.

    Without --splits every object trains the model (a model for recognising new objects);
    with --splits only that split's training objects do. Without --method it is the generic
    default (tzsl.models.choices.DEFAULT_METHOD), the method a zero-shot study keeps unless
    another beats it clearly; --from-results FOLDER trains the method that study chose. An
    attribute too rare to learn (too few positive or negative training objects, the zero-shot
    study's rule for a split) is left out with a 'note:' line and recorded in the bundle;
    'tzsl predict' then ranks classes on the attributes kept.
    """
    from tzsl.studies.engine import check_experiment  # noqa: PLC0415
    from tzsl.studies.zero_shot.runner import load_study_features  # noqa: PLC0415

    if out.exists() and not force:
        raise ConfigError(f"{out} already exists; use --force to overwrite")
    if per_ep and method is not None:
        raise ConfigError("--per-ep and --method exclude each other")
    ctx = click.get_current_context()
    given = [p for p in ("fusion", "prior", "method", "per_ep", "splits_file", "split_name", "min_objects",
                         "undersampling", "cv", "grid", "seed")
             if ctx.get_parameter_source(p) is not click.core.ParameterSource.DEFAULT]
    if from_results is not None:
        if given:
            options = {q.name: q.opts[0] for q in ctx.command.params}
            names = ", ".join(options[p] for p in given)
            raise ConfigError(f"--from-results sets the method, its settings, the seed and the dataset's attribute "
                              f"filter from the study; leave out {names}")
        _train_from_results(from_results, out, dataset, features_file, plain_dir, path, data_dir, no_progress,
                            no_cache, n_jobs, backend, scheduler, force)
        return
    rule = [f"--{p}" for p, value in (("fusion", fusion), ("prior", prior)) if value is not None]
    if rule and (per_ep or method is not None):
        raise ConfigError(f"{', '.join(rule)} set(s) the default DAP model; with --method or --per-ep the "
                          "method's own decision rule is saved")
    if method is not None:
        from tzsl.models import get_method  # noqa: PLC0415

        get_method(method)  # an unknown name fails before any data is read
    exp = _experiment({**_dataset_values(dataset, features_file, plain_dir, path, data_dir),
                       **({} if min_objects is None else {"dataset.min_objects": min_objects}),
                       **_study_values(seed, n_jobs, backend, scheduler, undersampling, cv, grid, no_progress,
                                       no_cache)})
    check_experiment(exp)  # paths and the Dask scheduler, before any data is read
    if per_ep:
        features = load_study_features(exp)
        start = time.perf_counter()
        _train_per_ep(features, out, splits_file, split_name, exp, force)
        click.echo(f"fitted in {time.perf_counter() - start:.1f} s; wrote {out}")
        return
    from tzsl.inference.model_bundles import command_entry  # noqa: PLC0415

    entry = command_entry(exp.config, method, fusion, prior)
    _fit_entry(entry, load_study_features(exp), exp, out, force, splits_file=splits_file, split_name=split_name)


def _fit_entry(entry: dict, features, exp, out: Path, force: bool, **options) -> None:
    """Fit a deployable entry, save its bundle and print what was fitted."""
    from tzsl.inference.model_bundles import train_attribute_bundle  # noqa: PLC0415

    start = time.perf_counter()
    summary = train_attribute_bundle(features, exp.config, out, entry=entry, force=force, echo=click.echo, **options)
    click.echo(summary.to_string(index=False, float_format=lambda v: f"{v:.3g}"))
    click.echo(f"fitted {entry['label']} in {time.perf_counter() - start:.1f} s; wrote {out}")


def _train_from_results(folder: Path, out: Path, dataset, features_file, plain_dir, path, data_dir, no_progress,
                        no_cache, n_jobs, backend, scheduler, force) -> None:
    """``train-attributes --from-results``: the entry of the study's deployment.json, on the study's dataset."""
    from tzsl.studies.config import option_values  # noqa: PLC0415
    from tzsl.studies.engine import check_experiment  # noqa: PLC0415
    from tzsl.studies.zero_shot.deployment import check_dataset, dataset_values, read_deployment  # noqa: PLC0415
    from tzsl.studies.zero_shot.runner import load_study_features  # noqa: PLC0415

    source, record = read_deployment(folder)
    given = {"builtin": dataset, "features": None if features_file is None else str(features_file),
             "plain": None if plain_dir is None else str(plain_dir), "path": None if path is None else str(path)}
    values = dataset_values(source, record, given)
    if data_dir is not None:
        values.update(option_values(STUDY, {"data_dir": data_dir}))
    shared = option_values(STUDY, {"n_jobs": n_jobs, "backend": backend, "scheduler": scheduler,
                                   "progress": not no_progress})
    exp = _experiment({**values, **shared, "compute.cache": not no_cache})
    check_experiment(exp)
    features = load_study_features(exp)
    check_dataset(source, record, features)
    click.echo(f"{source}: {record['label']} ({record['reason']})")
    chosen = {"file": str(source.resolve()), "branch": record["branch"], "reason": record["reason"],
              "study": record.get("experiment")}
    _fit_entry(record, features, exp, out, force, deployment=chosen)


def _train_per_ep(features, out, splits_file, split_name, exp, force) -> None:
    from tzsl.inference.model_bundles import (  # noqa: PLC0415
        left_out_notes,
        training_record,
        training_subset,
    )
    from tzsl.inference.predict_active import train_per_ep_bundle  # noqa: PLC0415
    from tzsl.studies.zero_shot.relaxations import trainable_attribute_rule  # noqa: PLC0415

    config = exp.config
    sub, split, left_out = training_subset(features, splits_file, split_name, **trainable_attribute_rule(config.splits))
    for note in left_out_notes(left_out):
        click.echo(f"note: {note}")
    meta = train_per_ep_bundle(sub, out, seed=config.splits.seed, force=force, split=split,
                               **training_record(sub, left_out))
    click.echo(f"per-EP model: EPs {', '.join(meta['eps'])} ({', '.join(f'{s:g} s' for s in meta['ep_seconds'])}), "
               f"{len(meta['attribute_names'])} attributes, {len(meta['training_objects'])} training objects")


def evaluate_values(kind, splits_file, n_splits, n_test, multilabel, sweep, out, dataset, features_file, plain_dir,
                    path, undersampling, cv, grid, no_progress, no_cache, seed, n_jobs, backend, scheduler,
                    data_dir, purpose: str | None = None) -> dict:
    """``tzsl evaluate``'s options as experiment keys (``{"table.key": value}``)."""
    from tzsl.studies.config import option_values  # noqa: PLC0415

    kinds = ["file"] if splits_file is not None else (list(SPLIT_KINDS) if kind == "both" else [kind])
    return {**_dataset_values(dataset, features_file, plain_dir, path, data_dir),
            **_study_values(seed, n_jobs, backend, scheduler, undersampling, cv, grid, no_progress, no_cache),
            "splits.kinds": kinds, "splits.file": None if splits_file is None else str(splits_file),
            "splits.n_splits": n_splits, "splits.n_test": n_test, "methods.multilabel": multilabel,
            **({} if purpose is None else {"splits.purpose": purpose}),
            "methods.sweep": sweep, **option_values(STUDY, {"out": out})}


@cli.command()
@click.option("--split", "kind", type=click.Choice([*SPLIT_KINDS, "both"]), default="random",
              show_default=True, help="Split family (paper Tables 1-2: random; Table 3: challenging).")
@click.option("--splits", "splits_file", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Use the splits of this CSV instead (see 'tzsl splits').")
@schema_option("--n-splits", study=STUDY, key="splits.n_splits", type=click.IntRange(min=1),
               help="Random splits.")
@schema_option("--n-test", study=STUDY, key="splits.n_test", type=click.IntRange(min=1),
               help="Test objects per random split.")
@purpose_option
@schema_option("--multilabel/--no-multilabel", study=STUDY, key="methods.multilabel",
               help="Also fit the joint (multi-label) attribute model on the random splits.")
@schema_option("--sweep/--no-sweep", study=STUDY, key="methods.sweep", help="Attribute-count sweep (F10).")
@schema_option("--out", study=STUDY, key="output.folder", type=click.Path(file_okay=False, path_type=Path),
               help="Results folder.")
@_source_options
@_study_options
@data_dir_option
@force_option
def evaluate(force, **options):
    """Zero-shot recognition with DAP per split and on average, beside the paper's numbers.

    The same as 'tzsl run' on the matching experiment file (study = "phac2-dap"); see
    'tzsl run phac2-dap --print-config' for every setting.
    """
    from tzsl.studies.engine import run_experiment  # noqa: PLC0415

    exp = _experiment(evaluate_values(**options))
    results, _ = run_experiment(exp, force=force, echo=click.echo)
    click.echo(f"\nwrote {len(results.written)} files to {results.root}")


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
    from tzsl.benchmarks.bench import run_bench  # noqa: PLC0415
    from tzsl.features import dataset_features  # noqa: PLC0415
    from tzsl.studies.config import ZeroShotSettings  # noqa: PLC0415

    if out is not None and out.exists() and not force:
        raise ConfigError(f"{out} already exists; use --force to overwrite")
    features = dataset_features("phac2-penn", data_dir=data_dir)
    # timed on the paper's grid, like the literal recipe beside it
    config = ZeroShotSettings.of_preset("phac2-dap", splits={"seed": seed}, svm={"grid": "paper"})
    table = run_bench(features, config, split_index=split_index, skip_literal=skip_literal,
                      echo=click.echo)
    click.echo(table.to_string(index=False, float_format=lambda v: f"{v:.3f}"))
    if out is not None:
        from tzsl._io import atomic_write  # noqa: PLC0415

        atomic_write(out, lambda p: table.to_csv(p, index=False))
        click.echo(f"wrote {out}")
