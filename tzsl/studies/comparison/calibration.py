"""Calibration inside a study: posterior columns of the comparison trials, ECE/Brier columns, reliability.

Every study scores its methods through :func:`tzsl.studies.comparison.method_runs.method_summary`; this
module adds what calibration needs to that path, and nothing else:

* :func:`method_posteriors`: the calibrated and the method's own (uncalibrated) class posteriors of
  a fitted method on the test trials (a method built by the registry is inside a
  :class:`~tzsl.models.CalibratedZeroShotClassifier`, fitted on pseudo-unseen training classes);
* :func:`posterior_columns`: the per-trial confidence and Brier terms of both, as extra columns of
  :func:`~tzsl.studies.comparison.method_runs.comparison_trials`;
* :func:`add_calibration`: the ``ece`` / ``brier`` columns (and ``*_uncalibrated``), each with its
  two-level bootstrap interval (:func:`tzsl.evaluation.add_calibration_columns`), called once by
  ``method_summary``;
* :func:`reliability_by_method` and :func:`reliability_figure`: the reliability diagram of a study
  (``<study>_reliability.csv`` / ``.png``), one panel per method; :func:`calibration_skipped`: the
  methods whose calibration was skipped (the figure and the report say so).
* :func:`dap_split_posteriors`: the PHAC-2 study's DAP rows come from posteriors it has already
  fitted; their temperature is fitted here the same way (pseudo-unseen classes of the split's
  training objects, :func:`tzsl.models.calibration.pseudo_unseen_scores`), never on test objects.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence

import numpy as np
import pandas as pd
from sklearn.base import clone

from tzsl.evaluation import DEFAULT_N_BINS, add_calibration_columns, calibration_columns, calibration_terms
from tzsl.evaluation import reliability_table as _bins
from tzsl.models import (
    CalibratedZeroShotClassifier,
    CalibrationWarning,
    DAPRule,
    MultiLabelAttributeClassifier,
    ZeroShotClassifier,
    ZSLInputError,
)
from tzsl.models.calibration import fit_temperature, pseudo_unseen_scores, selected_params, tempered_proba
from tzsl.value_lists import FUSIONS

__all__ = [
    "CALIBRATION_COLUMNS",
    "add_calibration",
    "calibration_skipped",
    "dap_split_posteriors",
    "method_posteriors",
    "posterior_columns",
    "reliability_by_method",
    "reliability_figure",
    "write_reliability_figure",
]

#: Columns added to every method comparison (calibrated posterior first, then the method's own).
CALIBRATION_COLUMNS = calibration_columns("") + calibration_columns("_uncalibrated")

#: The calibrator's defaults (folds, subsample bound), read from its signature: written once there.
_CALIBRATOR = CalibratedZeroShotClassifier()


def method_posteriors(model, X_test, test_rows) -> tuple[np.ndarray | None, np.ndarray | None]:
    """Calibrated and uncalibrated class posteriors of a fitted method among ``test_rows``.

    Returns
    -------
    proba, proba_uncalibrated : ndarray of shape (n_test, n_test_classes) or None
        None when the method has no ``predict_proba`` over a class table. A method without a
        calibrator gives its own posterior for both.
    """
    if not callable(getattr(model, "predict_proba", None)):
        return None, None
    P = np.asarray(model.predict_proba(X_test, test_rows), dtype=float)
    raw = getattr(model, "predict_proba_uncalibrated", None)
    return P, (np.asarray(raw(X_test, test_rows), dtype=float) if callable(raw) else P)


def posterior_columns(proba, proba_uncalibrated, y_true, predicted) -> dict[str, np.ndarray]:
    """Per-trial ``confidence``, ``brier`` (and ``*_uncalibrated``) of a method's posteriors.

    Parameters
    ----------
    proba, proba_uncalibrated : ndarray of shape (n_trials, n_classes) or None
    y_true : int ndarray of shape (n_trials,)
        Column of each trial's true class.
    predicted : int ndarray of shape (n_trials,)
        The method's prediction (the same for both: a temperature keeps the ranking).

    Returns
    -------
    dict of ndarray of shape (n_trials,)
        Empty when ``proba`` is None (the comparison shows NaN).
    """
    if proba is None:
        return {}
    out = {}
    for suffix, P in (("", proba), ("_uncalibrated", proba_uncalibrated)):
        terms = calibration_terms(P, np.asarray(y_true), predicted=np.asarray(predicted))
        out[f"confidence{suffix}"], out[f"brier{suffix}"] = terms.confidence, terms.brier
    return out


def add_calibration(summary: pd.DataFrame, trials: pd.DataFrame) -> pd.DataFrame:
    """``summary`` with :data:`CALIBRATION_COLUMNS` from the trials' posterior columns (NaN without them)."""
    out = add_calibration_columns(summary, trials, by="method")
    for column in CALIBRATION_COLUMNS:
        if column not in out.columns:
            out[column] = np.nan
    return out


