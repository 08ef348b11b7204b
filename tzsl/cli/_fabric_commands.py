"""Fabric study command: ``evaluate-fabric``, a front-end of the engine.

``--model classical`` builds a ``study = "fabric"`` experiment, ``--model deep`` a
``study = "fabric-deep"`` one; both run through :func:`tzsl.studies.engine.run_experiment`
exactly as ``tzsl run`` runs the matching file. Option defaults come from the schema.
"""

from __future__ import annotations

from pathlib import Path

import click

from tzsl.cli._root import (
    cli,
    data_dir_option,
    force_option,
    n_jobs_option,
    no_progress_option,
    schema_option,
    seed_option,
)

#: Model families of ``evaluate-fabric``; "classical" = texture descriptors + EmbeddingZSL / ESZSL;
#: "deep" = the CNN + LSTM of tzsl.studies.fabric.deep (needs the deep extra).
FABRIC_MODELS = ("classical", "deep")


def evaluate_fabric_values(model, out, n_seeds, configs, gelsight_root, attributes, no_progress, data_dir, n_jobs,
                           seed) -> tuple[str, dict]:
    """``tzsl evaluate-fabric``'s options as (study, experiment keys)."""
    from tzsl.studies.config import option_values  # noqa: PLC0415

    study = "fabric-deep" if model == "deep" else "fabric"
    values = {"splits.n_seeds": n_seeds, "splits.configs": [int(c) for c in configs] or None,
              "dataset.attributes": attributes,
              "dataset.gelsight_root": None if gelsight_root is None else str(gelsight_root),
              **option_values(study, {"out": out, "seed": seed, "data_dir": data_dir, "progress": not no_progress})}
    if model == "deep":
        return study, values
    return study, {**values, **option_values(study, {"n_jobs": n_jobs}), "zero_shot.enabled": False}  # paper only


@cli.command("evaluate-fabric")
@schema_option("--out", study="fabric", key="output.folder", type=click.Path(file_okay=False, path_type=Path),
               help="Results folder (fabric_table1.csv, fabric_runs.csv, fabric_lambda.png, manifests).")
@click.option("--n-seeds", type=click.IntRange(min=1), default=None,
              help="Seeds of the embedding model, --seed .. --seed + N - 1 (mean and std over them) "
                   "[default: 5 classical, 1 deep].")
@click.option("--config", "configs", type=click.Choice(["1", "2"]), multiple=True,
              help="Zero-shot split: 1 = test groups 0,5,7 (the paper's), 2 = test 0,4,7. Repeat for "
                   "both [default: 1 and 2].")
@click.option("--gelsight-root", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Your GelSight fabric videos (<root>/fabric_groups.csv, <root>/<condition>/<fabric>/<press>.avi); "
                   "adds one row per condition (Flat/Fold/Rand get the paper's rows beside).")
@schema_option("--attributes", study="fabric", key="dataset.attributes",
               type=click.Choice(["a8", "a4", "a12", "three_value_a8", "three_value_a8v2"]),
               help="Group x attribute matrix.")
@click.option("--model", type=click.Choice(FABRIC_MODELS), default="classical", show_default=True,
              help="classical: texture descriptors with EmbeddingZSL (lambda grid) and ESZSL; deep: the "
                   "CNN + LSTM (lambda grid; needs tzsl[deep]) -> fabric_deep_table.csv.")
@no_progress_option
@data_dir_option
@force_option
@n_jobs_option(study="fabric")
@seed_option(study="fabric")
def evaluate_fabric(out: Path, n_seeds, configs: tuple[str, ...], gelsight_root: Path | None, attributes: str,
                    model: str, no_progress: bool, data_dir: Path | None, force: bool, n_jobs: int,
                    seed: int) -> None:
    """Fabric zero-shot study: accuracy per lambda and ESZSL, the paper's Table 1 beside ours.

    Rows: the public depth images as sequences (one sample per fabric) and as single images,
    per split config; plus GelSight rows with --gelsight-root. The same as 'tzsl run fabric'
    (or 'tzsl run fabric-deep' with --model deep) with these settings and [zero_shot] enabled =
    false: the paper protocol only, not the generic zero-shot tables on fabric-depth.
    """
    from tzsl.studies.config import config_from_options  # noqa: PLC0415
    from tzsl.studies.engine import run_experiment  # noqa: PLC0415

    study, values = evaluate_fabric_values(model, out, n_seeds, configs, gelsight_root, attributes, no_progress,
                                           data_dir, n_jobs, seed)
    results, _ = run_experiment(config_from_options(study, values), force=force, echo=click.echo)
    click.echo(f"wrote {', '.join(p.name for p in results.written)} to {results.root}")
