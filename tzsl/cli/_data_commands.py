"""Data commands: ``datasets`` (the built-in datasets) and ``extract``."""

from __future__ import annotations

import json
from pathlib import Path

import click

from tzsl.cli._root import RegistryName, cli, data_dir_option, force_option, schema_option
from tzsl.exceptions import ConfigError


@cli.command()
@click.option("--json", "as_json", is_flag=True, help="Print the datasets as JSON instead of a table.")
def datasets(as_json: bool) -> None:
    """List the built-in datasets: name, what it holds, where it comes from.

    Each is read with 'tzsl extract --dataset NAME' or '[dataset] builtin = NAME' in an
    experiment file, and fetched with 'tzsl data fetch'. Your own data need none of this: see
    'tzsl formats' and 'tzsl convert --from'.
    """
    from tzsl.datasets import dataset_names, get_dataset  # noqa: PLC0415 (keep --help fast)

    records = [{"name": d.name, "description": d.description, "content": d.content, "eps": list(d.eps),
                "needs_path": d.needs_path, "convertible": d.convertible, "source": d.source}
               for d in map(get_dataset, dataset_names())]
    if as_json:
        click.echo(json.dumps(records, indent=2))
        return
    for r in records:
        needs = " (needs --path)" if r["needs_path"] else ""
        click.echo(f"{r['name']}: {r['description']}{needs}\n    {r['content']}, EPs: {', '.join(r['eps'])}; "
                   f"source: {r['source']}")


@cli.command()
@click.option("--dataset", type=RegistryName("dataset"), required=True,
              help="A built-in dataset ('tzsl datasets' lists them).")
@click.option("--path", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Input file of a dataset that reads one (phac2-h5: the HDF5 release).")
@click.option("--out", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Write the per-trial, per-sensor feature table here (.csv or .npz; see data/README.md).")
@schema_option("--min-objects", study="zero-shot", key="dataset.min_objects", type=int,
              help="Keep attributes present in at least this many objects.")
@data_dir_option
@force_option
def extract(dataset: str, path: Path | None, out: Path | None, min_objects: int, data_dir: Path | None,
            force: bool) -> None:
    """Extract per-trial, per-sensor features and print a summary."""
    from tzsl.datasets import feature_table_paths, write_feature_table  # noqa: PLC0415
    from tzsl.features import dataset_features  # noqa: PLC0415
    from tzsl.features.summary import format_summary, summarise  # noqa: PLC0415

    if out is not None:
        if out.suffix not in (".csv", ".npz"):
            raise ConfigError(f"--out {out}: use a .csv or .npz file name")
        existing = [p for p in feature_table_paths(out) if p.exists()]
        if existing and not force:
            raise ConfigError(f"{existing[0]} already exists; use --force to overwrite")
    features = dataset_features(dataset, data_dir=data_dir, path=path, min_objects=min_objects)
    click.echo(format_summary(summarise(features)))
    if out is not None:
        for written in write_feature_table(features, out):
            click.echo(f"wrote {written}")