def reliability_by_method(trials: pd.DataFrame, study: str, n_bins: int = DEFAULT_N_BINS) -> pd.DataFrame:
    """The reliability diagram's points of every method (calibrated and uncalibrated), pooled over splits.

    Returns
    -------
    DataFrame
        ``study``, ``method``, ``posterior`` ("calibrated" / "uncalibrated"), then the columns of
        :func:`tzsl.evaluation.reliability_table` (equal-mass bins of the test trials).
    """
    parts = []
    for method, t in trials.groupby("method", sort=False):
        for suffix, label in (("", "calibrated"), ("_uncalibrated", "uncalibrated")):
            column = f"confidence{suffix}"
            if column not in t.columns or t[column].isna().all():
                continue
            ok = t[column].notna()
            table = _bins(t.loc[ok, column], t.loc[ok, "correct"], n_bins=n_bins)
            parts.append(table.assign(study=study, method=method, posterior=label))
    columns = ["study", "method", "posterior", "bin", "confidence", "accuracy", "n_trials", "confidence_low",
               "confidence_high"]
    return pd.concat(parts, ignore_index=True)[columns] if parts else pd.DataFrame(columns=columns)


def calibration_skipped(table: pd.DataFrame) -> list[str]:
    """Methods whose calibrated reliability points equal their uncalibrated ones: calibration was skipped.

    ``table``: :func:`reliability_by_method` (a ``split_kind`` column allowed). A method calibrated on
    pseudo-unseen training classes moves its posterior; one left uncalibrated (too few training
    classes: a :class:`~tzsl.models.CalibrationWarning`) writes its own posterior twice.
    """
    keys = [c for c in ("split_kind", "bin") if c in table.columns]
    out = []
    for method, t in table.groupby("method", sort=False):
        calibrated, own = (t[t["posterior"] == kind].sort_values(keys)[["confidence", "accuracy"]].to_numpy(float)
                           for kind in ("calibrated", "uncalibrated"))
        if len(calibrated) and calibrated.shape == own.shape and np.allclose(calibrated, own, equal_nan=True):
            out.append(str(method))
    return out


