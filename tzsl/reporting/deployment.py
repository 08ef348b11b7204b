"""The deploy choice of a zero-shot study, as the terminal and the HTML report say it.

A ``study = "zero-shot"`` run records the method it would deploy (``deployment`` in its record and
manifest, the same dict as its ``deployment.json``: :mod:`tzsl.studies.zero_shot.deployment`).
:func:`deployment_lines` says it in a few sentences read from that record, nothing computed again:
what is chosen and why (with its interval and chance), that its accuracy on the splits it was
chosen on is optimistic, and how a robot gets the model. A study that made no choice (a paper
preset, an older results folder) gets the generic default of ``tzsl train-attributes``
(:data:`tzsl.models.choices.DEFAULT_METHOD`) and says so.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from tzsl.reporting.manifests import dict_at

__all__ = ["deploy_choice", "deployment_lines"]


def deploy_choice(record: Mapping[str, Any]) -> dict[str, Any] | None:
    """The ``deployment`` of a study record (or of its generic part's), None when it made none."""
    found = record.get("deployment") or dict_at(dict(record), "zero_shot").get("deployment")
    return found if isinstance(found, dict) and "label" in found else None


def deployment_lines(record: Mapping[str, Any], root: str | Path) -> list[str]:
    """Sentences (unwrapped) saying what a robot would be given: the first starts ``deploy:``, the last says
    where the model is or how to train it.

    Parameters
    ----------
    record : dict
        A study's record (``StudyRun.record``, or a manifest's ``config``).
    root : path
        The results folder (where ``deployment.json`` and the model file are).
    """
    choice = deploy_choice(record)
    if choice is None:
        from tzsl.models import get_method  # noqa: PLC0415 - the registry, read only when a summary is printed
        from tzsl.models.choices import DEFAULT_METHOD  # noqa: PLC0415

        preset = ", ".join(f"{key}={value}" for key, value in get_method(DEFAULT_METHOD).preset.items())
        return [f"deploy: not chosen here; tzsl train-attributes trains {DEFAULT_METHOD} by default"
                + (f" ({preset})" if preset else "")]
    lines = [f"deploy: {choice['label']} (deployment.json): {choice['reason']}"]
    if choice.get("chosen") and choice.get("branch") != "too-few-splits":
        lines.append(str(choice["selection_note"]))
    model = choice.get("model_file")
    if model:
        lines.append(f"model: {Path(root) / model}, trained on every object (tzsl predict --model ...)")
    else:
        lines.append(f"model: tzsl train-attributes --from-results {root} --out model.tzsl")
    return lines
