"""The zero-shot study's runner: ``study = "zero-shot"`` and its PHAC-2 paper preset ``"phac2-dap"``.

Registered in :mod:`tzsl.studies.config` (:func:`~tzsl.studies.config.register_study`):
:func:`run_zero_shot` runs a checked experiment, :func:`zero_shot_results` opens its results folder,
:func:`zero_shot_outputs` lists the files it writes and :func:`relaxation_notes` says, before any
fit, which settings the dataset cannot honour (``tzsl run --check``).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path

import pandas as pd

from tzsl.studies._outputs import PrefixedResults, ResultsDir, prefixed
from tzsl.studies.config import Experiment
from tzsl.studies.study_settings import StudyRun, format_table

__all__ = ["SelectedColumns", "dropped_columns", "phac2_features", "prepare_phac2", "relaxation_notes",
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
    for fusion in sorted({"max", "avg"} - set(methods.fusions)):
        for column in [f"{fusion}dap"] + (["avgdap_per_class_mean"] if fusion == "avg" else []):
            drop["table1_fusion.csv"] += [column, f"{column}_ci95_low", f"{column}_ci95_high"]
        drop["table1_fusion.csv"].append(f"paper_{fusion}dap")
    for prior in sorted({"uni", "test", "train"} - set(methods.priors)):
        drop["table2_priors.csv"] += [prior, f"{prior}_ci95_low", f"{prior}_ci95_high", f"paper_{prior}"]
    return {prefixed(prefix, name): columns for name, columns in drop.items()}


def zero_shot_outputs(config) -> list[str]:
    """Files a zero-shot (or phac2-dap) run writes (checked free before any computation)."""
    from tzsl.studies.study_labels import StudyLabels, paper_protocol  # noqa: PLC0415
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
            names += [f"{labels.methods_table}.csv", f"{labels.comparison_table}.csv", f"{labels.reliability_table}.csv",
                      f"{labels.reliability_table}.png"]
        if methods.gzsl:
            names.append("gzsl.csv")
    if "challenging" in kinds:
        names += ["table3_challenging.csv", "object_map.csv", "object_map.png"]
        if methods.method_specs() and "challenging" in methods.compare_on:
            names += [f"{labels.methods_table}.csv", f"{labels.comparison_table}.csv",
                      f"{labels.reliability_table}.csv", f"{labels.reliability_table}.png"]
    return ["manifest.json", *dict.fromkeys(prefixed(config.output.prefix, n) for n in names)]


def zero_shot_results(exp: Experiment, force: bool) -> ResultsDir:
    """The staged results folder of a zero-shot run, leaving unselected fusion / prior columns out."""
    output = exp.config.output
    results = SelectedColumns(Path(output.folder), force, dropped_columns(exp.config.methods, output.prefix),
                              staging=True)
    results.check_free(zero_shot_outputs(exp.config))
    return results


def phac2_features(exp: Experiment):
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


def _check_folds(exp: Experiment, n_train_objects: int) -> None:
    from tzsl.studies.zero_shot.study import check_cv_folds  # noqa: PLC0415

    check_cv_folds(exp.config.svm.cv, n_train_objects, exp.source)


def prepare_phac2(exp: Experiment):
    """Load the dataset and the split file of a phac2-dap experiment and check the CV folds fit.

    Everything a phac2-dap run reads and draws before its first fit (``tzsl run --check`` calls
    it too): the random splits are drawn here, so a split that cannot be drawn is reported with
    the experiment file before any fit. Settings the dataset cannot honour are relaxed first
    (:func:`tzsl.studies.zero_shot.relaxations.relax_to_dataset`). Returns ``(exp, features, splits or
    None, split_file or None, relaxations)``: the relaxed experiment, the file's splits (``kinds =
    ["file"]``), the random splits, or None (challenging only).
    """
    from tzsl.evaluation import read_splits_csv  # noqa: PLC0415
    from tzsl.exceptions import ConfigError, SplitError  # noqa: PLC0415
    from tzsl.studies.zero_shot.study import make_splits  # noqa: PLC0415

    from tzsl.studies.zero_shot.relaxations import relax_to_dataset  # noqa: PLC0415

    features = phac2_features(exp)
    exp, relaxed = relax_to_dataset(exp, features)
    c = exp.config
    user_splits, split_file = None, None
    if c.splits.kinds == ["file"]:
        split_file = exp.resolve(c.splits.file) if c.splits.file is not None else (
            exp.resolve(c.dataset.plain) / "splits.csv")
        user_splits = read_splits_csv(split_file, features.attributes,
                                      min_train_positives=c.splits.random_min_train_positives)
        _check_folds(exp, min(len(s.train_objects) for s in user_splits))
    else:
        _check_folds(exp, features.n_objects - (c.splits.n_test if "random" in c.splits.kinds else 0))
        if "random" in c.splits.kinds:
            try:
                user_splits, _ = make_splits(features, "random", c)
            except SplitError as exc:
                raise ConfigError(f"{exp.source}: splits: {exc}") from None
    return exp, features, user_splits, split_file, relaxed


def relaxation_notes(exp: Experiment) -> list[str]:
    """``relaxed ...`` lines for the settings the dataset cannot honour (reads the data; no fit)."""
    return [f"relaxed {relaxed.line()}" for relaxed in prepare_phac2(exp)[-1]]


def run_zero_shot(exp: Experiment, results: ResultsDir, say: Callable[[str], None]) -> StudyRun:
    """``study = "zero-shot"`` and its paper preset ``"phac2-dap"``: one study, labelled by
    :func:`~tzsl.studies.study_labels.study_labels` (the paper's numbers only on its data)."""
    from tzsl.studies.zero_shot.gzsl import GZSL_FILE, RELAXED_COLUMN, relaxation_notes, run_gzsl  # noqa: PLC0415
    from tzsl.studies.zero_shot.study import make_splits, run_dap_study, solver_lines  # noqa: PLC0415
    from tzsl.studies.zero_shot.tables import table_titles  # noqa: PLC0415
    from tzsl.studies.study_labels import study_labels  # noqa: PLC0415

    study = exp.study
    exp, features, user_splits, split_file, relaxed = prepare_phac2(exp)
    c = exp.config
    labels = study_labels(study, c, features)
    say(f"{features.dataset}: {features.n_trials} trials, {features.n_objects} objects, "
        f"{len(features.sensors)} sensor(s), {features.X.shape[2]} features per sensor, "
        f"{features.attributes.shape[1]} attributes")
    notes = [labels.note] if labels.note else []
    notes += [f"relaxed {r.line()}" for r in relaxed]
    for note in notes:
        say(f"note: {note}")
    kinds = tuple(c.splits.kinds)
    methods = c.methods
    options = {"methods": methods.method_specs()}
    file_splits = user_splits if split_file is not None else None  # random ones are redrawn identically
    solver_record: dict = {}
    out = PrefixedResults(results, c.output.prefix)
    tables = run_dap_study(features, out, c, kinds=kinds, splits=file_splits, sweep=methods.sweep,
                           compare_methods=bool(options["methods"]), method_options=options,
                           record=solver_record, labels=labels)
    for text in solver_lines(solver_record["attribute_solver"]):
        say(text)
    gzsl_notes = []
    if methods.gzsl:
        splits = user_splits if user_splits is not None else make_splits(features, "random", c)[0]
        tables["gzsl"] = run_gzsl(features, splits, c, echo=say)
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
    record = {"study_kind": study, "purpose": c.splits.purpose, "dap_settings": used,
              "svm_params": c.svm.estimator_params(),
              "kinds": list(kinds),
              "splits_file": None if split_file is None else str(split_file),
              "method_options": options, "labels": {"study": labels.study, "data": labels.data,
                                                    "paper": labels.paper, "note": labels.note},
              "relaxations": [r.record() for r in relaxed] + [{"setting": "gzsl", "why": n} for n in gzsl_notes],
              "dataset": features.dataset, **solver_record}
    data_files = list(features.info.get("data_files", [])) + ([] if split_file is None else [split_file])
    return StudyRun(shown, record, data_files)
