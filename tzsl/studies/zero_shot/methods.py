"""Registry methods vs DAP on the same splits of the zero-shot study (``methods_per_split.csv``,
``method_comparison.csv``; ``phac2_methods.csv`` and ``phac2_method_comparison.csv`` in the PHAC-2 paper preset).

Every method of ``[methods]`` (``eszsl``, ``embedding`` and ``compare``, see
:meth:`~tzsl.studies.config.ZeroShotMethods.method_specs`) is fitted on each random split's
training objects with :func:`tzsl.studies.comparison.method_runs.fit_predict` and scored on the
split's test trials. The reference is the paper's method, AVGDAP with a uniform prior, read
from the already fitted DAP posteriors (no refit), as are MAXDAP and, when the study fitted it,
the multi-label DAP; their temperatures are fitted on pseudo-unseen classes of each split's
training objects (:func:`tzsl.studies.comparison.calibration.dap_split_posteriors`). Scoring is the
one of every study (:func:`tzsl.studies.comparison.method_runs.method_summary`), with the study's
reliability diagram (``phac2_reliability.csv``; ``reliability.csv`` outside the paper preset).
"""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd
from joblib import Parallel, delayed

from tzsl._parallel import one_blas_thread, reissued, relayed
from tzsl._profile import stage
from tzsl.datasets import FeatureSet
from tzsl.evaluation import Split, summarise_over_splits
from tzsl.exceptions import TzslError
from tzsl.fit_store import count_fits, fit_store_counts
from tzsl.models import get_method
from tzsl.studies.comparison.calibration import dap_split_posteriors, posterior_columns, reliability_by_method
from tzsl.studies.comparison.method_runs import (
    comparison_file,
    comparison_trials,
    fit_predict,
    grid_edge_share,
    method_label,
    method_summary,
    split_masks,
)
from tzsl.studies.config import dap_label
from tzsl.studies.outputs.failures import ERROR_COLUMN, attempt
from tzsl.studies.papers.numbers import DAP_MULTILABEL_ACCURACY, DAP_TABLE1, DAP_TABLE3
from tzsl.studies.papers.run_labels import StudyLabels
from tzsl.studies.zero_shot.deployment import class_accuracy
from tzsl.studies.zero_shot.tables import split_label

if TYPE_CHECKING:
    from tzsl.studies.zero_shot.split_posteriors import SplitPosteriors

__all__ = ["COMPARISON_TABLE", "DEFAULT_METHODS", "REFERENCE_METHOD", "STUDY", "fit_predict_split", "method_comparison",
           "study_detector"]

#: Methods compared when none are given: ESZSL and the embedding model at lambda 0.1 and 1.
DEFAULT_METHODS: tuple[dict, ...] = ({"name": "eszsl"}, {"name": "embedding", "lam": 0.1},
                                     {"name": "embedding", "lam": 1.0})
#: Row label of the paper's method (AVGDAP, uniform prior, RBF-SVM detectors) in ``method_comparison.csv``.
REFERENCE_METHOD = "dap-avg"


def study_detector(results) -> str:
    """The ``detector`` of the attribute banks behind the study's fitted splits (``rbf-svm`` without one)."""
    return getattr(results[0].model, "detector", "rbf-svm") if results else "rbf-svm"
#: Study label of the rows; table key (file stem) of the comparison.
STUDY = "phac2"
COMPARISON_TABLE = comparison_file(STUDY)[: -len(".csv")]
#: The DAP paper's numbers (random splits, uni-prior): Table 1 averages and section 4.4.
PAPER = {"dap-max": DAP_TABLE1["average"][0], "dap-avg": DAP_TABLE1["average"][1],
         "multilabel-dap": DAP_MULTILABEL_ACCURACY}
#: The paper's numbers by split kind: Table 1 on random splits, Table 3's AVGDAP mean on challenging ones.
PAPER_BY_KIND = {"random": PAPER, "challenging": {"dap-avg": DAP_TABLE3["average"][2]}}
#: Notes of the rows read from the DAP posteriors: with the paper's numbers beside, and without.
PAPER_NOTES = {"dap-avg": "the paper's method (reference); paper: Table 1 average",
               "dap-max": "same fits as dap-avg; paper: Table 1 average",
               "multilabel-dap": "classifier chain (section 4.4); paper: section 4.4"}
