"""Plain-file dataset commands: ``formats``, ``validate``, ``convert``."""

from __future__ import annotations

import json
import re
from pathlib import Path

import click

from tzsl.cli._root import RegistryName, cli, data_dir_option, force_option, no_progress_option, schema_option
from tzsl.exceptions import ConfigError, DataFileError

#: Datasets ``tzsl convert`` writes as plain-file folders.
#: ``--from`` kinds (:data:`tzsl.datasets.LAB_FORMATS`, written here so --help stays fast).


def _statistics_help() -> str:
    from tzsl.features import SIGNAL_STATISTICS, SIGNAL_TRANSFORMS  # noqa: PLC0415

    width = max(map(len, SIGNAL_STATISTICS))
    rows = [f"    {name:<{width}}  {text}" for name, text in {**SIGNAL_STATISTICS, **SIGNAL_TRANSFORMS}.items()]
    return ("signal statistics ([signals] statistics), per channel over the rows of a trial;\n"
            "features are named <channel>_<statistic>, channel-major\n" + "\n".join(rows) + "\n")


def format_text() -> str:
    """The full format description printed by ``tzsl formats``."""
    return _plain_format_help() + "\n" + _statistics_help()


def _plain_format_help() -> str:
    from tzsl.datasets import PLAIN_FORMAT_HELP  # noqa: PLC0415 - when needed: keeps "tzsl --help" fast

    return PLAIN_FORMAT_HELP


class _LazyHelpCommand(click.Command):
    """A command whose long help is built only when it is shown (``tzsl formats --help``)."""

    @property
    def help(self):
        return "Describe the plain-file dataset format (also in data/README.md).\n\n" + _unwrapped(_plain_format_help())

    @help.setter
    def help(self, value):
        pass


def _unwrapped(text: str) -> str:
    """Keep click from re-wrapping the paragraphs of ``text`` in --help."""
    return "\n\n".join("\b\n" + para for para in text.strip().split("\n\n"))


@cli.command(cls=_LazyHelpCommand, short_help="Describe the plain-file dataset format (also in data/README.md).")
def formats() -> None:
    click.echo(format_text(), nl=False)


def _split_problems(folder: Path, attributes) -> list:
    """Problems ``tzsl.evaluation.read_splits_csv`` finds in ``splits.csv`` (its full checks)."""
    from tzsl.datasets import SPLITS_FILE, Problem  # noqa: PLC0415
    from tzsl.evaluation import read_splits_csv  # noqa: PLC0415
    from tzsl.exceptions import SplitError  # noqa: PLC0415

    path = folder / SPLITS_FILE
    if not path.is_file():
        return []
    try:
        read_splits_csv(path, attributes)
    except (SplitError, DataFileError) as exc:
        lines = str(exc).splitlines()
        found = []
        for text in lines[1:] if len(lines) > 1 else lines:
            text = text.strip()
            match = re.match(rf"^{re.escape(str(path))}(?::(\d+))?: (.*)$", text)
            if match:
                found.append(Problem(SPLITS_FILE, int(match.group(1)) if match.group(1) else None, match.group(2)))
            else:
                found.append(Problem(SPLITS_FILE, None, text))
        return found
    return []


def summary_lines(features_dims: str, data) -> list[str]:
    groups = data.attribute_groups
    group_text = ""
    if groups:
        counts: dict[str, int] = {}
        for g in groups.values():
            counts[g] = counts.get(g, 0) + 1
        group_text = " (" + ", ".join(f"{g}: {n}" for g, n in counts.items()) + ")"
    n_objects = data.trials["object_name"].nunique()
    with_trials = data.trials["class"].nunique()
    return [
        f"dataset:    {data.name}",
        f"classes:    {len(data.classes)} ({with_trials} with trials)",
        f"attributes: {data.classes.shape[1]}{group_text}",
        f"trials:     {data.n_trials}",
        f"objects:    {n_objects}",
        f"sensors:    {len(data.sensors)} ({', '.join(data.sensors)})",
        f"features:   {features_dims}",
        f"splits:     {'splits.csv' if data.splits_file is not None else 'none'}",
    ]


