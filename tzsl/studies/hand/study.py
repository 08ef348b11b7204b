"""The Shadow-hand study (DAP paper section 5.8): Table 5, multi-grasp curves, confusion matrices, S.

One call of :func:`run_hand_study` does, for every seed:

1. takes the grasps (a grasp folder, or - when none is given - a fresh simulated data set for
   that seed, :func:`tzsl.datasets.simulate_grasps`; simulated numbers say nothing about robots);
2. extracts contacts, material and shape features (:func:`tzsl.features.grasp_features`);
3. fits :class:`tzsl.models.HandDAPClassifier` on the grasps of the **training objects only**
   (scaling, PCA, SVMs and sigmoids never see a test object); grasps of test objects in which no
   BioTac touched are dropped, as in the paper (section 5.5), and counted;
4. scores the test grasps against the test objects' rows of K:

   * Table 5: single-grasp accuracy of MAXDAP, AVGDAP, LDAP per object subset (per grasp);
   * DF-MDAP (eqs. 11-12) accuracy vs the number of grasps T, SC-MDAP accuracy, mean grasps used
     and fraction decided vs k, over ``n_sequences`` random grasp orders per test object (the
     same orders for every T and k; the T-grasp sequence is the first T grasps of the order);
   * confusion matrices of LDAP (single grasp), DF-MDAP at ``confusion_T`` and SC-MDAP at
     ``confusion_k`` (the paper's Fig. 12 settings, T=5 and k=4: fixed in advance, not chosen on
     test results); an object counts as "all correct" when every one of its grasps / sequences is
     classified correctly (the paper's "perfect recognition of 8 out of 10 objects");
   * per-attribute accuracy on the test grasps (material attributes per touching BioTac, as in
     the paper's Fig. 8) and the distance matrix S of eq. 13 from the AVGDAP-fused posteriors
     (eq. 8; LDAP's ``max(0.5, p)`` would cap every distance of a present attribute at 0.5).

Every table has one row per seed plus ``mean`` and ``std`` rows (std over seeds, ``ddof=1``:
empty for a single seed), and the paper's number beside ours where the paper prints one.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from tzsl._profile import stage
from tzsl.datasets import Grasp, HandTable, read_grasps, simulate_grasps
from tzsl.evaluation import summarise_over_splits
from tzsl.exceptions import ConfigError, SplitError
from tzsl.features import GraspFeatures
from tzsl.models.multigrasp import (
    HAND_FUSIONS,
    attribute_distance_matrix,
    df_mdap,
    fuse_grasp_posteriors,
    sample_grasp_sequences,
    sc_mdap,
)
from tzsl.studies.config import HandSettings
from tzsl.studies.hand.figures import (
    attribute_accuracy_figure,
    attribute_distance_figure,
    confusion_figure,
    multigrasp_k_figure,
    multigrasp_T_figure,
)
from tzsl.studies.hand.methods import (
    COMPARISON_TABLE,
    fusion_label,
    hand_comparison,
    hand_fusion_trials,
    registry_trials,
    timed,
)
from tzsl.studies.hand.model import feature_params, fit_hand_model, hand_features
from tzsl.studies.hand.results import HandStudyResult
from tzsl.studies.hand.tables import (
    SUBSETS,
    attribute_table,
    distance_table,
    format_hand_summary,
    table5,
    with_intervals,
)
from tzsl.studies.outputs.failures import ERROR_COLUMN, attempt
from tzsl.studies.outputs.results_folder import ResultsDir
from tzsl.studies.papers import numbers as paper

__all__ = [
    "HAND_OUTPUTS",
    "HandStudyResult",
    "feature_params",
    "fit_hand_model",
    "format_hand_summary",
    "hand_features",
    "run_hand_study",
]

#: Every file :func:`run_hand_study` writes (checked before any computation).
HAND_OUTPUTS: tuple[str, ...] = (
    "hand_table5.csv",
    "hand_multigrasp_T.csv",
    "hand_multigrasp_T.png",
    "hand_multigrasp_k.csv",
    "hand_multigrasp_k.png",
    "hand_confusion.csv",
    "hand_confusion.png",
    "hand_attribute_accuracy.csv",
    "hand_attribute_accuracy.png",
    "hand_attribute_distance.csv",
    "hand_attribute_distance.png",
    f"{COMPARISON_TABLE}.csv",
)


# ---------------------------------------------------------------------------- one seed
def _object_counts(pred: np.ndarray, own: np.ndarray, names: np.ndarray) -> tuple[int, int]:
    """Objects whose samples are all / mostly (> 50%) classified correctly."""
    rates = np.array([(pred[own == o] == o).mean() for o in names if (own == o).any()])
    return int((rates == 1.0).sum()), int((rates > 0.5).sum())


def _confusion_rows(label: str, seed: int, true: np.ndarray, pred: np.ndarray, names: np.ndarray) -> list[dict]:
    tab = pd.crosstab(pd.Categorical(true, categories=names), pd.Categorical(pred, categories=names), dropna=False)
    return [
        {"seed": seed, "method": label, "true": t, "predicted": p, "count": int(tab.loc[t, p])}
        for t in names if (true == t).any() for p in names
    ]


def _evaluate_seed(features: GraspFeatures, table: HandTable, config: HandSettings, seed: int,
                   notes: list[str]) -> dict[str, list]:
    model, fit_seconds = timed(fit_hand_model, features, table, config, seed)
    columns = list(model.K_.columns)
    test_objects = table.test_objects
    Kc = table.K.loc[test_objects, columns].astype(int)
    names = Kc.index.to_numpy()
    K = Kc.to_numpy(dtype=float)
    rule = model.dap_rule()  # DAP over the fused posteriors, the model's prior

    test = np.isin(features.objects, test_objects)
    touched = features.contact.any(axis=1)
    dropped = int((test & ~touched).sum())
    if dropped:
        notes.append(f"seed {seed}: dropped {dropped} test grasp(s) in which no BioTac touched the object")
    te = features.subset(test & touched)
    if len(te) == 0:
        raise SplitError(f"no test grasp with a touching BioTac (test objects {test_objects})")
    y = te.objects.astype(object)
    P_mat, contact, P_sh = model.attribute_posteriors(te.to_array())
    fused = {f: fuse_grasp_posteriors(P_mat, contact, P_sh, f) for f in HAND_FUSIONS}
    # exact ties (e.g. LDAP's max(0.5, p) when a grasp misses the attribute two classes differ in)
    # are broken uniformly at random, seeded, so no class wins ties by its place in Table 4
    ties = np.random.default_rng([seed, 7])
    pred = {f: names[rule.predict(fused[f], K, random_state=ties)] for f in HAND_FUSIONS}
    subset_of = table.subset.reindex(y).fillna("").to_numpy()
    subsets = [s for s in SUBSETS if (subset_of == s).any()] + sorted(
        {s for s in subset_of if s and s not in SUBSETS}
    )

    out: dict[str, list] = {k: [] for k in ("table5", "T", "k", "attr", "S", "confusion", "trust")}
    out["trials"] = hand_fusion_trials(pred, y, seed)
    out["seconds"] = [{fusion_label(fusion): fit_seconds for fusion in pred}]
    train = np.isin(features.objects, table.train_objects)
    trials, seconds = registry_trials(config.methods.compare, features.subset(train).to_array(),
                                      features.objects[train], table.K[columns], te.to_array(), y, names, seed)
    out["trials"] += trials
    out["seconds"].append({k: v[0] for k, v in seconds.items()})
    for f in HAND_FUSIONS:
        ok = pred[f] == y
        row: dict = {"seed": seed, "method": f.upper()}
        out["trust"] += [("table5", seed, "all", y, ok, "trial", {"method": f.upper()}),
                         ("table5", seed, "all_per_class_mean", y, ok, "class_mean", {"method": f.upper()})]
        out["trust"] += [("table5", seed, s, y[subset_of == s], ok[subset_of == s], "trial", {"method": f.upper()})
                         for s in subsets]
        for s in subsets:
            row[s] = float(ok[subset_of == s].mean())
        row["all"] = float(ok.mean())
        row["all_per_class_mean"] = float(np.mean([ok[y == o].mean() for o in pd.unique(y)]))
        row["objects_all_correct"], row["objects_majority_correct"] = _object_counts(pred[f], y, names)
        row["n_test_grasps"] = int(len(y))
        out["table5"].append(row)
    out["confusion"] += _confusion_rows("LDAP", seed, y, pred["ldap"], names)

    # multi-grasp: the same random orders of each object's grasps for every T and k
    counts = pd.Series(y).value_counts()
    L = int(min(config.methods.sequence_length, counts.min()))
    if L < config.methods.sequence_length:
        notes.append(f"seed {seed}: sequences of {L} grasps (object {counts.idxmin()!r} has only {counts.min()})")
    idx, own = sample_grasp_sequences(y, L, config.methods.n_sequences, random_state=seed)
    P_ldap = fused["ldap"]
    for T in range(1, min(config.methods.max_T, L) + 1):
        p = names[rule.predict(df_mdap(P_ldap[idx[:, :T]]), K, random_state=ties)]
        all_ok, most_ok = _object_counts(p, own, names)
        out["trust"].append(("T", seed, "accuracy", own, p == own, "trial", {"T": T}))
        out["T"].append({"seed": seed, "T": T, "accuracy": float((p == own).mean()),
                         "objects_all_correct": all_ok, "objects_majority_correct": most_ok,
                         "n_sequences": int(len(own))})
        if T == min(config.methods.confusion_T, L):
            out["confusion"] += _confusion_rows(f"DF-MDAP (T={T})", seed, own, p, names)
    decisions = rule.predict(P_ldap, K, random_state=ties)  # LDAP per grasp (as the paper)
    for k in range(1, config.methods.max_k + 1):
        d, used, decided = sc_mdap(decisions[idx], k)
        p = names[d]
        all_ok, most_ok = _object_counts(p, own, names)
        out["trust"].append(("k", seed, "accuracy", own, p == own, "trial", {"k": k}))
        out["k"].append({"seed": seed, "k": k, "accuracy": float((p == own).mean()),
                         "mean_grasps_used": float(used.mean()), "decided_fraction": float(decided.mean()),
                         "objects_all_correct": all_ok, "objects_majority_correct": most_ok,
                         "sequence_length": L, "n_sequences": int(len(own))})
        if k == config.methods.confusion_k:
            out["confusion"] += _confusion_rows(f"SC-MDAP (k={k})", seed, own, p, names)

    # attributes: per touching BioTac for materials (paper Fig. 8), joint angles for shapes
    A = Kc.loc[y].to_numpy()  # (n, m) labels of the test grasps
    n_mat = len(model.material_attributes_)
    for j, name in enumerate(columns):
        if j < n_mat:
            hits = (P_mat[:, :, j] > 0.5) == (A[:, j][:, None] == 1)
            lab = np.broadcast_to(A[:, j][:, None], contact.shape)[contact]
            hit = hits[contact]
            kind, objects = "material", np.broadcast_to(y[:, None], contact.shape)[contact]
        else:
            hit = (P_sh[:, j - n_mat] > 0.5) == (A[:, j] == 1)
            lab = A[:, j]
            kind, objects = "shape", y
        out["trust"].append(("attr", seed, "accuracy", objects, hit, "trial", {"attribute": name, "kind": kind}))
        both = (lab == 1).any() and (lab == 0).any()
        out["attr"].append({
            "seed": seed, "attribute": name, "kind": kind, "accuracy": float(hit.mean()),
            "balanced_accuracy": float((hit[lab == 1].mean() + hit[lab == 0].mean()) / 2) if both else np.nan,
            "n_predictions": int(hit.size), "test_objects_with_attribute": int(Kc[name].sum()),
        })
    S = attribute_distance_matrix(fused["avgdap"], y, Kc)
    S.insert(0, "seed", seed)
    out["S"].append(S.rename_axis("object").reset_index())
    return out


# ---------------------------------------------------------------------------- the study
def run_hand_study(
    grasps: str | Path | Sequence[Grasp] | None,
    table: HandTable,
    out: str | Path | ResultsDir,
    seeds: Sequence[int] = (0,),
    config: HandSettings | None = None,
    *,
    force: bool = False,
    log: Callable[[str], None] | None = None,
) -> HandStudyResult:
    """Run the hand study and write its tables and figures to ``out``.

    What the run's manifest records of it (settings, seeds, notes, the simulator's parameters) and the
    data files it read are :attr:`HandStudyResult.record` and ``data_files``: ``tzsl run`` and
    :func:`tzsl.run` write them into the run's one ``manifest.json``.

    Parameters
    ----------
    grasps : grasp folder, sequence of Grasp, or None
        The labelled grasps. ``None``: simulate a data set per seed from ``table.K`` with the
        simulator settings of ``config`` (simulated data; results say so in every figure).
    table : HandTable
        Class-attribute table with train/test split and object subsets (e.g.
        :func:`tzsl.datasets.load_hand_table4`).
    out : folder or ResultsDir
        Output folder; existing files are refused unless ``force`` (checked before computing).
    seeds : sequence of int
        One model fit (and, when simulating, one data set) and one set of grasp orders per seed.
    config : HandSettings, optional
        The checked ``[simulation]``, ``[features]``, ``[methods]`` and ``[compute]`` tables; default:
        the schema's defaults.
    force : bool
        Overwrite existing results.
    log : callable, optional
        Receives progress lines.

    Returns
    -------
    HandStudyResult
    """
    config = HandSettings() if config is None else config
    seeds = [int(s) for s in seeds]
    if not seeds or len(set(seeds)) != len(seeds):
        raise ConfigError(f"seeds must be distinct integers, got {seeds}")
    results = out if isinstance(out, ResultsDir) else ResultsDir(out, force=force)
    results.check_free(HAND_OUTPUTS)
    log = log or (lambda _msg: None)

    simulated = grasps is None
    data_files: list[Path] = []
    fixed: GraspFeatures | None = None
    source = "simulated"
    if grasps is not None:  # not simulated
        given: Sequence[Grasp]
        if isinstance(grasps, str | Path):
            source = str(grasps)
            data_files.append(Path(grasps) / "grasps.csv")
            given = read_grasps(grasps)
        else:
            source = "in-memory grasps"
            given = grasps
        with stage("features"):
            fixed = hand_features(given, table, config)
    data_label = (f"SIMULATED grasps (tzsl simulator, seeds {seeds}) - not the paper's data"
                  if simulated else f"grasps: {source}")

    notes: list[str] = []
    parts: dict[str, list] = {k: [] for k in ("table5", "T", "k", "attr", "S", "confusion", "trust", "trials",
                                              "seconds")}
    simulation: dict[str, dict] = {}
    failed: list[tuple[int, str]] = []
    for seed in seeds:
        if simulated:
            with stage("simulate"):  # the simulator (SIMULATED grasps) and their grasp features
                sim = simulate_grasps(table.K, **config.simulation.model_dump(),
                                      material_attributes=table.material_attributes, random_state=seed)
                simulation[str(seed)] = sim.params
                features = hand_features(sim.grasps, table, config)
            log(f"seed {seed}: simulated {len(sim.grasps)} grasps of {len(table.K)} objects")
        else:
            assert fixed is not None  # the given grasps' features, computed above
            features = fixed
        res, error = attempt(_evaluate_seed, features, table, config, seed, notes)
        if res is None:  # NaN rows in Table 5 with the reason; reported at the end of the run
            failed.append((seed, error))
            parts["table5"] += [{"seed": seed, "method": f.upper(), "all": np.nan, ERROR_COLUMN: error}
                                for f in HAND_FUSIONS]
            log(f"seed {seed}: failed: {error}")
            continue
        for row in res["table5"]:
            row[ERROR_COLUMN] = ""
        for key, rows in res.items():
            parts[key] += rows
        ldap = [r for r in res["table5"] if r["method"] == "LDAP"][0]["all"]
        log(f"seed {seed}: LDAP single-grasp accuracy {ldap:.3f}")
    if len(failed) == len(seeds):  # nothing to tabulate: the last seed again, its error ends the run
        _evaluate_seed(features, table, config, seeds[-1], [])

    names = list(table.test_objects)
    trust = parts["trust"]
    result = HandStudyResult(
        table5=with_intervals(table5(parts["table5"]), trust, "table5", ("method",)),
        multigrasp_T=with_intervals(summarise_over_splits(pd.DataFrame(parts["T"]), split_column="seed", by=["T"]),
                                    trust, "T", ("T",)),
        multigrasp_k=with_intervals(summarise_over_splits(pd.DataFrame(parts["k"]), split_column="seed", by=["k"]),
                                    trust, "k", ("k",)),
        attribute_accuracy=with_intervals(attribute_table(parts["attr"]), trust, "attr", ("attribute", "kind"),
                                          baselines=False),
        attribute_distance=distance_table(parts["S"]),
        confusion=pd.DataFrame(parts["confusion"]),
        method_comparison=hand_comparison(parts["trials"], parts["seconds"], 1.0 / len(table.test_objects),
                                          simulated),
        simulated=simulated,
        notes=notes,
    )
    for name in ("table5", "multigrasp_T", "multigrasp_k", "attribute_accuracy", "attribute_distance", "confusion"):
        getattr(result, name).insert(0, "data", "simulated" if simulated else "supplied")
    result.multigrasp_T["paper_T1_ldap"] = paper.DAP_HAND_SINGLE_GRASP_BEST
    results.write_csv("hand_table5.csv", result.table5)
    results.write_csv("hand_multigrasp_T.csv", result.multigrasp_T)
    results.write_figure("hand_multigrasp_T.png", multigrasp_T_figure(result.multigrasp_T, data_label))
    results.write_csv("hand_multigrasp_k.csv", result.multigrasp_k)
    results.write_figure("hand_multigrasp_k.png", multigrasp_k_figure(result.multigrasp_k, data_label))
    results.write_csv("hand_confusion.csv", result.confusion)
    results.write_figure("hand_confusion.png", confusion_figure(result.confusion, names, data_label))
    results.write_csv("hand_attribute_accuracy.csv", result.attribute_accuracy)
    results.write_figure("hand_attribute_accuracy.png",
                         attribute_accuracy_figure(result.attribute_accuracy, data_label))
    results.write_csv(f"{COMPARISON_TABLE}.csv", result.method_comparison)
    results.write_csv("hand_attribute_distance.csv", result.attribute_distance)
    results.write_figure("hand_attribute_distance.png",
                         attribute_distance_figure(result.attribute_distance, data_label))
    result.record = {  # for the run's one manifest (the engine's manifest.json)
        "hand": {"study": "hand (DAP paper section 5.8)", "seeds": list(seeds), "grasps": source,
                 "simulated": simulated, "table": table.source, "train_objects": table.train_objects,
                 "test_objects": table.test_objects, **config.model_dump(mode="json")},
        "notes": notes, **({"simulation": simulation} if simulated else {})}
    result.data_files = list(data_files)
    result.written = list(results.written)
    return result
