"""The generic study inside a paper preset: ``[zero_shot]`` of ``study = "fabric"`` and ``"hand"``.

A paper preset runs the ``zero-shot`` study (:func:`~tzsl.studies.zero_shot.runner.run_zero_shot`)
on its built-in dataset (``fabric-depth``, ``hand-simulated``) and then the paper's protocol. The
generic part is an ordinary ``zero-shot`` experiment built from the preset's file: its
``[zero_shot.methods]``, ``[zero_shot.gzsl]``, ``[zero_shot.splits]`` and ``[zero_shot.svm]``, the
preset's ``[compute]`` and ``[output] folder``, every file written as ``<dataset>_<name>``
(``fabric-depth_table1_fusion.csv``), so no name collides with the paper protocol's
(``fabric_*``, ``hand_*``). Its tables carry no paper number: the study is ``zero-shot``.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from tzsl.studies.config import Experiment, ZeroShotStudy
from tzsl.studies.outputs.results_folder import ResultsDir
from tzsl.studies.outputs.study_run import StudyRun
from tzsl.studies.zero_shot.runner import (
    SelectedColumns,
    dropped_columns,
    relaxation_notes,
    run_zero_shot,
    zero_shot_outputs,
)

__all__ = ["PRESET_DATASETS", "PresetHooks", "generic_experiment", "preset_outputs", "preset_relaxation_notes",
           "preset_results", "run_generic_part", "with_generic_part"]

#: The built-in dataset each paper preset runs the generic study on.
PRESET_DATASETS: dict[str, str] = {"fabric": "fabric-depth", "hand": "hand-simulated"}


def _skipped(exp: Experiment) -> str | None:
    """Why the generic part does not run ("" / None when it does)."""
    c = exp.config
    if not c.zero_shot.enabled:
        return "[zero_shot] enabled = false"
    if getattr(c.dataset, "grasps", None) is not None:
        return "[dataset] grasps: the generic part runs on the built-in hand-simulated dataset only"
    return None


def generic_experiment(exp: Experiment) -> Experiment | None:
    """The ``zero-shot`` experiment of a paper preset's ``[zero_shot]`` (None when it does not run).

    Parameters
    ----------
    exp : Experiment
        A checked ``fabric`` or ``hand`` experiment.

    Returns
    -------
    Experiment or None
        ``study = "zero-shot"`` on :data:`PRESET_DATASETS` ``[exp.study]``, source
        ``"<source> [zero_shot]"``; None with ``[zero_shot] enabled = false`` or a grasp folder.
    """
    if _skipped(exp) is not None:
        return None
    c, part = exp.config, exp.config.zero_shot
    builtin = PRESET_DATASETS[exp.study]
    dataset = {"builtin": builtin, "data_dir": getattr(c.dataset, "data_dir", None)}
    if part.min_objects is not None:
        dataset["min_objects"] = part.min_objects
    config = ZeroShotStudy.model_validate({
        "study": "zero-shot", "description": f"the generic zero-shot study of preset {exp.study!r}",
        "dataset": dataset, "methods": part.methods.model_dump(), "gzsl": part.gzsl.model_dump(),
        "splits": part.splits.model_dump(), "svm": part.svm.model_dump(), "compute": c.compute.model_dump(),
        "output": {"folder": c.output.folder, "prefix": builtin}})
    return Experiment(source=f"{exp.source} [zero_shot]", base=exp.base, config=config)


def preset_outputs(exp_config, paper_outputs: list[str]) -> list[str]:
    """Files a preset run writes: ``manifest.json``, the generic part's (``<dataset>_<name>``) and the
    paper protocol's (``paper_outputs``)."""
    names = ["manifest.json", *paper_outputs]
    if exp_config.zero_shot.enabled and getattr(exp_config.dataset, "grasps", None) is None:
        generic = ZeroShotStudy.model_validate({
            "dataset": {"builtin": PRESET_DATASETS[exp_config.study]},
            "methods": exp_config.zero_shot.methods.model_dump(),
            "splits": exp_config.zero_shot.splits.model_dump(), "svm": exp_config.zero_shot.svm.model_dump(),
            "output": {"folder": exp_config.output.folder, "prefix": PRESET_DATASETS[exp_config.study]}})
        names += zero_shot_outputs(generic)
    return list(dict.fromkeys(names))


def preset_results(exp: Experiment, force: bool, paper_outputs: list[str]) -> ResultsDir:
    """The staged results folder of a preset run, its files checked free before any fit."""
    generic = generic_experiment(exp)
    drop = {} if generic is None else dropped_columns(generic.config.methods, generic.config.output.prefix)
    results = SelectedColumns(Path(exp.config.output.folder), force, drop, staging=True)
    results.check_free(preset_outputs(exp.config, paper_outputs))
    return results


def preset_relaxation_notes(exp: Experiment) -> list[str]:
    """``tzsl run --check`` lines of the generic part (settings its dataset cannot honour)."""
    generic = generic_experiment(exp)
    return [] if generic is None else [f"[zero_shot] {line}" for line in relaxation_notes(generic)]


class PresetHooks:
    """The engine's hooks of one paper preset (``outputs``, ``results``, ``notes`` of
    :func:`~tzsl.studies.config.register_study`), from the files its paper protocol writes.

    Parameters
    ----------
    paper_outputs : callable
        ``paper_outputs(config) -> list[str]``: the paper protocol's files for a checked config.
    """

    def __init__(self, paper_outputs: Callable[[object], list[str]]) -> None:
        self.paper_outputs = paper_outputs

    def outputs(self, config) -> list[str]:
        """Files the preset run writes: the generic part's and the paper protocol's."""
        return preset_outputs(config, self.paper_outputs(config))

    def results(self, exp: Experiment, force: bool) -> ResultsDir:
        """The staged results folder of the run (every file checked free before any fit)."""
        return preset_results(exp, force, self.paper_outputs(exp.config))

    def notes(self, exp: Experiment) -> list[str]:
        """``tzsl run --check``: the settings the generic part relaxes on the preset's dataset."""
        return preset_relaxation_notes(exp)


def run_generic_part(exp: Experiment, results: ResultsDir, say: Callable[[str], None]) -> StudyRun | None:
    """Run the generic study of a preset into ``results`` (None, said, when it does not run)."""
    generic = generic_experiment(exp)
    if generic is None:
        say(f"note: generic zero-shot tables not run: {_skipped(exp)}")
        return None
    say(f"\n== {exp.study}: the generic zero-shot study on {generic.config.dataset.builtin} ==")
    return run_zero_shot(generic, results, say)


def with_generic_part(paper: StudyRun, generic: StudyRun | None) -> StudyRun:
    """One StudyRun of a preset: the paper's tables and record, the generic part's beside them.

    The generic tables are keyed ``zero_shot_<name>``; the record's ``zero_shot`` holds the generic
    part's record (its ``labels``, ``relaxations``, ...), or None when it did not run.
    """
    if generic is None:
        return StudyRun(paper.tables, {**paper.record, "zero_shot": None}, paper.data_files)
    tables = {**paper.tables, **{f"zero_shot_{name}": table for name, table in generic.tables.items()}}
    data_files = list(dict.fromkeys([*map(str, paper.data_files), *map(str, generic.data_files)]))
    return StudyRun(tables, {**paper.record, "zero_shot": generic.record}, [Path(p) for p in data_files])