@cli.command()
@click.argument("dataset_dir", type=click.Path(path_type=Path))
@click.option("--json", "as_json", is_flag=True, help="Print the summary and the dataset card as one JSON object.")
def validate(dataset_dir: Path, as_json: bool) -> None:
    """Check a plain-file dataset folder; list every problem with file and line.

    Exit code 0, a summary and a dataset card (classes, trials per class, positive classes per
    attribute, identical attribute rows, attributes too rare to learn, the default split's
    chance) when the folder is valid; 3 and the list of problems otherwise. See 'tzsl formats'
    for the format.
    """
    from tzsl.datasets import card_lines, read_plain_dataset, validate_dataset  # noqa: PLC0415
    from tzsl.features import (  # noqa: PLC0415
        DEFAULT_ROCKET_KERNELS,
        DEFAULT_SIGNAL_STATISTICS,
        SIGNAL_STATISTICS,
        SIGNAL_TRANSFORMS,
    )

    problems = validate_dataset(dataset_dir, statistics=(*SIGNAL_STATISTICS, *SIGNAL_TRANSFORMS))
    data = None
    if not problems:
        data = read_plain_dataset(dataset_dir)
        problems = _split_problems(dataset_dir, data.object_attributes)
    if problems:
        for problem in problems:
            click.echo(str(problem))
        raise DataFileError(dataset_dir, f"{len(problems)} problem(s); see the list above")
    assert data is not None  # no problems: the folder was read above
    if data.kind == "columns":
        dims = f"{len(data.feature_names)} feature columns per sensor"
    else:
        config = data.settings.get("signals", {})
        stats = config.get("statistics", list(DEFAULT_SIGNAL_STATISTICS))
        baseline = config.get("baseline_rows", 0)
        per_channel = sum(2 * DEFAULT_ROCKET_KERNELS if s in SIGNAL_TRANSFORMS else 1 for s in stats)
        dims = (f"{len(data.channels) * per_channel} per sensor from signal files: {len(data.channels)} channels x "
                f"{per_channel} {'statistics' if per_channel == len(stats) else 'features'} ({', '.join(stats)}), "
                f"baseline_rows={baseline}")
    card = _card(data)
    if as_json:
        click.echo(json.dumps({"dataset": data.name, "folder": str(dataset_dir), "valid": True,
                               "features": dims, **card}, indent=2))
        return
    for line in summary_lines(dims, data) + card_lines(card):
        click.echo(line)
    click.echo(f"{dataset_dir}: valid")


def _card(data) -> dict:
    """The dataset card read against the generic study's default split (its schema defaults)."""
    from tzsl.datasets import dataset_card  # noqa: PLC0415
    from tzsl.studies.config import ZeroShotSplits  # noqa: PLC0415
    from tzsl.studies.zero_shot.relaxations import relaxed_n_test, trainable_attribute_rule  # noqa: PLC0415

    splits = ZeroShotSplits()
    trials = data.trials.drop_duplicates("trial_id") if "trial_id" in data.trials.columns else data.trials
    n_test = relaxed_n_test(data.object_attributes, splits)  # as the template's run will draw them
    return dataset_card(data.classes, trials["class"].astype(str).tolist(), n_test=n_test,
                        **trainable_attribute_rule(splits))


@cli.command()
@click.option("--from", "source", type=RegistryName("lab-format"), default=None,
              help="A lab's own recordings, read as --mapping says: ros-bag (ROS 1/2 bags), hdf5 (your HDF5 "
                   "layout), series (a folder of per-trial .csv/.npy time series).")
@click.option("--mapping", type=click.Path(path_type=Path), default=None,
              help="The TOML mapping of --from: topics/groups/files to trials, sensors, channels and classes.")
@click.option("--allow-outside", is_flag=True, default=False,
              help="Let --mapping read files outside its folder (absolute paths, '..', links pointing out); "
                   "without it they are refused.")
@click.option("--dataset", type=RegistryName("convertible"), default=None,
              help="A built-in dataset ('tzsl datasets' lists them): published features are written as feature "
                   "columns, raw signals as one signal file per trial and sensor.")
@click.option("--out", type=click.Path(file_okay=False, path_type=Path), required=True,
              help="Dataset folder to write (must not exist or be empty, unless --force).")
@no_progress_option
@schema_option("--min-objects", study="zero-shot", key="dataset.min_objects", type=int,
              help="Keep attributes present in at least this many objects.")
@click.option("--signal-format", type=click.Choice(["npz", "csv"]), default="npz", show_default=True,
              help="Signal file type of a dataset of raw signals.")
