"""Every method on the hand study's grasps: ``hand_method_comparison.csv``.

The hand study fits one :class:`~tzsl.models.HandDAPClassifier` per seed and scores its three
fusions (MAXDAP, AVGDAP, LDAP) on the test grasps with a touching BioTac. The same test grasps
are given to every registry method of ``[methods] compare`` (feature methods: ESZSL, SAE, ALE,
SJE, DeViSE, IAP, the embedding model, DAP with one RBF-SVM per attribute), fitted on the
training objects' grasps through :func:`tzsl.studies.comparison.method_runs.fit_predict`. Their input
is the packed grasp array (:func:`tzsl.features.pack_grasp_features`: every finger's 22 material
features, the contact flags, the joint angles; NaN set to 0): the hand-specific fusion over
touching fingers is what the hand DAP adds on top. The reference is the paper's method, LDAP;
on simulated grasps every row says so (``data = "simulated"``).
"""

from __future__ import annotations

import time

import numpy as np
import pandas as pd

from tzsl.studies.comparison.calibration import posterior_columns
from tzsl.studies.comparison.method_runs import (
    comparison_file,
    comparison_trials,
    fit_predict,
    method_label,
    method_summary,
)
from tzsl.studies.papers.numbers import DAP_HAND_TABLE5

__all__ = ["COMPARISON_TABLE", "REFERENCE_METHOD", "STUDY", "fusion_label", "hand_comparison", "registry_trials"]

STUDY = "hand"
#: Table key (file stem) of the study's comparison.
COMPARISON_TABLE = comparison_file(STUDY)[: -len(".csv")]
#: The paper's single-grasp method (Table 5's best).
REFERENCE_METHOD = "ldap"


def fusion_label(fusion: str) -> str:
    """Row label of a hand DAP fusion: ``"ldap"`` (the registered method), ``"hand-dap_fusion_maxdap"``."""
    return REFERENCE_METHOD if fusion == "ldap" else method_label({"name": "hand-dap", "fusion": fusion})


def registry_trials(specs, X_train: np.ndarray, objects_train: np.ndarray, K: pd.DataFrame,
                    X_test: np.ndarray, y_test: np.ndarray, test_objects, seed: int) -> tuple[list, dict]:
    """Fit every registry method on the training grasps; score the test grasps among the test objects.

    Parameters
    ----------
    specs : sequence of dict
        Registry entries ``{"name": ..., **parameters}``.
    X_train : ndarray of shape (n_train, d)
        Packed training grasps (NaN allowed: set to 0).
    objects_train : ndarray of shape (n_train,)
    K : DataFrame
        Class-attribute table (objects x attributes), the model's columns.
    X_test : ndarray of shape (n_test, d)
    y_test : ndarray of shape (n_test,)
        True object of each test grasp.
    test_objects : sequence of str
        Candidate objects, in the order of the reference's rows.
    seed : int

    Returns
    -------
    (list of DataFrame, dict)
        :func:`~tzsl.studies.comparison.method_runs.comparison_trials` per method and its fit seconds.
    """
    X_train, X_test = np.nan_to_num(np.asarray(X_train, float)), np.nan_to_num(np.asarray(X_test, float))
    names = np.asarray(list(test_objects))
    class_rows = K.loc[np.unique(objects_train)].to_numpy(dtype=float)
    K_test = K.loc[names].to_numpy(dtype=float)
    trials: list[pd.DataFrame] = []
    seconds: dict[str, list[float]] = {}
    for spec in specs:
        fit = fit_predict(spec, X_train, np.asarray(objects_train), class_rows, X_test, K_test, seed)
        label = method_label(spec)
        trials.append(comparison_trials(label, f"seed{seed}", y_test, names[fit.predicted] == y_test,
                                        **posterior_columns(fit.proba, fit.proba_uncalibrated,
                                                            pd.Index(names).get_indexer(y_test), fit.predicted)))
        seconds.setdefault(label, []).append(fit.fit_seconds)
    return trials, seconds


def hand_comparison(trials: list[pd.DataFrame], per_seed_seconds: list[dict[str, float]], chance: float,
                    simulated: bool) -> pd.DataFrame:
    """The hand study's method comparison (LDAP the reference; the paper's Table 5 "all" beside).

    ``per_seed_seconds``: one ``{method label: fit seconds}`` per fit (seed).
    """
    seconds: dict[str, list[float]] = {}
    for fits in per_seed_seconds:
        for label, value in fits.items():
            seconds.setdefault(label, []).append(value)
    paper = {fusion_label(f): row["all"] for f, row in DAP_HAND_TABLE5.items()}
    where = "SIMULATED grasps" if simulated else "grasps"
    pooled = pd.concat(trials, ignore_index=True)
    notes = {label: f"{where}; packed grasp features" for label in pooled["method"].unique()}
    notes.update({label: f"{where}; paper: Table 5 (all test objects, Shadow hand)" for label in paper})
    notes[REFERENCE_METHOD] = f"{where}; the paper's method (reference); paper: Table 5"
    return method_summary(pooled, seconds, chance, REFERENCE_METHOD, study=STUDY,
                          data="simulated" if simulated else "real", paper=paper, notes=notes, split_kind="paper")


def hand_fusion_trials(pred: dict, y: np.ndarray, seed: int) -> list[pd.DataFrame]:
    """Trials of the hand DAP's fusions (``pred``: fusion -> predicted object per test grasp)."""
    return [comparison_trials(fusion_label(f), f"seed{seed}", y, np.asarray(p) == y) for f, p in pred.items()]


def timed(function, *args, **kwargs):
    """``(function(*args, **kwargs), wall seconds)``."""
    start = time.perf_counter()
    out = function(*args, **kwargs)
    return out, time.perf_counter() - start