CHALLENGING_NOTES = {"dap-avg": "the paper's method (reference); paper: Table 3 average",
                     "dap-max": "same fits as dap-avg", "multilabel-dap": "classifier chain"}
GENERIC_NOTES = {"dap-avg": "reference (AVGDAP, uniform prior)", "dap-max": "same fits as dap-avg",
                 "multilabel-dap": "classifier chain"}


def fit_predict_split(spec: dict, features: FeatureSet, split: Split, seed: int):
    """Fit the method entry ``spec`` on the split's training objects, seeded with ``seed`` where it is random.

    Returns
    -------
    fit : tzsl.studies.comparison.method_runs.MethodFit
    y : ndarray of shape (n_test_trials,)
        Row of ``split.test_objects`` of each test trial (the truth of ``fit.predicted``).
    """
    attributes = list(split.kept_attributes)
    train, test = split_masks(features, split)
    objects = features.objects
    class_rows = features.attributes.loc[np.unique(objects[train]), attributes].to_numpy(dtype=float)
    K = features.attributes.loc[list(split.test_objects), attributes].to_numpy(dtype=float)
    fit = fit_predict(spec, features.X[train], objects[train], class_rows, features.X[test], K, seed)
    y = pd.Index(split.test_objects).get_indexer(objects[test])
    return fit, y


def _dap_posteriors(features: FeatureSet, r: SplitPosteriors, seed: int) -> dict:
    """The split's DAP posteriors, calibrated on pseudo-unseen classes of its training objects."""
    train, _ = split_masks(features, r.split)
    A = features.attributes.loc[features.objects[train], list(r.attributes)].to_numpy(dtype=int)
    return dap_split_posteriors(r, features.X[train], A, features.objects[train], seed=seed)


def _fit_every_method(features: FeatureSet, results: list[SplitPosteriors], methods, seed: int,
                      n_jobs: int) -> dict[tuple[int, str], tuple]:
    """``{(split index, method label): (fit and true test rows or None, error text)}``.

    The (split, method) fits of tzsl's own methods run in ``n_jobs`` joblib workers, each seeded as in
    a serial run (identical results); a method registered at run time by the caller's code (a plug-in)
    exists only in this process, so its fits run here. The score ensembles run after every other
    method (:func:`_phases`): a member configured as a compared method (same estimator, parameters,
    seed and training rows) is that method's fit, read back from the fit store instead of fitted again.
    The workers' fit-store events (``hit``: a fit read back) are counted in this run's profile.
    """
    jobs = [(i, spec) for i in range(len(results)) for spec in methods]
    fits = {}
    # many small fits: one BLAS thread each (in this process; joblib's workers have one already), parallel
    # over fits; on 2 cores threaded BLAS spent many times the CPU of one thread on ESZSL's SVD
    with one_blas_thread():
        for phase in _phases([job for job in jobs if _is_builtin(job[1])]):
            with stage("fit"):  # the methods' fits (and their test scores), in joblib workers
                done = Parallel(n_jobs=n_jobs)(delayed(relayed(_counted_fit))(spec, features, results[i].split,
                                                                              seed + i) for i, spec in phase)
            for (i, spec), item in zip(phase, done, strict=True):
                fits[(i, method_label(spec))] = _recount(*reissued(item))
        for i, spec in jobs:
            if (i, method_label(spec)) not in fits:
                fits[(i, method_label(spec))] = attempt(fit_predict_split, spec, features, results[i].split, seed + i)
    return fits


def _counted_fit(spec: dict, features: FeatureSet, split: Split, seed: int) -> tuple[tuple, int, dict[str, int]]:
    """:func:`fit_predict_split` as a job: ``(attempt's (result, error), process id, its fit-store events)``."""
    before = fit_store_counts()
    done = attempt(fit_predict_split, spec, features, split, seed)
    return done, os.getpid(), fit_store_counts(since=before)


def _recount(done: tuple, pid: int, events: dict[str, int]) -> tuple:
    """``done``, after counting a worker's fit-store ``events`` here (a job run in this process counted them)."""
    for name, n in events.items() if pid != os.getpid() else ():
        count_fits(name, n)
    return done


