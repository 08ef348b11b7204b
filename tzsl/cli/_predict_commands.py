"""``tzsl predict``: rank candidate classes for new grasps with a saved model (any method, one path).

Per-EP (active touch) bundles take ``--eps-done`` and report the ranking, the decision of the
stopping rule and, with ``--suggest-next``, the next EP; ``--json`` prints one JSON object.
"""

from __future__ import annotations

import json
from pathlib import Path

import click

from tzsl.cli._root import cli
from tzsl.exceptions import ConfigError


def _names(text: str | None) -> list[str] | None:
    if text is None:
        return None
    names = [t.strip() for t in text.split(",") if t.strip()]
    if not names:
        raise ConfigError(f"expected a comma-separated list of names, got {text!r}")
    return names


@cli.command("predict", short_help="Rank candidate classes for new grasps with a saved model (SC-/DF-MDAP, active).")
@click.option("--model", "model_path", type=click.Path(dir_okay=False, path_type=Path), required=True,
              help="Model bundle written by train-attributes, train-hand or train-deep (loading it runs no code).")
@click.option("--classes", type=click.Path(path_type=Path), required=True,
              help="Candidate classes: CSV with the class name first, then one 0/1 column per model attribute; "
                   "or a plain dataset folder (its classes.csv).")
@click.option("--candidates", default=None,
              help="Comma-separated classes of --classes to rank (default: every row), e.g. the unseen ones.")
@click.option("--multi-grasp", "mode", type=click.Choice(["sc", "df"]), default="sc", show_default=True,
              help="Multi-grasp fusion: sc = SC-MDAP (stop at k equal decisions), df = DF-MDAP (average grasps).")
@click.option("--k", type=click.IntRange(min=1), default=3, show_default=True,
              help="Equal classifications SC-MDAP needs.")
@click.option("--top", type=click.IntRange(min=0), default=5, show_default=True,
              help="Classes listed per grasp (0 = all).")
@click.option("--eps-done", default=None,
              help="Per-EP bundles: EPs done so far on the object, comma-separated (e.g. squeeze,hold); GRASP is "
                   "one trial's feature file holding at least their columns.")
@click.option("--suggest-next", is_flag=True, help="Per-EP bundles: also suggest the next EP (largest expected "
                                                   "entropy reduction).")
@click.option("--threshold", type=click.FloatRange(0, 1), default=None,
              help="Per-EP bundles: decided when the top class posterior reaches this [default: that of "
                   "tzsl.models.active_touch.suggest_next_ep, printed in the output].")
@click.option("--max-eps", type=click.IntRange(min=1), default=None, help="Per-EP bundles: EP budget.")
@click.option("--max-seconds", type=click.FloatRange(min=0), default=None, help="Per-EP bundles: budget in seconds.")
@click.option("--json", "as_json", is_flag=True, help="Print the report as one JSON object (with the posteriors "
                                                     "and how their calibrator was fitted).")
@click.option("--trust-pickle", is_flag=True,
              help="Also load an old (format 1) bundle holding a pickle, which runs code from the file: "
                   "only for a file whose author you trust. Better: re-run the train command.")
@click.argument("grasp", nargs=-1, required=True, type=click.Path(path_type=Path))
def predict(model_path: Path, classes: Path, candidates: str | None, mode: str, k: int, top: int,
            eps_done: str | None, suggest_next: bool, threshold: float | None, max_eps: int | None,
            max_seconds: float | None, as_json: bool, trust_pickle: bool, grasp: tuple[Path, ...]) -> None:
    """Classify GRASP... (in arrival order) among the candidate classes and fuse the grasps.

    GRASP, as the model's feature schema says: feature files (.csv / .npz: a plain dataset's
    trials.csv, a 'tzsl extract --out' table; no attribute row is read) or, for models trained on
    signal files, signal files (one per grasp for one-sensor models) or a CSV with a signal_file
    column; for hand models, grasp .npz files or grasp folders; for deep (CNN + LSTM) models,
    press videos (.avi) or .npz files with a 'frames' array (5, H, W[, C]). An .npz input whose
    arrays declare more than 2 GiB is refused before loading; raise the limit (in bytes) with the
    environment variable TZSL_MAX_NPZ_BYTES.
    """
    from tzsl.inference import Recogniser  # noqa: PLC0415 - the Python API: the same result from Python
    from tzsl.inference.bundle import read_bundle_header  # noqa: PLC0415
    from tzsl.inference.bundle_kinds import PER_EP_KIND  # noqa: PLC0415

    active = read_bundle_header(model_path).kind == PER_EP_KIND
    if not active and (eps_done or suggest_next or threshold is not None or max_eps or max_seconds):
        raise ConfigError(f"{model_path}: --eps-done, --suggest-next, --threshold, --max-eps and --max-seconds "
                          "need a per-EP bundle (tzsl train-attributes --per-ep)")
    if active:
        if not _names(eps_done):
            raise ConfigError(f"{model_path}: a per-EP bundle needs --eps-done (the EPs done so far, "
                              "e.g. squeeze,hold)")
        if len(grasp) != 1:
            raise ConfigError(f"a per-EP bundle reads one feature file (one trial), got {len(grasp)} files")
    recogniser = Recogniser.load(model_path, classes, candidates=_names(candidates), mode=mode, k=k,
                                 trust_pickle=trust_pickle)
    if active:
        _print_active(recogniser, classes, grasp[0], _names(eps_done), suggest_next, threshold, max_eps,
                      max_seconds, as_json, top)
        return
    from tzsl.inference.predict import format_prediction, prediction_report  # noqa: PLC0415

    predictor = recogniser.predictor
    assert predictor is not None  # None only for a per-EP bundle, handled above
    result = recogniser.classify(list(grasp))
    if as_json:
        click.echo(json.dumps(prediction_report(result, predictor, top=top), sort_keys=False))
        return
    click.echo(f"model: {predictor.describe()}")
    click.echo(f"classes: {len(recogniser.classes)} from {classes}")
    click.echo(format_prediction(result, top=top))


def _print_active(recogniser, classes, features_file, eps_done, suggest_next, threshold, max_eps, max_seconds,
                  as_json, top) -> None:
    from tzsl.inference.predict_active import format_active_report  # noqa: PLC0415

    report = recogniser.suggest_next_ep_from_file(features_file, eps_done, threshold=threshold, max_eps=max_eps,
                                                  max_seconds=max_seconds)
    if as_json:
        click.echo(json.dumps(report, sort_keys=False))
        return
    metadata = recogniser.per_ep[1]
    for note in recogniser.classes.attrs.get("notes", []):
        click.echo(f"note: {note}")
    click.echo(f"model: per-EP attribute model, EPs {', '.join(metadata['eps'])}, "
               f"{len(metadata['attribute_names'])} attributes")
    click.echo(f"classes: {len(recogniser.classes)} from {classes}")
    click.echo(format_active_report(report, top=top, suggest=suggest_next))
