"""Deep-model commands: ``train-deep`` (needs the ``deep`` extra: ``pip install tzsl[deep]``)."""

from __future__ import annotations

from pathlib import Path

import click

from tzsl.cli._root import SchemaOption, cli, data_dir_option, force_option, no_progress_option, seed_option
from tzsl.exceptions import ConfigError


def model_default(name: str):
    """The default of :class:`~tzsl.models.DeepAttributeEmbedding`'s parameter ``name``, read when needed."""

    def read():
        from tzsl.studies.config import estimator_parameters  # noqa: PLC0415

        value = estimator_parameters("DeepAttributeEmbedding")[name]
        return str(value) if name in ("lam", "finetune") else value

    read.schema_key = name  # type: ignore[attr-defined]
    return read


def _model_option(*decls, name: str, **kwargs):
    return click.option(*decls, cls=SchemaOption, default=model_default(name), show_default=True, **kwargs)


def require_torch() -> None:
    """Refuse, in one line, when the deep extra is not installed."""
    import importlib.util  # noqa: PLC0415

    if importlib.util.find_spec("torch") is None:
        raise ConfigError("the deep model needs torch: pip install 'tzsl[deep]'")


def parse_lam(text: str) -> float | str:
    """The paper's lambda from the command line: a number >= 0 or "inf"."""
    if text.strip().lower() in ("inf", "infinity"):
        return "inf"
    try:
        value = float(text)
    except ValueError:
        raise ConfigError(f'--lam must be a number >= 0 or "inf", got {text!r}') from None
    if not value >= 0:
        raise ConfigError(f'--lam must be a number >= 0 or "inf", got {text!r}')
    return value


def parse_finetune(text: str) -> int | str:
    """Fine-tuning depth: a number of trailing backbone stages, or "all"."""
    if text.strip().lower() == "all":
        return "all"
    try:
        value = int(text)
    except ValueError:
        raise ConfigError(f'--finetune must be an integer >= 0 or "all", got {text!r}') from None
    if value < 0:
        raise ConfigError(f'--finetune must be an integer >= 0 or "all", got {text!r}')
    return value


def deep_model_options(func):
    """Options shared by the commands that train the deep model."""
    options = [
        _model_option("--epochs", name="epochs", type=click.IntRange(min=1), help="Training epochs."),
        _model_option("--lam", name="lam",
                     help='Lambda of the loss C + lambda R; 0 = C only, "inf" = R only.'),
        _model_option("--backbone", name="backbone", type=click.Choice(["efficientnet-lite0", "vgg16", "small-cnn"]),
                     help="Per-frame CNN. efficientnet-lite0: ImageNet weights shipped with tzsl[deep]; "
                          "vgg16 (the paper's): needs --weights-path; small-cnn: trained from scratch."),
        click.option("--weights-path", type=click.Path(dir_okay=False, path_type=Path), default=None,
                     help="Local backbone weights file (VGG-16: torchvision key names)."),
        _model_option("--finetune", name="finetune",
                     help='Backbone stages trained (from the top); 0 = frozen backbone, "all" = every stage.'),
        click.option("--image-size", type=int, default=None,
                     help="Resize frames to this side length (default: the backbone's native size)."),
        _model_option("--hidden-size", name="hidden_size", type=click.IntRange(min=1), help="LSTM hidden size."),
        _model_option("--batch-size", name="batch_size", type=click.IntRange(min=1), help="Sequences per mini-batch."),
        _model_option("--lr", name="lr", type=float, help="Learning rate."),
        _model_option("--weight-decay", name="weight_decay", type=float, help="L2 penalty on weights."),
        _model_option("--optimizer", name="optimizer", type=click.Choice(["adam", "sgd"]),
                     help="sgd = the paper's (momentum 0.9)."),
        _model_option("--early-stopping/--no-early-stopping", name="early_stopping",
                     help="Choose the number of epochs (up to --epochs) by class-grouped validation on the "
                          "training groups only."),
        click.option("--checkpoint-dir", type=click.Path(file_okay=False, path_type=Path), default=None,
                     help="Write a checkpoint after every epoch (and cache the frozen CNN features) here."),
        click.option("--resume", is_flag=True,
                     help="Continue from the checkpoint in --checkpoint-dir (same settings and data)."),
        click.option("--n-threads", type=int, default=None,
                     help="Torch CPU threads (default: torch's; 1 avoids oversubscription on a shared machine)."),
    ]
    for option in reversed(options):
        func = option(func)
    return func


def deep_model_params(*, epochs, lam, backbone, weights_path, finetune, image_size, hidden_size, batch_size, lr,
                      weight_decay, optimizer, early_stopping, checkpoint_dir, resume, n_threads=None) -> dict:
    """``[methods.model]`` of a fabric-deep experiment from parsed command-line options (``lam`` aside).

    Checked by building the estimator, so bad options fail before any data is read.
    """
    from tzsl.models import DeepAttributeEmbedding  # noqa: PLC0415

    if resume and checkpoint_dir is None:
        raise ConfigError("--resume needs --checkpoint-dir")
    params = {"backbone": backbone, "weights_path": None if weights_path is None else str(weights_path),
              "finetune": parse_finetune(str(finetune)), "image_size": image_size, "hidden_size": hidden_size,
              "epochs": epochs, "batch_size": batch_size, "lr": lr, "weight_decay": weight_decay,
              "optimizer": optimizer, "early_stopping": early_stopping,
              "checkpoint_dir": None if checkpoint_dir is None else str(checkpoint_dir), "resume": resume,
              "n_threads": n_threads}
    params = {k: v for k, v in params.items() if v is not None}
    DeepAttributeEmbedding(lam=parse_lam(str(lam)), **params)._check_params()
    return params


