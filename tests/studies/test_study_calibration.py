"""Calibration in a study: posterior columns, ECE/Brier columns, reliability table, figure and report section.

Simulated posteriors (labels drawn from them: calibrated by construction; sharpened: over-confident).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from tzsl.evaluation import Split
from tzsl.models import (
    AttributeClassifierBank,
    AttributeSVM,
    CalibratedZeroShotClassifier,
    CalibrationWarning,
    ZSLInputError,
)
from tzsl.reporting.report import render_report
from tzsl.studies.comparison import calibration as study_calibration
from tzsl.studies.comparison.calibration import (
    CALIBRATION_COLUMNS,
    calibration_skipped,
    dap_split_posteriors,
    posterior_columns,
    reliability_by_method,
    reliability_figure,
)
from tzsl.studies.comparison.method_runs import COMPARISON_COLUMNS, comparison_trials, method_summary
from tzsl.studies.zero_shot.study import SplitPosteriors


def _split(rng, n_classes=10, trials=30):
    logits = rng.standard_normal((n_classes * trials, n_classes)) * 1.5
    P = np.exp(logits) / np.exp(logits).sum(axis=1, keepdims=True)
    y = (rng.random((len(P), 1)) > np.cumsum(P, axis=1)).sum(axis=1)
    Q = P**4 / (P**4).sum(axis=1, keepdims=True)
    return P, Q, y, np.repeat(np.arange(n_classes), trials)


def _trials(rng):
    parts = []
    for s in range(4):
        P, Q, y, objects = _split(rng)
        classes = np.array([f"s{s}o{o}" for o in objects])
        pred = P.argmax(axis=1)
        # "calibrated": predict_proba is the true posterior, the method's own is sharpened
        parts.append(comparison_trials("calibrated", s, classes, pred == y, **posterior_columns(P, Q, y, pred)))
        parts.append(comparison_trials("raw", s, classes, pred == y, **posterior_columns(Q, Q, y, pred)))
        parts.append(comparison_trials("no-posterior", s, classes, pred == y))
    return pd.concat(parts, ignore_index=True)


def test_method_summary_has_ece_and_brier_with_intervals(tmp_path):
    trials = _trials(np.random.default_rng(0))
    table = method_summary(trials, {}, 0.1, "calibrated", study="simulated-study", data="simulated")
    assert list(table.columns) == COMPARISON_COLUMNS and set(CALIBRATION_COLUMNS) <= set(table.columns)
    t = table.set_index("method")
    assert t.loc["calibrated", "ece"] < 0.05 < 0.15 < t.loc["raw", "ece"]
    assert t.loc["calibrated", "ece_uncalibrated"] == t.loc["raw", "ece"]  # same raw posteriors, same trials
    assert t.loc["calibrated", "brier"] < t.loc["calibrated", "brier_uncalibrated"]
    assert (t.loc[["calibrated", "raw"], "ece_ci95_low"] <= t.loc[["calibrated", "raw"], "ece"]).all()
    assert (t.loc[["calibrated", "raw"], "brier_ci95_high"] > t.loc[["calibrated", "raw"], "brier"]).all()
    assert t.loc["no-posterior", CALIBRATION_COLUMNS].isna().all()
    assert t.loc["raw", "accuracy"] == t.loc["calibrated", "accuracy"]


def test_reliability_table_figure_and_report_section(tmp_path):
    trials = _trials(np.random.default_rng(1))
    rel = reliability_by_method(trials, "simulated-study")
    assert set(rel["method"]) == {"calibrated", "raw"} and set(rel["posterior"]) == {"calibrated", "uncalibrated"}
    assert rel.groupby(["method", "posterior"])["n_trials"].sum().eq(1200).all()
    over = rel[(rel["method"] == "raw") & (rel["posterior"] == "calibrated")]
    top = over[over["bin"] == over["bin"].max()].iloc[0]
    assert top["accuracy"] < top["confidence"] - 0.05  # over-confident: below the diagonal
    summary = method_summary(trials, {}, 0.1, "calibrated", study="simulated-study", data="simulated")
    # "raw" writes the same posterior as calibrated and uncalibrated: its calibration was skipped
    assert calibration_skipped(rel) == ["raw"]
    fig = reliability_figure(rel, summary)
    panels = {ax.get_title(): ax for ax in fig.axes if ax.get_visible() and ax.get_title()}
    assert list(panels) == ["calibrated", "raw"]  # small multiples: one panel per method
    legend = {name: [t.get_text() for t in ax.get_legend().get_texts()] for name, ax in panels.items()}
    assert [label.split(" (ECE ")[0] for label in legend["calibrated"]] == ["uncalibrated", "calibrated"]
    assert [label.split(" (ECE ")[0] for label in legend["raw"]] == ["uncalibrated"]
    notes = {name: [t.get_text() for t in ax.texts] for name, ax in panels.items()}
    assert notes == {"calibrated": [], "raw": ["calibration skipped:\ncalibrated = uncalibrated"]}
    root = tmp_path / "res"
    root.mkdir()
    fig.savefig(root / "phac2_reliability.png")
    rel.to_csv(root / "phac2_reliability.csv", index=False)
    summary.to_csv(root / "phac2_method_comparison.csv", index=False)
    page = render_report(root)
    assert 'id="calibration"' in page and page.index('id="calibration"') < page.index("phac2_reliability.png")
    # the comparison shows its key columns (ece, brier); ece_uncalibrated is in the full table behind the toggle
    assert "phac2_reliability.csv" in page and "ece_\u200buncalibrated" in page and "<th>brier (95% CI)</th>" in page
    assert "Calibration was skipped for raw: the &#34;calibrated&#34; posterior equals the uncalibrated one" in page


def test_dap_split_calibration_uses_the_calibrator_s_bound_and_the_split_s_solver(monkeypatch):
    """The DAP study's folds are dealt on at most the calibrator's default number of trials, and refit
    the split's attribute bank with the solver its fit chose (here approximate, on few trials)."""
    rng = np.random.default_rng(0)
    rows = np.array([[1, 0], [0, 1], [1, 1], [0, 0], [1, 0], [0, 1]])
    objects = np.repeat(np.arange(6), 8)
    X = rows[objects][:, None, :] + 0.5 * rng.standard_normal((48, 1, 2))
    bank = AttributeClassifierBank(estimator=AttributeSVM(n_C=1, n_gamma=1), max_exact_trials=40, random_state=0)
    bank.fit(X, rows[objects], objects)
    seen = {}

    def record(clf, X_train, A_train, groups_train, **kwargs):
        seen.update(kwargs, solver=clf.attribute_model.solver, pinned=clf.attribute_model.estimator_params)
        raise ZSLInputError("recorded")  # the study then keeps T = 1: nothing else to fit here

    monkeypatch.setattr(study_calibration, "pseudo_unseen_scores", record)
    split = Split(name="random-1", train_objects=tuple(map(str, range(6))), test_objects=("a", "b"),
                  attributes=("h", "s"))
    r = SplitPosteriors(split=split, attributes=("h", "s"), P=rng.random((4, 1, 2)), K=np.array([[1, 0], [0, 1]]),
                        y=np.array([0, 1, 0, 1]), train_prior=np.array([0.5, 0.5]), model=bank)
    with pytest.warns(CalibrationWarning, match="recorded"):
        out = dap_split_posteriors(r, X, rows[objects], objects, fusions=("avg",))
    assert seen["max_trials"] == CalibratedZeroShotClassifier().calibration_max_trials
    assert bank.solver_choice_["solver"] == seen["solver"] == "approximate"  # 48 trials > 40; its folds: fewer
    assert out["dap-avg"][2] == 1.0
    chosen = [[(e.C_, e.gamma_) for e in row] for row in bank.estimators_]  # the calibrator's default: pinned
    assert [[(p["C_range"][0], p["gamma_range"][0]) for p in row] for row in seen["pinned"]] == chosen
    with pytest.warns(CalibrationWarning, match="recorded"):
        dap_split_posteriors(r, X, rows[objects], objects, fusions=("avg",), refit="search")
    assert seen["pinned"] is None and seen["solver"] == "approximate"  # the grids searched again, same solver
