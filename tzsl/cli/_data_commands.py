"""Data commands: ``extract``."""

from __future__ import annotations

from pathlib import Path

import click

from tzsl.cli._root import cli, data_dir_option, force_option
from tzsl.exceptions import ConfigError


@cli.command()
@click.option("--dataset", type=click.Choice(["phac2-penn", "phac2-h5", "phac2-hold-mat"]), required=True,
              help="phac2-penn: Penn static features; phac2-h5: the raw HDF5 release (--path); "
                   "phac2-hold-mat: the raw HOLD-phase MATLAB trials.")
@click.option("--path", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Input file for --dataset phac2-h5.")
@click.option("--out", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Write the per-trial, per-sensor feature table here (.csv or .npz; see data/README.md).")
@click.option("--min-objects", type=int, default=3, show_default=True,
              help="Keep attributes present in at least this many objects.")
@data_dir_option
@force_option
def extract(dataset: str, path: Path | None, out: Path | None, min_objects: int, data_dir: Path | None,
            force: bool) -> None:
    """Extract per-trial, per-sensor features and print a summary."""
    from tzsl.datasets import feature_table_paths, write_feature_table  # noqa: PLC0415
    from tzsl.studies.extract import extract_features, format_summary, summarise  # noqa: PLC0415

    if out is not None:
        if out.suffix not in (".csv", ".npz"):
            raise ConfigError(f"--out {out}: use a .csv or .npz file name")
        existing = [p for p in feature_table_paths(out) if p.exists()]
        if existing and not force:
            raise ConfigError(f"{existing[0]} already exists; use --force to overwrite")
    features = extract_features(dataset, data_dir=data_dir, path=path, min_objects=min_objects)
    click.echo(format_summary(summarise(features)))
    if out is not None:
        for written in write_feature_table(features, out):
            click.echo(f"wrote {written}")