def _phases(jobs: list[tuple[int, dict]]) -> list[list[tuple[int, dict]]]:
    """The (split, method) fits in dispatch order: every method but the score ensembles, then the ensembles,
    each phase longest first (:func:`_longest_first`); an empty phase is left out.

    An ensemble's members are registry methods; where a study compares a method configured as a member,
    the member's fit is that method's. Fitting the ensembles after every other method makes those fits
    exist (in the fit store) before an ensemble asks for them, instead of two workers fitting them at once.
    """
    ensembles = [job for job in jobs if _family(job[1]) == "ensemble"]
    others = [job for job in jobs if _family(job[1]) != "ensemble"]
    return [sorted(phase, key=_longest_first) for phase in (others, ensembles) if phase]


def _family(spec: dict) -> str:
    """The registry family of a method entry (empty for an unknown name: its error is recorded when it runs)."""
    try:
        return get_method(spec["name"]).family
    except TzslError:
        return ""


def _longest_first(job: tuple[int, dict]) -> tuple[int, int]:
    """Dispatch order of a (split, method) fit within its phase: the per-sensor attribute-bank methods (DAP and
    its detector variants) and score ensembles, then the feature methods, each in split order.

    Their fits differ in length by two orders of magnitude (a DAP bank searches every attribute classifier's
    hyper-parameters; ESZSL is one solve), so dispatching the long ones first keeps the last worker from
    running one alone at the end of the run. Results do not depend on the order: every fit is seeded by its
    split and read back by (split, method).
    """
    split, spec = job
    try:
        method = get_method(spec["name"])
    except TzslError:  # an unknown name: its error is recorded whenever it runs
        return 1, split
    return (0 if method.input_ndim == 3 else 1), split


def _is_builtin(spec: dict) -> bool:
    """Whether every class of the method comes with tzsl (importable in a fresh worker process)."""
    try:
        return all(c.__module__.startswith("tzsl.") for c in get_method(spec["name"]).components())
    except TzslError:  # an unknown name: fitted here, where its error is recorded
        return False