def train_deep_values(out: Path, results: Path | None, config: str, attributes: str, gelsight_root: Path | None,
                      conditions: tuple[str, ...], data_dir: Path | None, seed: int, no_progress: bool,
                      lam, dataset: str = "fabric", **model_options) -> dict:
    """``tzsl train-deep``'s options as the keys of a ``study = "fabric-deep"`` experiment."""
    from tzsl.studies.config import option_values  # noqa: PLC0415

    if conditions and gelsight_root is None:
        raise ConfigError("--condition needs --gelsight-root")
    fit = {
        "output.folder": str(results if results is not None else (out.parent if str(out.parent) else Path("."))),
        "output.model": str(out), "splits.n_seeds": 1, "methods.embedding_lambdas": [parse_lam(str(lam))],
        "methods.model": deep_model_params(lam=lam, **model_options),
        **option_values("fabric-deep", {"seed": seed, "data_dir": data_dir, "progress": not no_progress}),
    }
    if dataset == "physiclear":
        fabric_only = [name for name, given in (("--config", config != "1"), ("--attributes", attributes != "a8"),
                                                ("--gelsight-root", gelsight_root is not None)) if given]
        if fabric_only:
            raise ConfigError(f"{', '.join(fabric_only)}: fabric data only; --dataset physiclear reads its own "
                              "videos, class-attribute table and object split")
        return {**fit, "dataset.builtin": "physiclear"}
    return {**fit, "splits.configs": [int(config)], "dataset.attributes": attributes,
            "dataset.gelsight_root": None if gelsight_root is None else str(gelsight_root),
            "features.gelsight_conditions": list(conditions) or None}


@cli.command("train-deep")
@click.option("--out", type=click.Path(dir_okay=False, path_type=Path), required=True,
              help="Write the trained model bundle here (e.g. model.tzsl-deep).")
@click.option("--results", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Folder of the run's tables (fabric_deep_runs.csv, fabric_deep_table.csv, manifest) "
                   "[default: the bundle's folder].")
@click.option("--dataset", type=click.Choice(["fabric", "physiclear"]), default="fabric", show_default=True,
              help="fabric: the fabric depth images (or --gelsight-root); physiclear: the 5 contact key frames of "
                   "PhysiCLeAR's GelSight videos, fitted on the paper's training objects and scored on its test "
                   "objects (fetch: tzsl data fetch physiclear).")
@click.option("--config", "config", type=click.Choice(["1", "2"]), default="1", show_default=True,
              help="Fabric zero-shot split: 1 = the paper's (test groups 0, 5, 7), 2 = test groups 0, 4, 7.")
@click.option("--attributes", type=click.Choice(["a8", "a4", "a12", "three_value_a8", "three_value_a8v2"]),
              default="a8", show_default=True, help="Group x attribute matrix of the fabric data.")
@click.option("--gelsight-root", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Train on your GelSight press videos (<root>/fabric_groups.csv, "
                   "<root>/<condition>/<fabric_name>/<press>.avi) instead of the fabric depth images.")
@click.option("--condition", "conditions", multiple=True,
              help="With --gelsight-root: the condition folder to use (required when there are several).")
@deep_model_options
@data_dir_option
@seed_option(study=None)
@force_option
@no_progress_option
def train_deep(out: Path, results: Path | None, dataset: str, config: str, attributes: str,
               gelsight_root: Path | None, conditions: tuple[str, ...], data_dir: Path | None, seed: int, force: bool,
               no_progress: bool, **model_options) -> None:
    """Train the CNN + LSTM attribute model (fabric paper), save it, and write its train/test accuracy.

    A front-end of the fabric-deep study: the same as 'tzsl run' of a study = "fabric-deep" file with
    one config, one lambda, one seed and [output] model = OUT. Sequences: each fabric's depth images
    in capture order (5 evenly spaced), or the 5 key frames of every press video under
    --gelsight-root, or (--dataset physiclear) the 5 contact key frames of every PhysiCLeAR video.
    """
    from tzsl.studies.config import config_from_options  # noqa: PLC0415
    from tzsl.studies.engine import run_experiment  # noqa: PLC0415

    if out.exists() and not force:
        raise ConfigError(f"{out} already exists; use --force to overwrite it")
    values = train_deep_values(out, results, config, attributes, gelsight_root, conditions, data_dir, seed,
                               no_progress, dataset=dataset, **model_options)
    require_torch()
    folder, _ = run_experiment(config_from_options("fabric-deep", values), force=force, echo=click.echo)
    click.echo(f"wrote {out} and {', '.join(p.name for p in folder.written)} to {folder.root}")