@data_dir_option
@force_option
def convert(source: str | None, mapping: Path | None, allow_outside: bool, dataset: str | None, out: Path,
            no_progress: bool, min_objects: int, signal_format: str, data_dir: Path | None, force: bool) -> None:
    """Write a lab's recordings (--from KIND --mapping FILE) or a built-in dataset (--dataset) as a
    plain-file dataset folder (see 'tzsl formats'); check it with 'tzsl validate OUT'.

    In PHAC-2 every object is its own class; objects sharing an adjective row are allowed
    by '[classes] allow_identical_rows = true' in the written dataset.toml.
    """
    if (source is None) == (dataset is None):
        raise click.UsageError("give --from KIND --mapping FILE, or --dataset NAME")
    if allow_outside and source is None:
        raise click.UsageError("--allow-outside goes with --from KIND --mapping FILE")
    if source is not None:
        from tzsl.datasets import convert_lab_dataset  # noqa: PLC0415

        if mapping is None:
            raise click.UsageError("--from needs --mapping FILE")
        if out.exists() and (not out.is_dir() or any(out.iterdir())) and not force:
            raise ConfigError(f"{out} already exists; use --force to overwrite")
        folder, done = convert_lab_dataset(source, mapping, out, force=force, progress=not no_progress,
                                           allow_outside=allow_outside)
        click.echo(f"wrote {folder}: {done['classes']} classes x {done['attributes']} attributes, {done['trials']} "
                   f"trials, {len(done['sensors'])} sensor(s), {len(done['channels'])} channels per signal file; "
                   f"next: tzsl validate {folder}")
        return
    from tzsl.datasets import CatalogDataset, feature_set_to_plain, get_dataset, write_plain_dataset  # noqa: PLC0415
    from tzsl.features import BIOTAC_CHANNELS, dataset_features, raw_trial_signals  # noqa: PLC0415

    assert dataset is not None  # exactly one of --from and --dataset, checked above
    if out.exists() and (not out.is_dir() or any(out.iterdir())) and not force:
        raise ConfigError(f"{out} already exists; use --force to overwrite")
    builtin = get_dataset(dataset)
    if isinstance(builtin, CatalogDataset):  # its own loader writes the folder, every attribute as published
        from tzsl.datasets import read_plain_dataset  # noqa: PLC0415

        written = read_plain_dataset(builtin.convert(out, data_dir, force=force, signal_format=signal_format))
        per = (f"{len(written.channels or ())} channels per signal file" if written.kind == "signals"
               else f"{len(written.feature_names or ())} feature columns per sensor")
        click.echo(f"wrote {out}: {len(written.classes)} classes x {written.classes.shape[1]} attributes, "
                   f"{written.n_trials} trials, {len(written.sensors)} sensor(s), {per}; next: tzsl validate {out}")
        return
    features = dataset_features(dataset, data_dir=data_dir, min_objects=min_objects)
    if get_dataset(dataset).content == "static-features":
        feature_set_to_plain(features, out, force=force)
        what = f"{features.X.shape[2]} feature columns per sensor"
    else:
        raw = {t.trial_id: t for t in get_dataset(dataset).load(data_dir)}
        trials = features.trials
        signals = [raw_trial_signals(raw[tid]) for tid in trials["trial_id"]]
        classes = features.attributes.rename_axis("class")
        table = trials[["trial_id", "object_name", "object_id", "trial_index"]].rename(
            columns={"object_name": "object"})
        table.insert(1, "class", table["object"])
        settings = {
            "name": features.dataset,
            "classes": {"allow_identical_rows": bool(classes.duplicated().any())},
            "signals": {"channels": list(BIOTAC_CHANNELS), "baseline_rows": 100, "statistics": ["mean"]},
        }
        write_plain_dataset(out, classes, table, sensors=features.sensors, signals=signals,
                            channels=BIOTAC_CHANNELS, settings=settings, signal_format=signal_format, force=force)
        what = f"{len(signals) * len(features.sensors)} signal files of {len(BIOTAC_CHANNELS)} channels"
    click.echo(f"wrote {out}: {len(features.attributes)} classes x {features.attributes.shape[1]} attributes, "
               f"{features.n_trials} trials, {len(features.sensors)} sensors, {what}")
