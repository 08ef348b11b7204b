"""The zero-shot study's runner: ``study = "zero-shot"`` and its PHAC-2 paper preset ``"phac2-dap"``.

Registered in :mod:`tzsl.studies.config` (:func:`~tzsl.studies.config.register_study`):
:func:`run_zero_shot` runs a checked experiment, :func:`zero_shot_results` opens its results folder,
:func:`zero_shot_outputs` lists the files it writes and :func:`relaxation_notes` says, before any
fit, which settings the dataset cannot honour (``tzsl run --check``).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from tzsl._profile import stage
from tzsl.datasets import FeatureSet
from tzsl.exceptions import ConfigError
from tzsl.studies.config import Experiment
from tzsl.studies.outputs.results_folder import PrefixedResults, ResultsDir, prefixed
from tzsl.studies.outputs.study_run import StudyRun, format_table
from tzsl.value_lists import FUSIONS, PRIORS

__all__ = ["PreparedStudy", "SelectedColumns", "dropped_columns", "load_study_features", "prepare", "relaxation_notes",
           "run_zero_shot", "zero_shot_outputs", "zero_shot_results"]


class SelectedColumns(ResultsDir):
    """A results folder that leaves unselected fusion / prior columns out of Tables 1 and 2."""

    def __init__(self, root, force: bool, drop: Mapping[str, list[str]], staging: bool = False) -> None:
        super().__init__(root, force=force, staging=staging)
        self.drop = dict(drop)

    def write_csv(self, name: str, table: pd.DataFrame, index: bool = False) -> Path:
        return super().write_csv(name, table.drop(columns=self.drop.get(name, []), errors="ignore"), index)


def dropped_columns(methods, prefix: str = "") -> dict[str, list[str]]:
    """Columns of Tables 1 and 2 that ``[methods] fusions`` / ``priors`` leave out, by file name
    (with the run's ``[output] prefix``)."""
    drop: dict[str, list[str]] = {"table1_fusion.csv": [], "table2_priors.csv": []}
    for fusion in sorted(set(FUSIONS) - set(methods.fusions)):
        for column in [f"{fusion}dap"] + (["avgdap_per_class_mean"] if fusion == "avg" else []):
            drop["table1_fusion.csv"] += [column, f"{column}_ci95_low", f"{column}_ci95_high"]
        drop["table1_fusion.csv"].append(f"paper_{fusion}dap")
    for prior in sorted(set(PRIORS) - set(methods.priors)):
        drop["table2_priors.csv"] += [prior, f"{prior}_ci95_low", f"{prior}_ci95_high", f"paper_{prior}"]
    return {prefixed(prefix, name): columns for name, columns in drop.items()}


def zero_shot_outputs(config) -> list[str]:
    """Files a zero-shot (or phac2-dap) run writes (checked free before any computation)."""
    from tzsl.studies.papers.run_labels import StudyLabels, paper_protocol  # noqa: PLC0415
    from tzsl.studies.zero_shot.spread import FUSION_PRIOR_TABLE, REFIT_TABLE  # noqa: PLC0415

    labels = StudyLabels(paper=paper_protocol(config.study, config)[0])
    kinds, methods = config.splits.kinds, config.methods
    names = ["splits.csv", "failed_splits.csv", f"{FUSION_PRIOR_TABLE}.csv"]
    if config.splits.refit_seeds:
        names.append(f"{REFIT_TABLE}.csv")
    if "random" in kinds or "file" in kinds:
        names += ["table1_fusion.csv", "table2_priors.csv", "attribute_accuracy.csv",
                  "attribute_accuracy_per_split.csv", "attribute_accuracy.png"]
        if methods.multilabel:
            names.append("multilabel.csv")
        if methods.sweep:
            names += ["attribute_sweep.csv", "attribute_sweep.png"]
        if methods.method_specs():
            names += [f"{labels.methods_table}.csv", f"{labels.comparison_table}.csv",
                      f"{labels.reliability_table}.csv", f"{labels.reliability_table}.png"]
        if methods.gzsl:
            names.append("gzsl.csv")
    if "challenging" in kinds:
        names += ["table3_challenging.csv", "object_map.csv", "object_map.png"]
        if methods.method_specs() and "challenging" in methods.compare_on:
            names += [f"{labels.methods_table}.csv", f"{labels.comparison_table}.csv",
                      f"{labels.reliability_table}.csv", f"{labels.reliability_table}.png"]
    if config.study == "zero-shot":
        from tzsl.studies.zero_shot.deployment import CLASS_ACCURACY_FILE, DEPLOYMENT_FILE, MODEL_FILE  # noqa: PLC0415

        names += [DEPLOYMENT_FILE, *([MODEL_FILE] if config.output.model else [])]
        if "random" in kinds or "file" in kinds:
            names.append(CLASS_ACCURACY_FILE)
    return ["manifest.json", *dict.fromkeys(prefixed(config.output.prefix, n) for n in names)]


def zero_shot_results(exp: Experiment, force: bool) -> ResultsDir:
    """The staged results folder of a zero-shot run, leaving unselected fusion / prior columns out."""
    output = exp.config.output
    results = SelectedColumns(Path(output.folder), force, dropped_columns(exp.config.methods, output.prefix),
                              staging=True)
    results.check_free(zero_shot_outputs(exp.config))
    return results


def load_study_features(exp: Experiment):
    """The FeatureSet of a zero-shot experiment's ``[dataset]`` and ``[features]``
    (:func:`tzsl.features.load_features`)."""
    from tzsl.features import load_features  # noqa: PLC0415

    ds, feat, compute = exp.config.dataset, exp.config.features, exp.config.compute
    plain_options = {} if ds.plain is None else {  # signal files: read in n_jobs processes, cached with the fits
        "statistics": feat.statistics, "baseline_rows": feat.baseline_rows, "channels": feat.channels,
        "n_jobs": compute.n_jobs, "cache": compute.cache}
    return load_features(ds.builtin, features_file=exp.resolve(ds.features), plain=exp.resolve(ds.plain),
                         data_dir=exp.resolve(ds.data_dir), path=exp.resolve(ds.path), min_objects=ds.min_objects,
                         **plain_options)


def _default_split_file(exp: Experiment, features) -> Path:
    """``[splits] kinds = ["file"]`` without ``file``: the ``splits.csv`` of the plain folder, or of a catalog
    dataset's converted folder (one that ships its publication's split, e.g. ``physiclear``)."""
    ds = exp.config.dataset
    folder = exp.resolve(ds.plain) if ds.plain is not None else features.info.get("plain_folder")
    if folder is None or not (Path(folder) / "splits.csv").is_file():
        raise ConfigError(f"{exp.source}: splits: kinds = ['file'] needs file = a split CSV ('tzsl splits'); "
                          f"{ds.builtin or ds.features} ships no split file")
    return Path(folder) / "splits.csv"


def _check_folds(exp: Experiment, n_train_objects: int) -> None:
    from tzsl.studies.zero_shot.study import check_cv_folds  # noqa: PLC0415

    check_cv_folds(exp.config.svm.cv, n_train_objects, exp.source)


@dataclass(frozen=True)
class PreparedStudy:
    """What a zero-shot run reads and draws before its first fit (:func:`prepare`).

    Attributes
    ----------
    exp : Experiment
        The experiment with the settings the dataset cannot honour relaxed.
    features : FeatureSet
        The dataset's features, read once.
    splits : dict
        Every split the run scores, drawn (or read) once, by kind: ``"random"`` or ``"file"`` ->
        ``(splits, None)``, ``"challenging"`` -> ``(splits, object map)``.
    split_file : Path or None
        The split file of ``kinds = ["file"]``.
    relaxations : list of Relaxation
        What was relaxed, in order (:mod:`tzsl.studies.zero_shot.relaxations`).
    """

    exp: Experiment
    features: FeatureSet
    splits: dict[str, tuple[list, pd.DataFrame | None]]
    split_file: Path | None
    relaxations: list

    @property
    def scored_splits(self) -> list | None:
        """The random splits, or the file's (GZSL and the method comparison's); None: challenging only."""
        found = self.splits.get("file") or self.splits.get("random")
        return None if found is None else found[0]


def prepare(exp: Experiment) -> PreparedStudy:
    """Read the dataset (and the split file) of a zero-shot experiment, relax what it cannot honour, draw
    the splits and check the CV folds fit.

    Everything a zero-shot run reads and draws before its first fit (``tzsl run --check`` calls it
    too), each once: a split that cannot be drawn is reported with the experiment file before any
    fit; settings the dataset cannot honour are relaxed first
    (:func:`tzsl.studies.zero_shot.relaxations.relax_to_dataset`, which draws the splits it checks).
    """
    from tzsl.evaluation import read_splits_csv  # noqa: PLC0415
    from tzsl.exceptions import SplitError  # noqa: PLC0415
    from tzsl.studies.zero_shot.relaxations import relax_to_dataset  # noqa: PLC0415
    from tzsl.studies.zero_shot.study import make_splits  # noqa: PLC0415

    features = load_study_features(exp)
    with stage("splits"):  # the relaxation draws (and checks) every split the run scores
        exp, relaxed, drawn = relax_to_dataset(exp, features)
    c = exp.config
    split_file = None
    if c.splits.kinds == ["file"]:
        split_file = exp.resolve(c.splits.file) if c.splits.file is not None else _default_split_file(exp, features)
        drawn["file"] = (read_splits_csv(split_file, features.attributes,
                                         min_train_positives=c.splits.random_min_train_positives), None)
        _check_folds(exp, min(len(s.train_objects) for s in drawn["file"][0]))
    else:
        _check_folds(exp, features.n_objects - (c.splits.n_test if "random" in c.splits.kinds else 0))
        for kind in c.splits.kinds:
            if kind not in drawn:
                try:
                    drawn[kind] = make_splits(features, kind, c)
                except SplitError as exc:
                    raise ConfigError(f"{exp.source}: splits: {exc}") from None
    return PreparedStudy(exp, features, drawn, split_file, relaxed)


def relaxation_notes(exp: Experiment) -> list[str]:
    """``relaxed ...`` lines for the settings the dataset cannot honour (reads the data; no fit)."""
    return [f"relaxed {relaxed.line()}" for relaxed in prepare(exp).relaxations]


def _deploy(exp: Experiment, features: FeatureSet, per_class: dict[str, pd.DataFrame], out: PrefixedResults) -> dict:
    """The study's deploy choice (:mod:`tzsl.studies.zero_shot.deployment`), written as ``deployment.json``; with
    ``[output] model = true`` also its bundle, trained on every object (what ``train-attributes --from-results``
    writes)."""
    from tzsl.studies.zero_shot.deployment import (  # noqa: PLC0415
        CLASS_ACCURACY_FILE,
        DEPLOYMENT_FILE,
        MODEL_FILE,
        study_deployment,
    )

    kind = "file" if "file" in per_class else "random"
    empty = pd.DataFrame(columns=["method", "split", "class", "accuracy"])
    scores = per_class.get(kind, empty)
    if kind in per_class:  # the per-class scores the choice reads (and the benchmark's primary metric)
        out.write_csv(CLASS_ACCURACY_FILE, scores.assign(split_kind=kind, purpose=exp.config.splits.purpose))
    deployment = study_deployment(exp, features, scores, kind)
    out.write_json(out.name(DEPLOYMENT_FILE), deployment)
    if exp.config.output.model:
        from tzsl.inference.model_bundles import train_attribute_bundle  # noqa: PLC0415

        chosen = {"branch": deployment["branch"], "reason": deployment["reason"], "study": exp.source}
        with stage("model"):
            out.write_file(out.name(MODEL_FILE), lambda path: train_attribute_bundle(
                features, exp.config, path, entry=deployment, force=True, deployment=chosen))
    return deployment


def run_zero_shot(exp: Experiment, results: ResultsDir, say: Callable[[str], None]) -> StudyRun:
    """``study = "zero-shot"`` and its paper preset ``"phac2-dap"``: one study, labelled by
    :func:`~tzsl.studies.papers.run_labels.study_labels` (the paper's numbers only on its data)."""
    from tzsl.studies.papers.run_labels import study_labels  # noqa: PLC0415
    from tzsl.studies.zero_shot.gzsl import GZSL_FILE, RELAXED_COLUMN, relaxation_notes, run_gzsl  # noqa: PLC0415
    from tzsl.studies.zero_shot.study import run_zero_shot_tables, solver_lines  # noqa: PLC0415
    from tzsl.studies.zero_shot.tables import table_titles  # noqa: PLC0415

    study = exp.study
    prepared = prepare(exp)
    exp, features, split_file, relaxed = prepared.exp, prepared.features, prepared.split_file, prepared.relaxations
    c = exp.config
    labels = study_labels(study, c, features)
    size = {"trials": features.n_trials, "objects": features.n_objects, "sensors": len(features.sensors),
            "features_per_sensor": features.X.shape[2], "attributes": features.attributes.shape[1]}
    say(f"{features.dataset}: {size['trials']} trials, {size['objects']} objects, {size['sensors']} sensor(s), "
        f"{size['features_per_sensor']} features per sensor, {size['attributes']} attributes")
    notes = [labels.note] if labels.note else []
    notes += [f"relaxed {r.line()}" for r in relaxed]
    for note in notes:
        say(f"note: {note}")
    kinds = tuple(c.splits.kinds)
    methods = c.methods
    options = {"methods": methods.method_specs()}
    solver_record: dict = {}
    out = PrefixedResults(results, c.output.prefix)
    per_class: dict[str, pd.DataFrame] = {}
    tables = run_zero_shot_tables(features, out, c, splits=prepared.splits, record=solver_record, labels=labels,
                                  per_class=per_class)
    for text in solver_lines(solver_record["attribute_solver"]):
        say(text)
    gzsl_notes = []
    if methods.gzsl:
        scored = prepared.scored_splits
        assert scored is not None  # the schema refuses gzsl without random or file splits
        tables["gzsl"] = run_gzsl(features, scored, c, echo=say)
        out.write_csv(GZSL_FILE, tables["gzsl"])
        if RELAXED_COLUMN in tables["gzsl"].columns:
            gzsl_notes = relaxation_notes(tables["gzsl"][RELAXED_COLUMN])
            for note in gzsl_notes:
                say(f"note: relaxed gzsl {note}")
    drop = getattr(results, "drop", {})
    shown = {name: t.drop(columns=drop.get(out.name(f"{name}.csv"), []), errors="ignore") for name, t in tables.items()}
    for name, title in table_titles(labels).items():
        if name in tables:
            say(f"\n{title}\n{format_table(shown[name])}")
    # what the fits used: the file's settings after any relaxation (manifest "settings" are the file's)
    used = c.model_dump(mode="json", include={"methods", "gzsl", "splits", "svm", "compute"})
    record = {"study_kind": study, "purpose": c.splits.purpose, "study_settings": used,
              "svm_params": c.svm.estimator_params(),
              "kinds": list(kinds),
              "splits_file": None if split_file is None else str(split_file),
              "method_options": options, "labels": {"study": labels.study, "data": labels.data,
                                                    "paper": labels.paper, "note": labels.note},
              "relaxations": [r.record() for r in relaxed] + [{"setting": "gzsl", "why": n} for n in gzsl_notes],
              "dataset": features.dataset, "dataset_size": {k: int(v) for k, v in size.items()}, **solver_record}
    if study == "zero-shot":
        record["deployment"] = _deploy(exp, features, per_class, out)
    data_files = list(features.info.get("data_files", [])) + ([] if split_file is None else [split_file])
    return StudyRun(shown, record, data_files)
