"""Fabric study command: ``evaluate-fabric`` (the fabric paper's Table 1 analogue)."""

from __future__ import annotations

from pathlib import Path

import click

from tzsl.cli._main import cli, data_dir_option, force_option, n_jobs_option, seed_option

#: Model families of ``evaluate-fabric``; "classical" = texture descriptors + EmbeddingZSL / ESZSL;
#: "deep" = the CNN + LSTM of tzsl.experiments.deep (needs the deep extra).
FABRIC_MODELS = ("classical", "deep")


@cli.command("evaluate-fabric")
@click.option("--out", type=click.Path(file_okay=False, path_type=Path), default=Path("results"),
              show_default=True, help="Results folder (fabric_table1.csv, fabric_runs.csv, fabric_lambda.png, "
                                      "fabric_manifest.json).")
@click.option("--seeds", type=click.IntRange(min=1), default=5, show_default=True,
              help="Seeds of the embedding model (mean and std over them).")
@click.option("--config", "configs", type=click.Choice(["1", "2"]), multiple=True,
              help="Zero-shot split: 1 = test groups 0,5,7 (the paper's), 2 = test 0,4,7. Repeat for "
                   "both [default: 1 and 2].")
@click.option("--gelsight-root", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Your GelSight fabric videos (<root>/fabric_groups.csv, <root>/<condition>/<fabric>/<press>.avi); "
                   "adds one row per condition (Flat/Fold/Rand get the paper's rows beside).")
@click.option("--attributes", default="a8", show_default=True,
              help="Group x attribute matrix: a8, a4, a12, three_value_a8, three_value_a8v2.")
@click.option("--model", type=click.Choice(FABRIC_MODELS), default="classical", show_default=True,
              help="classical: texture descriptors with EmbeddingZSL (lambda grid) and ESZSL; deep: the "
                   "CNN + LSTM (lambda grid; needs tzsl[deep]) -> fabric_deep_table.csv.")
@click.option("--no-progress", is_flag=True, help="No progress bar.")
@data_dir_option
@force_option
@n_jobs_option
@seed_option
def evaluate_fabric(out: Path, seeds: int, configs: tuple[str, ...], gelsight_root: Path | None, attributes: str,
                    model: str, no_progress: bool, data_dir: Path | None, force: bool, n_jobs: int,
                    seed: int) -> None:
    """Fabric zero-shot study: accuracy per lambda and ESZSL, the paper's Table 1 beside ours.

    Rows: the public depth images as sequences (one sample per fabric) and as single images,
    per split config; plus GelSight rows with --gelsight-root. See tzsl.experiments.fabric.
    """
    from tzsl.experiments._outputs import ResultsDir  # noqa: PLC0415
    from tzsl.experiments.fabric import format_fabric_table, run_fabric_study  # noqa: PLC0415

    if model == "deep":
        from tzsl.experiments.deep import format_deep_table, run_deep_fabric_study  # noqa: PLC0415
        from tzsl.models._deep import require_torch  # noqa: PLC0415

        require_torch()
        deep = run_deep_fabric_study(
            ResultsDir(out, force=force), data_dir=data_dir, seeds=seeds,
            configs=tuple(int(c) for c in configs) or (1, 2), gelsight_root=gelsight_root,
            attributes=attributes, progress=not no_progress, seed=seed,
        )
        click.echo(format_deep_table(deep["table"]))
        click.echo(f"wrote {out / 'fabric_deep_table.csv'}, fabric_deep_runs.csv, fabric_deep_manifest.json")
        return
    result = run_fabric_study(
        ResultsDir(out, force=force),
        data_dir=data_dir,
        seeds=seeds,
        configs=tuple(int(c) for c in configs) or (1, 2),
        gelsight_root=gelsight_root,
        attributes=attributes,
        progress=not no_progress,
        seed=seed,
        n_jobs=n_jobs,
    )
    click.echo(format_fabric_table(result["table1"]))
    click.echo(f"wrote {out / 'fabric_table1.csv'}, fabric_runs.csv, fabric_lambda.png, fabric_manifest.json")
