"""Hand commands: ``simulate-grasps``, ``evaluate-hand`` and ``train-hand``."""

from __future__ import annotations

import time
from pathlib import Path

import click

from tzsl.cli._root import (
    cli,
    force_option,
    n_jobs_option,
    no_progress_option,
    parse_seeds,
    schema_option,
    seed_option,
)
from tzsl.exceptions import ConfigError

STUDY = "hand"

_SIMULATOR_NOTE = (
    "SIMULATED data: no public Shadow-hand grasp data exist, so this simulator exists to exercise "
    "and demonstrate the hand methods; it is not the paper's data and its numbers say nothing "
    "about real robots."
)

table_option = click.option(
    "--table", type=click.Path(dir_okay=False, path_type=Path), default=None,
    help="Class-attribute table with train/test split and object subsets "
         "(layout of tzsl/datasets/hand_table4.csv). Default: the DAP paper's Table 4.",
)


def _simulation_options(f):
    for option in reversed([
        schema_option("--grasps-per-object", study=STUDY, key="simulation.n_grasps_per_object",
                      type=click.IntRange(min=1), help="Simulated grasps of every object."),
        schema_option("--noise", study=STUDY, key="simulation.noise", type=click.FloatRange(min=0),
                      help="Sensor noise and per-grasp variation (0 = noiseless)."),
        schema_option("--difficulty", study=STUDY, key="simulation.difficulty", type=click.FloatRange(min=0),
                      help="Object-to-object variation of materials and postures."),
        schema_option("--shape-miss-rate", study=STUDY, key="simulation.shape_miss_rate",
                      type=click.FloatRange(0, 1),
                      help="Probability that a grasp misses each local shape attribute (handle, narrow neck, ...)."),
    ]):
        f = option(f)
    return f


def _table(path: Path | None):
    from tzsl.datasets import load_hand_table4  # noqa: PLC0415

    return load_hand_table4(path)


@cli.command("simulate-grasps", help=(
    "Write simulated Shadow-hand grasps (5 BioTacs, 19 joints) of the 16 objects of the DAP "
    "paper's Table 4 as a grasp folder (grasps.csv + one .npz per grasp; see data/README.md). "
    + _SIMULATOR_NOTE
))
@click.option("--out", type=click.Path(file_okay=False, path_type=Path), required=True, help="Grasp folder to write.")
@_simulation_options
@table_option
@seed_option(study=None)
@force_option
def simulate_grasps_command(out: Path, grasps_per_object: int, noise: float, difficulty: float,
                            shape_miss_rate: float, table: Path | None, seed: int, force: bool) -> None:
    from tzsl.datasets import simulate_grasps  # noqa: PLC0415

    if (out / "grasps.csv").exists() and not force:
        raise ConfigError(f"{out / 'grasps.csv'} already exists; use --force to overwrite")
    hand = _table(table)
    start = time.perf_counter()
    sim = simulate_grasps(hand.K, grasps_per_object, noise, difficulty, shape_miss_rate,
                          material_attributes=hand.material_attributes, random_state=seed, folder=out)
    click.echo(f"wrote {len(sim.grasps)} simulated grasps of {len(hand.K)} objects to {out} "
               f"({time.perf_counter() - start:.1f} s, seed {seed})")
    click.echo("note: " + _SIMULATOR_NOTE)


def evaluate_hand_values(grasps, table, out, seeds, grasps_per_object, noise, difficulty, shape_miss_rate,
                         n_sequences, n_jobs, no_progress) -> dict:
    """``tzsl evaluate-hand``'s options as experiment keys (``{"table.key": value}``)."""
    from tzsl.studies.config import option_values  # noqa: PLC0415

    return {"dataset.builtin": "hand-simulated" if grasps is None else None,
            "dataset.grasps": None if grasps is None else str(grasps),
            "dataset.table": None if table is None else str(table),
            **option_values("hand", {"out": out, "n_jobs": n_jobs, "progress": not no_progress}),
            "splits.seeds": list(seeds), "simulation.n_grasps_per_object": grasps_per_object,
            "simulation.noise": noise, "simulation.difficulty": difficulty,
            "simulation.shape_miss_rate": shape_miss_rate, "methods.n_sequences": n_sequences,
            "zero_shot.enabled": False}  # the paper protocol only


