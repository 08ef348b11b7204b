"""How a zero-shot run names itself in its tables: its study, its data, and whether a paper's numbers apply.

The paper's numbers appear only beside results on the paper's own dataset and protocol
(SPEC, evaluation rules): :func:`study_labels` decides that once per run, from the resolved
experiment and the dataset read, and says why when a paper preset runs without them.
"""

from __future__ import annotations

from dataclasses import dataclass

from tzsl.datasets import FeatureSet, get_dataset

__all__ = ["GENERIC_STUDY", "PAPER_PRESET", "StudyLabels", "paper_protocol", "study_labels"]

#: The generic study kind and the PHAC-2 paper's preset of it.
GENERIC_STUDY = "zero-shot"
PAPER_PRESET = "phac2-dap"


@dataclass(frozen=True)
class StudyLabels:
    """Labels of one run's tables.

    Attributes
    ----------
    study : str
        ``study`` column of the method comparison: ``"phac2"`` for the paper preset on the paper's
        data and protocol, else ``"zero-shot"``; with ``[output] prefix``, ``"-<prefix>"`` after it.
    data : str
        ``data`` column: ``"real"`` (a built-in real dataset), ``"simulated"`` or the user's
        dataset name (a plain folder or feature table).
    paper : bool
        Whether the paper's numbers (``paper_*`` columns, paper notes) go beside ours.
    note : str
        Why a paper preset runs without the paper's numbers ("" otherwise).
    """

    study: str = GENERIC_STUDY
    data: str = "real"
    paper: bool = False
    note: str = ""

    @property
    def methods_table(self) -> str:
        """File stem of the per-split method accuracies."""
        return "phac2_methods" if self.paper else "methods_per_split"

    @property
    def comparison_table(self) -> str:
        """File stem of the method comparison."""
        return "phac2_method_comparison" if self.paper else "method_comparison"

    @property
    def reliability_table(self) -> str:
        """File stem of the reliability diagram's points (and of its figure)."""
        return "phac2_reliability" if self.paper else "reliability"


def _protocol_differences(config) -> list[str]:
    """How the run's protocol differs from the DAP paper's (empty: it is the paper's)."""
    from tzsl.studies.papers import numbers as paper  # noqa: PLC0415

    ds, splits = config.dataset, config.splits
    why = []
    if ds.builtin not in paper.DAP_PAPER_DATASETS:
        source = ds.builtin or ("plain folder" if ds.plain is not None else "feature table")
        why.append(f"dataset {source} (paper: {' or '.join(paper.DAP_PAPER_DATASETS)})")
    if splits.kinds == ["file"]:
        why.append("splits from a file")
    if splits.n_test != paper.DAP_N_TEST:
        why.append(f"splits.n_test = {splits.n_test} (paper: {paper.DAP_N_TEST})")
    if ds.min_objects not in (None, paper.DAP_MIN_OBJECTS):
        why.append(f"dataset.min_objects = {ds.min_objects} (paper: {paper.DAP_MIN_OBJECTS})")
    return why


def paper_protocol(study: str, config) -> tuple[bool, str]:
    """Whether the paper's numbers apply to a run of ``config``, and why not ("" when they do)."""
    if study != PAPER_PRESET:
        return False, ""
    why = _protocol_differences(config)
    if not why:
        return True, ""
    return False, (f"study '{PAPER_PRESET}' is the PHAC-2 paper's preset of study '{GENERIC_STUDY}'; here it "
                   f"runs without the paper's numbers: {'; '.join(why)}")


def study_labels(study: str, config, features: FeatureSet) -> StudyLabels:
    """The labels of a ``zero-shot`` or ``phac2-dap`` run of ``config`` on ``features``.

    The paper's numbers apply when the study is the paper preset and its dataset and protocol
    are the paper's (:func:`paper_protocol`); an ``[output] prefix`` is appended to the study
    label (``phac2-headlines``), so two runs stack apart in one comparison; ``data`` is ``real`` for a built-in
    dataset recorded on hardware, ``simulated`` for a built-in dataset tzsl simulates (``hand-simulated``),
    else the dataset's name (which says ``SIMULATED`` for tzsl's simulated plain datasets).
    """
    builtin = config.dataset.builtin
    if builtin is not None:
        data = "simulated" if get_dataset(builtin).simulated else "real"
    else:
        data = features.dataset or "user dataset"
    paper, note = paper_protocol(study, config)
    prefix = config.output.prefix
    label = ("phac2" if paper else GENERIC_STUDY) + (f"-{prefix}" if prefix else "")
    return StudyLabels(study=label, data=data, paper=paper, note=note)