def reliability_figure(table: pd.DataFrame, comparison: pd.DataFrame | None = None):
    """Reliability diagram as small multiples: one panel per method, its calibrated and uncalibrated curves.

    ``table``: :func:`reliability_by_method`; ``comparison`` (optional): the method comparison, whose
    ``ece`` / ``ece_uncalibrated`` values label the curves. Points on the diagonal are calibrated;
    below it, over-confident. A panel whose method was not calibrated (:func:`calibration_skipped`)
    draws one curve and says so.
    """
    import matplotlib  # noqa: PLC0415 (only studies that draw need it)

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # noqa: PLC0415

    methods = list(dict.fromkeys(table["method"])) or [""]
    n_cols = min(4, len(methods))
    n_rows = -(-len(methods) // n_cols)
    fig, axes = plt.subplots(n_rows, n_cols, figsize=(3.3 * n_cols, 3.1 * n_rows + 0.6), squeeze=False)
    ece: dict[tuple[str, str], float] = {}
    if comparison is not None:
        for kind, column in (("calibrated", "ece"), ("uncalibrated", "ece_uncalibrated")):
            if column in comparison.columns:
                ece.update({(kind, m): float(v)
                            for m, v in zip(comparison["method"], comparison[column], strict=True)})
    skipped = set(calibration_skipped(table))
    styles = {"uncalibrated": {"color": "0.45", "ls": "--", "marker": "s"},
              "calibrated": {"color": "C0", "marker": "o"}}
    for ax, method in zip(axes.flat, methods, strict=False):  # the grid may hold more panels than methods
        ax.plot([0, 1], [0, 1], color="grey", ls=":", lw=1)
        for kind, style in styles.items():
            points = table[(table["method"] == method) & (table["posterior"] == kind)]
            if points.empty or (kind == "calibrated" and method in skipped):
                continue
            value = ece.get((kind, method), np.nan)
            label = kind if np.isnan(value) else f"{kind} (ECE {value:.3f})"
            ax.plot(points["confidence"], points["accuracy"], ms=3, lw=1, label=label, **style)
        if method in skipped:
            ax.text(0.97, 0.03, "calibration skipped:\ncalibrated = uncalibrated", transform=ax.transAxes,
                    ha="right", va="bottom", fontsize=7, color="#b00020")
        ax.set_xlim(0, 1)
        ax.set_ylim(0, 1)
        ax.set_title(method, fontsize=9)
        if ax.get_lines()[1:]:
            ax.legend(fontsize=6, loc="upper left")
    for ax in axes.flat[len(methods):]:
        ax.set_visible(False)
    fig.supxlabel("mean top-class probability (equal-mass bins)", fontsize=9)
    fig.supylabel("share of trials whose top class is right", fontsize=9)
    study = table["study"].iloc[0] if len(table) else ""
    fig.suptitle(f"{study}: reliability on test objects, one panel per method", fontsize=10)
    fig.tight_layout()
    return fig


def _dap_rules(fusions) -> dict[str, DAPRule]:
    return {f"dap-{f}": DAPRule(fusion=f, prior="uni") for f in fusions}


def dap_split_posteriors(r, X_train, A_train, groups_train, *, fusions: Sequence[str] | None = None, seed: int = 0,
                         refit: str = _CALIBRATOR.calibration_refit) -> dict[str, tuple[np.ndarray, np.ndarray, float]]:
    """Calibrated DAP posteriors of one PHAC-2 split from its already fitted test posteriors.

    The temperature of each DAP variant (uniform prior) is fitted on pseudo-unseen classes of the
    split's training objects: the study's attribute model (``r.model``, cloned with its settings,
    cache, chosen solver and, with the calibrator's default ``calibration_refit="pinned"``, each
    attribute classifier's chosen hyper-parameters) is refitted on the training objects minus a held-out
    group of classes, and the held-out trials are scored among the held-out classes
    (:func:`tzsl.models.calibration.pseudo_unseen_scores`), on at most the calibrator's default
    ``calibration_max_trials`` training trials (a seeded subsample of a larger split, every object
    keeping its share).
    The multi-label model (when the split has its posteriors) is refitted the same way.

    Parameters
    ----------
    r : tzsl.studies.zero_shot.study.SplitPosteriors
    X_train : ndarray of shape (n_train, n_sensors, n_features)
    A_train : ndarray of shape (n_train, n_attributes)
        Attribute rows of the training trials (the split's kept attributes).
    groups_train : ndarray of shape (n_train,)
        Object of each training trial.
    fusions : sequence of {"avg", "max"}, optional
        Default: every fusion (:data:`tzsl.value_lists.FUSIONS`), AVGDAP (the reference) first.
    seed : int
        Seeds which training class goes to which fold.
    refit : {"pinned", "search"}, default: the calibrator's ``calibration_refit``
        Whether the folds keep each attribute classifier's chosen hyper-parameters
        (:data:`tzsl.models.calibration.CALIBRATION_REFITS`).

    Returns
    -------
    dict
        ``{"dap-avg": (proba, proba_uncalibrated, temperature), "dap-max": ..., "multilabel-dap": ...}``,
        posteriors of shape (n_test_trials, n_test_objects).
    """
    rules = _dap_rules(fusions if fusions is not None else sorted(FUSIONS, key=lambda f: f != "avg"))
    chosen = selected_params(r.model, refit)  # the split's solver (and hyper-parameters)
    models = {"": clone(r.model).set_params(**chosen)}
    if r.P_multilabel is not None:
        names = set(MultiLabelAttributeClassifier().get_params(deep=False))
        models["multilabel-"] = MultiLabelAttributeClassifier(
            **{k: v for k, v in r.model.get_params(deep=False).items() if k in names})
    out = {}
    for prefix, model in models.items():
        used = rules if not prefix else {"dap-avg": rules["dap-avg"]}
        clf = ZeroShotClassifier(attribute_model=model, decision_rule=next(iter(used.values())))

        def score(fitted, Xv, K, used=used):
            S = fitted.attribute_scores(Xv)
            return {name: fitted.decision_function_from_scores(S, K, decision_rule=rule) for name, rule in used.items()}

        try:
            folds = pseudo_unseen_scores(clf, X_train, A_train, groups_train,
                                         n_folds=_CALIBRATOR.calibration_folds, random_state=seed, score=score,
                                         max_trials=_CALIBRATOR.calibration_max_trials)
        except ZSLInputError as exc:  # as the calibrator does: say so, keep T = 1 (the method's own posterior)
            warnings.warn(f"{prefix}DAP of split {r.split.name}: not calibrated: {exc}; its posterior is the "
                          "method's own", CalibrationWarning, stacklevel=2)
            folds = None
        for name, rule in used.items():
            t = 1.0 if folds is None else fit_temperature([s[name] for s, _, _ in folds], [y for _, y, _ in folds])
            test_scores = r.scores(rule.fusion, "uni", multilabel=bool(prefix))
            label = "multilabel-dap" if prefix else name
            out[label] = (tempered_proba(test_scores, t), tempered_proba(test_scores, 1.0), t)
    return out


def write_reliability_figure(out, tables: dict[str, pd.DataFrame], stem: str, comparison: str) -> None:
    """Write ``<stem>.png`` from the study's tables: the reliability points ``tables[stem]`` with the
    ECE labels of ``tables[comparison]`` (the method comparison), if there are points. Tables with a
    ``split_kind`` column (random and challenging splits) are drawn for their first split kind.

    ``out``: the study's :class:`~tzsl.studies.outputs.results_folder.ResultsDir`.
    """
    table, summary = tables.get(stem), tables.get(comparison)
    if table is None or table.empty:
        return
    if "split_kind" in table.columns:
        first = table["split_kind"].iloc[0]
        table = table[table["split_kind"] == first]
        summary = None if summary is None else summary[summary["split_kind"] == first]
    out.write_figure(f"{stem}.png", reliability_figure(table, summary))