@cli.command("evaluate-hand")
@click.option("--grasps", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Grasp folder with labelled grasps. Default: simulate a data set per seed (simulated data).")
@table_option
@schema_option("--out", study=STUDY, key="output.folder", type=click.Path(file_okay=False, path_type=Path),
               help="Results folder.")
@schema_option("--seeds", study=STUDY, key="splits.seeds", callback=parse_seeds,
               help="Seeds, e.g. '0,1,2' or '0-4': one model fit and one set of grasp orders each "
                    "(and one simulated data set each when --grasps is omitted).")
@_simulation_options
@schema_option("--n-sequences", study=STUDY, key="methods.n_sequences", type=click.IntRange(min=1),
               help="Random grasp orders per test object for the multi-grasp curves.")
@n_jobs_option(study=STUDY)
@no_progress_option
@force_option
def evaluate_hand(force: bool, **options) -> None:
    """Hand study (DAP paper section 5.8): Table 5, DF-MDAP vs T, SC-MDAP vs k, confusion
    matrices, attribute accuracy and distance matrix S, fitted on training objects only.

    The same as 'tzsl run' on a study = "hand" file with these settings and [zero_shot] enabled
    = false: the paper protocol only, not the generic zero-shot tables on hand-simulated ('tzsl
    run hand-simulated --print-config' shows every setting).
    """
    from tzsl.studies.config import config_from_options  # noqa: PLC0415
    from tzsl.studies.engine import run_experiment  # noqa: PLC0415

    exp = config_from_options(STUDY, evaluate_hand_values(**options))
    if options["grasps"] is None:
        click.echo(f"no --grasps given: simulating grasps with seed(s) {list(options['seeds'])}. " + _SIMULATOR_NOTE)
    start = time.perf_counter()
    results, _ = run_experiment(exp, force=force, echo=click.echo)
    for path in results.written:
        click.echo(f"wrote {path}")
    click.echo(f"done in {time.perf_counter() - start:.1f} s")


@cli.command("train-hand")
@click.option("--grasps", type=click.Path(file_okay=False, path_type=Path), required=True,
              help="Grasp folder; the grasps of the table's training objects are used, the others ignored.")
@table_option
@click.option("--out", type=click.Path(dir_okay=False, path_type=Path), required=True,
              help="Model bundle to write (e.g. model.tzsl).")
@click.option("--fusion", type=click.Choice(["ldap", "avgdap", "maxdap"]), default="ldap", show_default=True,
              help="Fusion over touching BioTacs for single-grasp classification.")
@seed_option(study=None)
@force_option
def train_hand(grasps: Path, table: Path | None, out: Path, fusion: str, seed: int, force: bool) -> None:
    """Fit the hand attribute classifiers on the training objects and save a model bundle."""
    from tzsl.inference.model_bundles import train_hand_bundle  # noqa: PLC0415

    start = time.perf_counter()
    from tzsl.inference.model_bundles import left_out_notes  # noqa: PLC0415

    model, meta = train_hand_bundle(grasps, _table(table), out, fusion=fusion, seed=seed, force=force)
    for line in left_out_notes(meta["left_out_attributes"]) + [f"relaxed {r}" for r in meta["relaxations"]]:
        click.echo(f"note: {line}")
    click.echo(f"fitted on {meta['n_training_grasps']} grasps of training objects {meta['training_objects']} "
               f"({meta['n_ignored_grasps']} grasps of other objects ignored) in {time.perf_counter() - start:.1f} s")
    click.echo(f"saved {out} (method hand-dap, {len(meta['attribute_names'])} attributes, fusion {fusion})")
