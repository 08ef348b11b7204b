"""Generalised zero-shot (GZSL) evaluation beside the classic one, for DAP and any registered method.

Classic zero-shot evaluation (the DAP paper's) asks a test trial "which of the *unseen*
classes is it?". GZSL asks "which of *all* classes, seen or unseen?": a model that is biased
towards the classes it was trained on scores well on seen classes and poorly on unseen ones,
and the harmonic mean of the two exposes it.

Protocol, per object split (:class:`tzsl.evaluation.Split`):

* **Classes are unique attribute rows.** Over the split's kept attributes, every distinct
  attribute row of the split's objects (training + test) is one class. An attribute-based model
  scores a class from its attribute row alone, so two objects sharing a row always get the same
  score and "which of the two" is a coin toss decided by their order; merging them makes every
  prediction well defined (PHAC-2: 60 objects, 45 distinct rows over the 19 attributes). A class
  is **seen** when a training object has its row, **unseen** otherwise. A test object whose row
  equals a training object's row therefore belongs to a *seen* class (its trials count in the
  seen score; ``n_test_objects_in_seen_classes`` reports how many); random splits make the test
  objects' rows mutually different, not different from the training rows.
* **Seen-class test trials** are held out of the training objects: per training object,
  ``round(holdout_fraction * n_trials)`` trials (at least 1, at most all but one), drawn at
  random with a recorded seed (PHAC-2, 10 trials per object, default 0.3: 3 held out, 7 fitted).
  The models are fitted on the remaining trials of the training objects only; the held-out
  trials and every trial of the test objects are scored over all classes.
* **Scores** (``[gzsl] methods``): ``"dap"``, the study's attribute classifiers with the fusion and
  prior configured (default AVGDAP / uni-prior), and any registered method on feature vectors
  (``tzsl methods``; default ESZSL, :class:`tzsl.models.ESZSLCV`, the sensors side by side), fitted as the
  method comparison fits it, its class scores uncalibrated.
  ``seen``, ``unseen`` are per-class mean accuracies and ``harmonic`` their harmonic mean
  (:func:`tzsl.evaluation.gzsl_scores`); ``zsl`` is the classic per-class mean accuracy of the
  unseen trials among the unseen classes only, from the same fit.
* **Calibrated stacking** (Chao et al., ECCV 2016), optional: a constant ``gamma`` is
  subtracted from every seen class's score before the argmax. ``gamma`` is chosen on training
  data only: some of the seen classes (as many as the split has unseen classes, drawn so that
  every attribute keeps ``min_train_positives`` positive training objects and one negative)
  play "unseen"; the model is refitted on the other training objects' fitting trials and
  ``gamma`` maximises the harmonic mean on their held-out trials plus every trial of the
  pseudo-unseen objects. The test objects are never looked at. Rows with ``calibrated=True``
  report the result and ``stacking_constant`` the chosen value.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from tzsl._parallel import one_blas_thread
from tzsl.datasets import FeatureSet
from tzsl.evaluation import (
    Outcomes,
    Split,
    add_trust_columns,
    choose_stacking_constant,
    gzsl_scores,
    holdout_trials,
    per_class_mean_accuracy,
    stacked_predict,
    summarise_over_splits,
)
from tzsl.exceptions import ConfigError, SplitError
from tzsl.models import DAPRule, get_method
from tzsl.models.protocol import attribute_rows
from tzsl.studies.comparison.method_runs import method_input, study_estimator
from tzsl.studies.config import GzslSettings, ZeroShotSettings, dap_label
from tzsl.studies.outputs.failures import ERROR_COLUMN, attempt
from tzsl.studies.zero_shot.study import attribute_bank, compute_context
from tzsl.studies.zero_shot.tables import split_label

#: Column of gzsl.csv saying what a split relaxed to calibrate stacking (present only when one did).
RELAXED_COLUMN = "relaxed"

__all__ = [
    "GZSL_FILE",
    "GzslProblem",
    "choose_stacking_constant",
    "gzsl_problem",
    "gzsl_split",
    "gzsl_table",
    "holdout_trials",
    "relaxation_notes",
    "run_gzsl",
    "stacked_predict",
]

#: Output table of :func:`run_gzsl` in a results folder.
GZSL_FILE = "gzsl.csv"



@dataclass
class GzslProblem:
    """One split's GZSL set-up: classes, which are seen, which trials fit and which are scored.

    Attributes
    ----------
    split : Split
    attributes : tuple of str, length m
    class_rows : ndarray of shape (n_classes, m), int 0/1
        The distinct attribute rows of the split's objects (one class each).
    seen : ndarray of shape (n_classes,), bool
        Classes with a training object.
    trial_class : ndarray of shape (n_trials,), int
        Class of every trial of ``features`` (-1 for objects outside the split).
    fit : ndarray of shape (n_trials,), bool
        Training-object trials the models are fitted on.
    heldout : ndarray of shape (n_trials,), bool
        Training-object trials held out (seen-class test trials).
    test : ndarray of shape (n_trials,), bool
        Trials of the split's test objects.
    """

    split: Split
    attributes: tuple[str, ...]
    class_rows: np.ndarray
    seen: np.ndarray
    trial_class: np.ndarray
    fit: np.ndarray
    heldout: np.ndarray
    test: np.ndarray
    info: dict = field(default_factory=dict)

    @property
    def evaluate(self) -> np.ndarray:
        """Trials scored over all classes: held-out training trials and test trials."""
        return self.heldout | self.test


# --------------------------------------------------------------------------- set-up


def has_unseen_class(features: FeatureSet, split: Split) -> bool:
    """Whether some test object's attribute row (kept attributes) is no training object's row.

    With merged attribute rows a split may have none: GZSL then has nothing to evaluate on it.
    """
    A = features.attributes[list(split.kept_attributes)]
    if not set(split.train_objects) | set(split.test_objects) <= set(A.index):
        return True  # unknown objects: gzsl_problem reports them
    train = {tuple(r) for r in A.loc[list(split.train_objects)].to_numpy(dtype=int)}
    return any(tuple(r) not in train for r in A.loc[list(split.test_objects)].to_numpy(dtype=int))


def single_trial_objects(objects: np.ndarray, train_objects) -> list[str]:
    """Training objects with a single trial (GZSL holds none of their trials out), sorted."""
    names, counts = np.unique(np.asarray(objects)[np.isin(objects, list(train_objects))], return_counts=True)
    return sorted(names[counts < 2].tolist())


def has_holdout_trials(features: FeatureSet, split: Split) -> bool:
    """Whether some training object of ``split`` has two trials, so one can be held out as seen-class test."""
    kept_whole = set(single_trial_objects(features.objects, split.train_objects))
    return any(o not in kept_whole for o in split.train_objects if o in set(features.objects))


def gzsl_problem(features: FeatureSet, split: Split, fraction: float, rng: np.random.Generator) -> GzslProblem:
    """Classes (unique attribute rows), seen mask and trial masks of one split."""
    attributes = split.kept_attributes
    objects = features.objects
    split_objects = list(split.train_objects) + list(split.test_objects)
    unknown = set(split_objects) - set(objects)
    if unknown:
        raise SplitError(f"split {split.name}: objects without trials: {sorted(unknown)}")
    A = features.attributes.loc[split_objects, list(attributes)].to_numpy(dtype=int)
    rows, inverse = np.unique(A, axis=0, return_inverse=True)
    inverse = inverse.ravel()
    object_class = pd.Series(inverse, index=split_objects)
    n_train = len(split.train_objects)
    seen = np.zeros(len(rows), dtype=bool)
    seen[inverse[:n_train]] = True
    if seen.all():
        raise SplitError(f"split {split.name}: every test object shares its attribute row with a training "
                         "object, so there is no unseen class for GZSL")
    trial_class = object_class.reindex(objects).fillna(-1).to_numpy(dtype=int)
    train = np.isin(objects, split.train_objects)
    heldout = holdout_trials(objects, split.train_objects, fraction, rng)
    if not heldout.any():
        raise SplitError(f"split {split.name}: no training object has 2 trials, so no seen-class trial can be held "
                         "out for GZSL")
    test = np.isin(objects, split.test_objects)
    in_seen = [o for o in split.test_objects if seen[object_class[o]]]
    info = {"n_test_objects_in_seen_classes": len(in_seen)}
    return GzslProblem(split=split, attributes=tuple(attributes), class_rows=rows, seen=seen,
                       trial_class=trial_class, fit=train & ~heldout, heldout=heldout, test=test, info=info)


def _pseudo_draw(A: np.ndarray, inverse: np.ndarray, n_rows: int, n_unseen: int, min_train_positives: int,
                 min_train_negatives: int, max_draws: int, rng: np.random.Generator) -> np.ndarray | None:
    """Training objects kept as pseudo-seen (mask), or None when no draw of ``n_unseen`` rows works."""
    if n_rows - n_unseen < 2:
        return None
    for _ in range(max_draws):
        pseudo = rng.choice(n_rows, size=n_unseen, replace=False)
        keep = ~np.isin(inverse, pseudo)
        positives = A[keep].sum(axis=0)
        if (positives >= min_train_positives).all() and (keep.sum() - positives >= min_train_negatives).all():
            return keep
    return None


def _pseudo_problem(features: FeatureSet, problem: GzslProblem, min_train_positives: int, max_draws: int,
                    rng: np.random.Generator) -> tuple[GzslProblem | None, str]:
    """A GZSL problem inside the training objects: some seen classes play unseen (calibration).

    Asks for as many pseudo-unseen classes as the split has unseen ones, each attribute keeping
    ``min_train_positives`` positive (and one negative) training objects. Where no draw allows
    that, the number of pseudo-unseen classes goes down to 1, each draw keeping two negative
    training objects per attribute (:mod:`tzsl.studies.zero_shot.relaxations`, step 5). Returns the
    problem (None when even that fails: the split is scored uncalibrated only) and a note of what
    was relaxed ("" if nothing).
    """
    split = problem.split
    train_objects = np.array(split.train_objects)
    A = features.attributes.loc[list(train_objects), list(problem.attributes)].to_numpy(dtype=int)
    rows, inverse = np.unique(A, axis=0, return_inverse=True)
    inverse = inverse.ravel()
    asked = int((~problem.seen).sum())
    keep, note = None, ""
    for n_unseen in range(asked, 0, -1):
        # the asked draw as ever; fewer pseudo-unseen classes also keep 2 negatives (the SVMs' CV needs them)
        keep = _pseudo_draw(A, inverse, len(rows), n_unseen, min_train_positives, 1 if n_unseen == asked else 2,
                            max_draws, rng)
        if keep is not None:
            break
    else:
        return None, (f"split {split.name}: calibrated stacking skipped: no draw of pseudo-unseen training "
                      f"classes (from {asked} down to 1) leaves every attribute {min_train_positives} positive and "
                      "2 negative training objects; uncalibrated rows only")
    if n_unseen != asked:
        note = f"split {split.name}: calibrated stacking on {n_unseen} pseudo-unseen classes (asked {asked})"
    objects = features.objects
    pseudo_train = train_objects[keep]
    pseudo_test = train_objects[~keep]
    seen = np.zeros(len(rows), dtype=bool)
    seen[inverse[keep]] = True
    trial_class = pd.Series(inverse, index=train_objects).reindex(objects).fillna(-1).to_numpy(dtype=int)
    in_train = np.isin(objects, pseudo_train)
    sub = Split(name=f"{split.name}-calibration", train_objects=tuple(pseudo_train),
                test_objects=tuple(pseudo_test), attributes=problem.attributes, kind="calibration")
    return GzslProblem(split=sub, attributes=problem.attributes, class_rows=rows, seen=seen,
                       trial_class=trial_class, fit=in_train & problem.fit, heldout=in_train & problem.heldout,
                       test=np.isin(objects, pseudo_test), info={}), note


# --------------------------------------------------------------------------- scores


def _dap_scores(features: FeatureSet, problem: GzslProblem, config: ZeroShotSettings, gzsl: GzslSettings,
                seed: int) -> np.ndarray:
    """DAP log-scores (n_evaluated, n_classes) of the evaluated trials, bank fitted on ``problem.fit``."""
    attrs = list(problem.attributes)
    A = features.attributes.loc[features.objects, attrs].to_numpy(dtype=int)
    fit = problem.fit
    bank = attribute_bank(config, attrs, seed)
    bank.fit(features.X[fit], A[fit], features.objects[fit])
    rule = DAPRule(fusion=gzsl.fusion, prior=gzsl.prior).fit(A[fit], groups=features.objects[fit])
    return rule.decision_function(bank.predict_proba(features.X[problem.evaluate]), problem.class_rows)


def _method_scores(method: str, features: FeatureSet, problem: GzslProblem, seed: int) -> np.ndarray:
    """Class scores (n_evaluated, n_classes) of the registered method ``method``, uncalibrated, fitted on
    ``problem.fit`` as the method comparison fits it (:func:`~tzsl.studies.comparison.method_runs.study_estimator`)."""
    spec = {"name": method, **({"calibration": "none"} if get_method(method).calibratable else {})}
    fit = problem.fit
    objects = features.objects[fit]
    S = features.attributes.loc[np.unique(objects), list(problem.attributes)].to_numpy(dtype=float)
    model = study_estimator(spec, seed).fit(method_input(spec, features.X[fit]), attribute_rows(objects, S), objects)
    return model.decision_function(method_input(spec, features.X[problem.evaluate]), problem.class_rows.astype(float))


def _scores(method: str, features, problem, config, gzsl, seed) -> np.ndarray:
    if method == "dap":
        return _dap_scores(features, problem, config, gzsl, seed)
    return _method_scores(method, features, problem, seed)


# --------------------------------------------------------------------------- one split, all splits


def _method_name(method: str, config: ZeroShotSettings) -> str:
    """Row label: a registered method's name; the study's DAP as the comparison labels it (its fusion,
    detector and prior: ``dap-avg``, ``dap-avg-logistic-c1``, ``dap-max-train-prior``)."""
    gzsl = config.gzsl
    return dap_label(gzsl.fusion, config.svm.detector, prior=gzsl.prior) if method == "dap" else method


def gzsl_split(features: FeatureSet, split: Split, config: ZeroShotSettings, index: int) -> list[dict]:
    """GZSL rows of one split (settings: ``config.gzsl``): one per method (and per calibration when enabled).

    Seeds: the attribute classifiers use the same seed as split ``index`` of the classic study
    (:func:`tzsl.studies.zero_shot.study.fit_split`); the held-out trials and the pseudo-unseen
    draw use ``SeedSequence([config.study_seed, index, 1])`` and ``[..., 2]``.
    """
    gzsl = config.gzsl
    seed = int(np.random.SeedSequence([config.study_seed, index]).generate_state(1)[0])
    problem = gzsl_problem(features, split, gzsl.holdout_fraction,
                           np.random.default_rng(np.random.SeedSequence([config.study_seed, index, 1])))
    pseudo, relaxed = None, ""
    if gzsl.calibrated_stacking:
        pseudo, relaxed = _pseudo_problem(features, problem, config.splits.random_min_train_positives, gzsl.max_draws,
                                          np.random.default_rng(np.random.SeedSequence([config.study_seed, index, 2])))
    kept_whole = single_trial_objects(features.objects, split.train_objects)
    if kept_whole:  # the same words on every split: one note for the run (relaxation_notes)
        relaxed = "; ".join(filter(None, [relaxed, f"split {split.name}: training objects with a single trial are "
                                                   "kept whole for fitting (seen-class trials are held out of the "
                                                   "others only)"]))
    y = problem.trial_class[problem.evaluate]
    seen_classes = np.flatnonzero(problem.seen)
    unseen_classes = np.flatnonzero(~problem.seen)
    is_unseen = ~problem.seen[y]
    base = {
        "split": split_label(split), "n_classes": len(problem.seen), "n_seen_classes": len(seen_classes),
        "n_unseen_classes": len(unseen_classes), "n_fit_trials": int(problem.fit.sum()),
        "n_seen_trials": int((~is_unseen).sum()), "n_unseen_trials": int(is_unseen.sum()),
        "n_attributes": len(problem.attributes), **problem.info, RELAXED_COLUMN: relaxed,
    }
    rows = []
    for method in gzsl.methods:
        scores = _scores(method, features, problem, config, gzsl, seed)
        zsl_pred = unseen_classes[np.argmax(scores[is_unseen][:, unseen_classes], axis=1)]
        zsl = per_class_mean_accuracy(y[is_unseen], zsl_pred)
        gammas = [(False, 0.0)]
        if pseudo is not None:
            val_scores, error = attempt(_scores, method, features, pseudo, config, gzsl, seed)
            if val_scores is None:  # the uncalibrated row stands; the calibrated one is left out, said why
                base[RELAXED_COLUMN] = "; ".join(filter(None, [base[RELAXED_COLUMN], (
                    f"split {split.name}: calibrated stacking of {_method_name(method, config)} skipped: {error}")]))
            else:
                gammas.append((True, choose_stacking_constant(val_scores, pseudo.trial_class[pseudo.evaluate],
                                                              pseudo.seen)))
        for calibrated, gamma in gammas:
            pred = stacked_predict(scores, problem.seen, gamma)
            result = gzsl_scores(y, pred, seen_classes, unseen_classes)
            seen_trials = ~is_unseen
            rows.append({**base, "method": _method_name(method, config), "calibrated": calibrated,
                         "stacking_constant": gamma, **result, "zsl": zsl,
                         "_outcomes": [("seen", y[seen_trials], pred[seen_trials] == y[seen_trials]),
                                       ("unseen", y[is_unseen], pred[is_unseen] == y[is_unseen]),
                                       ("zsl", y[is_unseen], zsl_pred == y[is_unseen])]})
    return rows


def relaxation_notes(cells: pd.Series) -> list[str]:
    """The GZSL table's ``relaxed`` cells as notes, each reason once with the splits it applies to.

    A cell holds ``"; "``-joined parts, each ``"split NAME: reason"`` (a reason may hold ``"; "`` itself);
    ``"split random-3: x"`` and ``"split random-4: x"`` become ``"splits random-3, random-4: x"``.
    A part starts at ``"; split NAME: "`` only (a reason such as ``"...; split left out"`` stays whole).
    """
    by_reason: dict[str, list[str]] = {}
    for cell in cells.fillna("").astype(str):
        for part in filter(None, (p.strip() for p in re.split(r"; (?=split [^\s:;]+: )", cell))):
            if part == "-":
                continue
            name, sep, reason = part.partition(": ") if part.startswith("split ") else ("", "", part)
            splits = by_reason.setdefault(reason, [])
            if sep and name[len("split "):] not in splits:
                splits.append(name[len("split "):])
    notes = []
    for reason, splits in by_reason.items():
        where = f"split {splits[0]}: " if len(splits) == 1 else f"splits {', '.join(splits)}: " if splits else ""
        notes.append(f"{where}{reason}")
    return notes


def gzsl_table(rows: list[dict]) -> pd.DataFrame:
    """Per-split rows followed by ``mean`` and ``std`` rows (over splits) per method and calibration.

    ``seen``, ``unseen`` and ``zsl`` (per-class mean accuracies) get ``_ci95_low``/``_ci95_high``
    columns (:func:`tzsl.evaluation._trust.add_trust_columns`: within a split over its classes,
    on ``mean`` rows over splits and classes; the harmonic mean has none). Baselines: ``chance``
    = 1 / (seen + unseen classes), the chance of ``seen`` and ``unseen``; ``zsl_chance`` = 1 /
    unseen classes.
    """
    outcomes = Outcomes(split_column="split", by=("method", "calibrated"))
    for row in rows:
        for column, classes, correct in row.pop("_outcomes", []):
            outcomes.add(row["split"], column, classes, correct, metric="class_mean",
                         method=row["method"], calibrated=row["calibrated"])
    table = pd.DataFrame(rows)
    if RELAXED_COLUMN in table.columns and not table[RELAXED_COLUMN].fillna("").astype(bool).any():
        table = table.drop(columns=RELAXED_COLUMN)
    for column in ("n_classes", "n_unseen_classes", "seen", "unseen", "harmonic", "zsl", "stacking_constant"):
        if column not in table.columns:  # absent when every split failed or was left out (no unseen class)
            table[column] = np.nan
    table["chance"] = 1.0 / table["n_classes"]
    table["zsl_chance"] = 1.0 / table["n_unseen_classes"]
    front = ["split", "method", "calibrated", "seen", "unseen", "harmonic", "zsl", "chance", "zsl_chance",
             "stacking_constant"]
    table = table[front + [c for c in table.columns if c not in front]]
    table = summarise_over_splits(table, split_column="split", by=["method", "calibrated"])
    return add_trust_columns(table, outcomes, baselines=False)


def run_gzsl(features: FeatureSet, splits: Sequence[Split], config: ZeroShotSettings | None = None,
             echo: Callable[[str], None] | None = None) -> pd.DataFrame:
    """GZSL evaluation of every split (see the module docstring for the protocol).

    Parameters
    ----------
    features : FeatureSet
        Per-trial, per-sensor features (n_trials, n_sensors, d).
    splits : sequence of Split
        Object splits (e.g. the random splits of the zero-shot study); split ``i`` uses the seeds of
        the study's split ``i``.
    config : ZeroShotSettings or None
        Attribute-classifier settings (``[svm]``, ``[compute]``) and the GZSL protocol (``[gzsl]``);
        default: the schema's defaults.

    Returns
    -------
    DataFrame
        :func:`gzsl_table`: columns ``split, method, calibrated, seen, unseen, harmonic, zsl,
        stacking_constant`` and counts (classes, trials, attributes); ``error``: why a split
        failed (its rows NaN; the other splits still run), empty otherwise.
    """
    config = config or ZeroShotSettings.of_preset("phac2-dap")
    gzsl = config.gzsl
    if not splits:
        raise ConfigError("GZSL evaluation needs at least one split")
    rows: list[dict] = []
    with compute_context(config), one_blas_thread():  # small fits: one BLAS thread
        for i, split in enumerate(splits):
            why = ("" if has_unseen_class(features, split) else
                   "every test object shares its attribute row with a training object (no unseen class)")
            if not why and not has_holdout_trials(features, split):
                why = "no training object has 2 trials (no seen-class trial to hold out)"
            if why:  # nothing to evaluate: left out, said why (no failure)
                rows += [{"split": split_label(split), "method": _method_name(m, config), "calibrated": False,
                          RELAXED_COLUMN: f"split {split.name}: {why}; split left out",
                          ERROR_COLUMN: ""} for m in gzsl.methods]
                continue
            part, error = attempt(gzsl_split, features, split, config, i)
            if part is None:  # NaN rows for this split, reported at the end of the run
                rows += [{"split": split_label(split), "method": _method_name(m, config), "calibrated": False,
                          "seen": np.nan, "unseen": np.nan, "harmonic": np.nan, "zsl": np.nan,
                          "stacking_constant": np.nan, ERROR_COLUMN: error} for m in gzsl.methods]
                if echo is not None:
                    echo(f"GZSL {split.name}: failed: {error}")
                continue
            part = [{**r, ERROR_COLUMN: ""} for r in part]
            rows += part
            if echo is not None:
                text = ", ".join(f"{r['method']}{'+cs' if r['calibrated'] else ''} H={r['harmonic']:.3f}"
                                 for r in part)
                echo(f"GZSL {split.name}: {text}")
    return gzsl_table(rows)
