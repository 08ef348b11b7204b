"""Deep-model commands: ``train-deep`` (needs the ``deep`` extra: ``pip install tzsl[deep]``)."""

from __future__ import annotations

from pathlib import Path

import click

from tzsl.cli._main import SchemaOption, cli, data_dir_option, force_option, no_progress_option, seed_option
from tzsl.exceptions import ConfigError


def model_default(name: str):
    """The default of :class:`~tzsl.models.DeepAttributeEmbedding`'s parameter ``name``, read when needed."""

    def read():
        from tzsl.experiments.config import estimator_parameters  # noqa: PLC0415

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


def build_deep_model(*, epochs, lam, backbone, weights_path, finetune, image_size, hidden_size, batch_size,
                     lr, weight_decay, optimizer, checkpoint_dir, resume, seed, n_threads=None, verbose=True):
    """A :class:`~tzsl.models.DeepAttributeEmbedding` from parsed command-line options."""
    from tzsl.models import DeepAttributeEmbedding  # noqa: PLC0415

    if resume and checkpoint_dir is None:
        raise ConfigError("--resume needs --checkpoint-dir")
    model = DeepAttributeEmbedding(
        backbone=backbone, weights_path=weights_path, finetune=parse_finetune(str(finetune)),
        image_size=image_size, hidden_size=hidden_size, lam=parse_lam(str(lam)), epochs=epochs,
        batch_size=batch_size, lr=lr, weight_decay=weight_decay, optimizer=optimizer,
        checkpoint_dir=checkpoint_dir, resume=resume, verbose=verbose, n_threads=n_threads, random_state=seed,
    )
    model._check_params()  # fail on bad options before any data is read
    return model


@cli.command("train-deep")
@click.option("--out", type=click.Path(dir_okay=False, path_type=Path), required=True,
              help="Write the trained model bundle here (e.g. model.tzsl-deep).")
@click.option("--config", "config", type=click.Choice(["1", "2"]), default="1", show_default=True,
              help="Fabric zero-shot split: 1 = the paper's (test groups 0, 5, 7), 2 = test groups 0, 4, 7.")
@click.option("--attributes", type=click.Choice(["a8", "a4", "a12", "three_value_a8", "three_value_a8v2"]),
              default="a8", show_default=True, help="Group x attribute matrix of the fabric data.")
@click.option("--gelsight-root", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Train on your GelSight press videos (<root>/fabric_groups.csv, "
                   "<root>/<condition>/<fabric_name>/<press>.avi) instead of the fabric depth images.")
@click.option("--condition", "conditions", multiple=True,
              help="With --gelsight-root: condition folder(s) to use (repeatable; default all).")
@deep_model_options
@data_dir_option
@seed_option(study=None)
@force_option
@no_progress_option
def train_deep(out: Path, config: str, attributes: str, gelsight_root: Path | None, conditions: tuple[str, ...],
               data_dir: Path | None, seed: int, force: bool, no_progress: bool, **model_options) -> None:
    """Train the CNN + LSTM attribute model (fabric paper) and print train/test accuracy.

    Sequences: each fabric's depth images in capture order (5 evenly spaced), or the 5 key
    frames of every press video under --gelsight-root. The trained model is saved as a bundle.
    """
    from tzsl.experiments.deep import format_deep_result, load_deep_sequences, run_deep_fabric  # noqa: PLC0415
    from tzsl.models import save_deep_bundle  # noqa: PLC0415

    if out.exists() and not force:
        raise ConfigError(f"{out} already exists; use --force to overwrite it")
    if conditions and gelsight_root is None:
        raise ConfigError("--condition needs --gelsight-root")
    require_torch()
    model = build_deep_model(seed=seed, verbose=not no_progress, **model_options)
    sequences, table = load_deep_sequences(
        data_dir=data_dir, gelsight_root=gelsight_root, conditions=list(conditions) or None, attributes=attributes
    )
    source = f"GelSight videos under {gelsight_root}" if gelsight_root else "fabric depth images"
    result = run_deep_fabric(sequences, table, config=int(config), model=model)
    click.echo(format_deep_result(result, source))
    save_deep_bundle(result.model, out, force=force)
    click.echo(f"wrote {out}")
