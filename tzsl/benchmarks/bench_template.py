"""``make bench``'s template part: the generic study's template on a SIMULATED mid-size dataset, cold and warm.

Issue 33 timed the shipped template (``experiments/my_dataset_template.toml``: a ``zero-shot``
study, every registered method, random and challenging splits, calibrated posteriors, GZSL) on a
public dataset of 41 objects, 2,549 grasps and 3 fingers. The bench writes a SIMULATED plain
dataset of that shape (:func:`write_template_dataset`, with
:func:`tzsl.datasets.write_synthetic_dataset`: one object per class, features a fixed random
non-linear function of the class's attributes plus noise; :data:`TEMPLATE_SHAPE`), copies the
template beside it unchanged (its ``plain = "my_dataset"`` is relative to the file) and times
``tzsl run`` of it cold and warm (:func:`tzsl.benchmarks._common.cold_and_warm`). Every number of
this part is from SIMULATED data: it measures cost, not recognition.
"""

from __future__ import annotations

import shutil
import tomllib
from collections.abc import Callable
from pathlib import Path

from tzsl.benchmarks._common import cold_and_warm

__all__ = ["DEFAULT_TEMPLATE", "TEMPLATE_SHAPE", "run_template", "write_template_dataset"]

#: The template ``make bench`` times, relative to the repository root (the folder ``make`` runs in).
DEFAULT_TEMPLATE = Path("experiments") / "my_dataset_template.toml"
#: Shape of the simulated dataset: the public dataset's objects (one class each), grasps and fingers
#: (sensors) as issue 33 gives them; the issue does not give its attributes and features per finger,
#: so ``n_attributes`` and ``n_features`` are the bench's choice.
TEMPLATE_SHAPE: dict[str, int] = {"n_classes": 41, "n_trials": 2549, "n_sensors": 3, "n_attributes": 12,
                                  "n_features": 24}


def write_template_dataset(folder: Path, *, seed: int = 0) -> Path:
    """Write the SIMULATED dataset of :data:`TEMPLATE_SHAPE` into ``folder`` (a plain dataset; its
    ``dataset.toml`` names it ``synthetic-SIMULATED``); returns ``folder``."""
    from tzsl.datasets import write_synthetic_dataset  # noqa: PLC0415

    shape = dict(TEMPLATE_SHAPE)
    return write_synthetic_dataset(folder, shape.pop("n_trials"), seed=seed, **shape)


def run_template(work: Path, *, template: Path = DEFAULT_TEMPLATE, n_jobs: int = 2,
                 echo: Callable[[str], None] = print) -> list[dict]:
    """Write the simulated dataset and the template beside it in ``work/template/``, and time
    ``tzsl run`` of the template cold and warm (measurements of part ``template``, all SIMULATED).

    The dataset is written where the template's ``[dataset] plain`` (relative to the file) points.

    Raises
    ------
    FileNotFoundError
        ``template`` does not exist (``make bench`` runs from the repository root).
    """
    if not Path(template).is_file():
        raise FileNotFoundError(f"{template}: no such template (run make bench from the repository root)")
    plain = tomllib.loads(Path(template).read_text(encoding="utf-8"))["dataset"]["plain"]
    folder = work / "template"
    folder.mkdir(parents=True, exist_ok=True)
    shape = ", ".join(f"{value} {key.removeprefix('n_')}" for key, value in TEMPLATE_SHAPE.items())
    echo(f"template: writing a SIMULATED dataset ({shape}) ...")
    write_template_dataset(folder / plain)
    experiment = folder / Path(template).name
    shutil.copyfile(template, experiment)
    return cold_and_warm("template", ["run", experiment], work, n_jobs=n_jobs, simulated=True, echo=echo)