def method_comparison(features: FeatureSet, results: list[SplitPosteriors], seed: int = 0,
                      methods: tuple[dict, ...] | list[dict] = DEFAULT_METHODS,
                      labels: StudyLabels | None = None, purpose: str = "", split_kind: str = "random",
                      n_jobs: int = 1, per_class: dict[str, pd.DataFrame] | None = None) -> dict[str, pd.DataFrame]:
    """Registry methods and AVGDAP on the same PHAC-2 splits (trial accuracy).

    Each method entry ``{"name": ..., **parameters}`` is built from the registry; a method
    taking a seed gets ``seed + i`` on split ``i``. Objects sharing an attribute row are merged
    into one training class by the methods that merge duplicates (ESZSL, the embedding model).
    ``split_kind`` (``random``, ``challenging``) labels every row of the three tables.

    ``labels`` (:func:`~tzsl.studies.papers.run_labels.study_labels`; default: a generic run on
    real data) name the tables and say whether the paper's numbers and notes go beside;
    ``purpose`` (``"select"`` / ``"confirm"``, :data:`tzsl.evaluation.PURPOSES`) fills the
    ``purpose`` column of both tables; ``n_jobs``: the (split, method) fits run in that many
    joblib workers; ``per_class``, when a dict, receives under ``split_kind`` every method's accuracy per
    (split, test class) (:func:`tzsl.studies.zero_shot.deployment.class_accuracy`: the scores the deploy
    choice reads).

    Returns
    -------
    dict of DataFrame
        ``labels.methods_table`` (``"phac2_methods"`` for the paper preset): one row per split
        (purpose, the study's DAP (``dap-avg``, or ``dap-avg-<detector>``) and one column per
        method label, e.g. ``eszsl``, ``embedding_lam_0.1``; NaN where that fit failed, the reason
        in the ``error`` column), then mean and std rows;
        ``labels.comparison_table``: :func:`~tzsl.studies.comparison.method_runs.method_summary`
        with ``dap-avg`` as the reference (with ECE and Brier score, calibrated and not);
        ``labels.reliability_table``: the reliability diagram's points of every method; ``dap-max``
        and ``multilabel-dap`` (when fitted) come from the same posteriors, their fit time and grid-edge
        share are the DAP fit's.
    """
    rows, trials = [], []
    detector = study_detector(results)
    reference = dap_label("avg", detector)
    labels_of = {"dap-avg": reference, "dap-max": dap_label("max", detector),
                 "multilabel-dap": "multilabel-dap" if detector == "rbf-svm" else f"multilabel-dap-{detector}"}
    seconds: dict[str, list[float]] = {reference: []}
    edges: dict[str, list[float]] = {}
    fits = _fit_every_method(features, results, methods, seed, n_jobs)
    for i, r in enumerate(results):
        label = split_label(r.split)
        objects = np.asarray(r.split.test_objects)[r.y]
        row = {"split": label, "purpose": purpose, "chance": r.split.chance, reference: r.accuracy("avg", "uni")}
        from_posteriors = [("dap-avg", r.predict("avg", "uni")), ("dap-max", r.predict("max", "uni"))]
        if r.P_multilabel is not None:
            from_posteriors.append(("multilabel-dap", r.predict("avg", "uni", multilabel=True)))
        errors = []
        posteriors, error = attempt(_dap_posteriors, features, r, seed + i)
        if posteriors is None:  # the DAP rows keep their accuracy; their calibration is NaN
            posteriors = {}
            errors.append(f"DAP calibration: {error}")
        for name, predicted in from_posteriors:  # the calibration's keys are the rows' registry names
            P = posteriors.get(name, (None, None))
            trials.append(comparison_trials(labels_of[name], label, objects, predicted == r.y,
                                            **posterior_columns(P[0], P[1], r.y, predicted)))
            seconds.setdefault(labels_of[name], []).append(r.fit_seconds)
            edges.setdefault(labels_of[name], []).append(grid_edge_share(r.model))
        for spec in methods:
            name = method_label(spec)
            done, error = fits[(i, name)]
            if done is None:  # NaN for this (split, method), reported at the end of the run
                row[name] = np.nan
                errors.append(f"{name}: {error}")
                continue
            fit, y = done
            correct = fit.predicted == y
            row[name] = float(correct.mean())
            trials.append(comparison_trials(name, label, objects, correct,
                                            **posterior_columns(fit.proba, fit.proba_uncalibrated, y, fit.predicted)))
            seconds.setdefault(name, []).append(fit.fit_seconds)
            edges.setdefault(name, []).append(grid_edge_share(fit.model))
        rows.append({**row, ERROR_COLUMN: "; ".join(errors)})
    per_split = summarise_over_splits(pd.DataFrame(rows)).reset_index()
    per_split["purpose"] = purpose  # the mean and std rows are over the same splits
    per_split.insert(1, "split_kind", split_kind)
    chance = float(np.mean([r.split.chance for r in results]))
    labels = labels or StudyLabels()
    paper = PAPER_BY_KIND.get(split_kind) if labels.paper and detector == "rbf-svm" else None
    notes = (CHALLENGING_NOTES if split_kind == "challenging" else PAPER_NOTES) if paper else GENERIC_NOTES
    notes = {labels_of[name]: note.replace("dap-avg", reference) for name, note in notes.items()}
    if detector != "rbf-svm":
        notes[reference] = f"{notes[reference]}; attribute detector {detector} ([svm] detector)"
    trials = pd.concat(trials, ignore_index=True)
    if per_class is not None:
        per_class[split_kind] = class_accuracy(trials)
    summary = method_summary(trials, seconds, chance, reference,
                             study=labels.study, data=labels.data, paper=paper,
                             notes=notes, grid_edge=edges, purpose=purpose, split_kind=split_kind)
    if not labels.paper:  # paper_* headers only beside the paper's dataset and protocol
        summary = summary.drop(columns="paper_accuracy")
    reliability = reliability_by_method(trials, labels.study)
    reliability.insert(1, "split_kind", split_kind)
    return {labels.methods_table: per_split, labels.comparison_table: summary, labels.reliability_table: reliability}
