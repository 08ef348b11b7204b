"""The hand study (DAP paper section 5.8) on a small simulated grasp set."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from pydantic import ValidationError

from tests.study_settings import study_settings
from tzsl.datasets import load_hand_table4, simulate_grasps
from tzsl.exceptions import ConfigError, DataFileError
from tzsl.models import HandDAPClassifier
from tzsl.models.dap import break_ties
from tzsl.studies.config import HandSettings
from tzsl.studies.hand.study import (
    HAND_OUTPUTS,
    fit_hand_model,
    format_hand_summary,
    hand_features,
    run_hand_study,
)
from tzsl.studies.papers import numbers as paper

TABLE = load_hand_table4()
CONFIG = study_settings(HandSettings, n_grasps_per_object=20, max_T=4, max_k=3, sequence_length=8, n_sequences=15,
                        confusion_T=3, confusion_k=2)


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    path = tmp_path_factory.mktemp("grasps")
    simulate_grasps(TABLE.K, 20, random_state=0, folder=path)
    return path


@pytest.fixture(scope="module")
def study(folder, tmp_path_factory):
    out = tmp_path_factory.mktemp("hand_results")
    return run_hand_study(folder, TABLE, out, seeds=[0, 1], config=CONFIG), out


def test_every_file_is_written_with_its_columns(study, folder):
    result, out = study
    assert sorted(p.name for p in out.iterdir()) == sorted(HAND_OUTPUTS)
    t5 = pd.read_csv(out / "hand_table5.csv")
    for col in ("seed", "method", "homogeneous", "heterogeneous_shape", "heterogeneous_material", "all",
                "paper_homogeneous", "paper_heterogeneous_shape", "paper_heterogeneous_material", "paper_all"):
        assert col in t5.columns, col
    assert list(t5["method"][:3]) == ["MAXDAP", "AVGDAP", "LDAP"]
    assert list(t5["seed"].astype(str)) == ["0"] * 3 + ["1"] * 3 + ["mean"] * 3 + ["std"] * 3
    assert (t5["data"] == "supplied").all()  # grasps read from a folder, not simulated by the study
    for col in ("all_ci95_low", "all_ci95_high", "all_per_class_mean_ci95_low", "homogeneous_ci95_high", "chance"):
        assert col in t5.columns, col
    rows = t5[t5["seed"].astype(str) != "std"]
    assert (rows["all_ci95_low"] <= rows["all"] + 1e-9).all() and (rows["all"] <= rows["all_ci95_high"] + 1e-9).all()
    assert rows["chance"].round(6).eq(round(1 / len(TABLE.test_objects), 6)).all()
    T = pd.read_csv(out / "hand_multigrasp_T.csv")
    assert {"seed", "T", "accuracy", "objects_all_correct", "paper_T1_ldap", "ci95_low", "ci95_high"} <= set(T.columns)
    assert sorted(T["T"].unique()) == [1, 2, 3, 4]
    k = pd.read_csv(out / "hand_multigrasp_k.csv")
    assert {"seed", "k", "accuracy", "mean_grasps_used", "decided_fraction", "objects_all_correct"} <= set(k.columns)
    att = pd.read_csv(out / "hand_attribute_accuracy.csv")
    assert ({"seed", "attribute", "kind", "accuracy", "balanced_accuracy", "paper_accuracy", "ci95_low"}
            <= set(att.columns))
    assert "chance" not in att.columns  # attribute accuracy: no test-class chance
    assert set(att["attribute"]) == set(TABLE.K.columns) | {"mean"}
    S = pd.read_csv(out / "hand_attribute_distance.csv")
    assert list(S.columns) == ["data", "seed", "object", *TABLE.material_attributes, *TABLE.shape_attributes]
    conf = pd.read_csv(out / "hand_confusion.csv")
    assert set(conf["method"]) == {"LDAP", "DF-MDAP (T=3)", "SC-MDAP (k=2)"}
    for png in out.glob("*.png"):
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert result.record["hand"]["seeds"] == [0, 1] and result.record["hand"]["simulated"] is False
    assert folder / "grasps.csv" in result.data_files


def test_table5_matches_the_model_scored_directly(study, folder):
    """Seed 0's row equals HandDAPClassifier fitted on the training objects and asked directly."""
    result, _ = study
    from tzsl.datasets import read_grasps

    feats = hand_features(read_grasps(folder), TABLE, CONFIG)
    tr = feats.subset(np.isin(feats.objects, TABLE.train_objects))
    te = feats.subset(np.isin(feats.objects, TABLE.test_objects) & feats.contact.any(axis=1))
    model = HandDAPClassifier(material_attributes=TABLE.material_attributes, random_state=0, n_jobs=1)
    model.fit(tr.to_array(), tr.objects, TABLE.K)
    Kte = TABLE.K.loc[TABLE.test_objects]
    t5 = result.table5.set_index(["seed", "method"])
    subset = TABLE.subset.loc[te.objects].to_numpy()
    ties = np.random.default_rng([0, 7])  # the study breaks exact ties at random with this seed, in this order
    for fusion in ("maxdap", "avgdap", "ldap"):
        pred = Kte.index.to_numpy()[break_ties(model.predict_log_scores(te.to_array(), Kte, fusion=fusion), ties)]
        ok = pred == te.objects
        row = t5.loc[(0, fusion.upper())]
        assert row["all"] == pytest.approx(ok.mean())
        assert row["heterogeneous_material"] == pytest.approx(ok[subset == "heterogeneous_material"].mean())
        assert row["paper_all"] == paper.DAP_HAND_TABLE5[fusion]["all"]
    mean = t5.loc[("mean", "LDAP"), "all"]
    assert mean == pytest.approx((t5.loc[(0, "LDAP"), "all"] + t5.loc[(1, "LDAP"), "all"]) / 2)
    assert np.isnan(t5.loc[("std", "LDAP"), "paper_all"])


def test_multigrasp_curves_are_consistent(study):
    result, _ = study
    T = result.multigrasp_T
    k = result.multigrasp_k
    for seed in (0, 1):
        t1 = T[(T["seed"] == seed) & (T["T"] == 1)]["accuracy"].item()
        k1 = k[(k["seed"] == seed) & (k["k"] == 1)]
        # T = 1 and k = 1 both classify the first grasp of each sequence with LDAP
        assert k1["accuracy"].item() == pytest.approx(t1)
        assert k1["mean_grasps_used"].item() == 1.0 and k1["decided_fraction"].item() == 1.0
        used = k[k["seed"] == seed]["mean_grasps_used"].to_numpy()
        assert np.all(np.diff(used) > 0) and used.max() <= CONFIG.methods.sequence_length
    assert (T["accuracy"].dropna().between(0, 1)).all()


def test_distance_matrix_and_attributes(study):
    result, _ = study
    S = result.attribute_distance
    mean = S[S["seed"] == "mean"].set_index("object").drop(columns=["seed", "data"])
    assert list(mean.index) == TABLE.test_objects
    assert ((mean >= 0) & (mean <= 1)).all().all()
    att = result.attribute_accuracy
    cardboard = att[(att["seed"] == 0) & (att["attribute"] == "cardboard")]
    assert np.isnan(cardboard["balanced_accuracy"].item())  # no test object is cardboard
    assert (att["kind"][att["attribute"].isin(TABLE.material_attributes)] == "material").all()


def test_summary_names_the_paper_numbers(study):
    text = format_hand_summary(study[0])
    assert "59.63%" in text and "8/10" in text and "SIMULATED" not in text


def test_fit_uses_training_objects_only(folder):
    from tzsl.datasets import read_grasps

    feats = hand_features(read_grasps(folder), TABLE, CONFIG)
    train = np.isin(feats.objects, TABLE.train_objects)
    a = fit_hand_model(feats, TABLE, CONFIG, seed=0)
    b = fit_hand_model(feats.subset(train), TABLE, CONFIG, seed=0)
    X = feats.subset(~train & feats.contact.any(axis=1)).to_array()
    np.testing.assert_array_equal(a.predict_attribute_proba(X), b.predict_attribute_proba(X))
    assert set(a.classes_) == set(TABLE.train_objects)


@pytest.mark.slow
def test_simulated_when_no_grasps_and_refuses_overwrite(tmp_path):
    cfg = study_settings(HandSettings, n_grasps_per_object=12, max_T=2, max_k=2, sequence_length=4, n_sequences=5,
                         confusion_T=2, confusion_k=2)
    result = run_hand_study(None, TABLE, tmp_path, seeds=[3], config=cfg)
    assert result.simulated
    assert "SIMULATED" in format_hand_summary(result)
    for csv in tmp_path.glob("*.csv"):
        assert (pd.read_csv(csv)["data"] == "simulated").all(), csv.name
    from tzsl.reporting.report import write_report

    page = write_report(tmp_path).read_text()
    hand = page[page.index('<section id="hand-table5">'):]
    hand = hand[:hand.index("</section>")]
    assert "SIMULATED DATA" in hand
    assert result.record["hand"]["simulated"] is True
    assert result.record["simulation"]["3"]["random_state"] == 3
    with pytest.raises(ConfigError, match="--force"):
        run_hand_study(None, TABLE, tmp_path, seeds=[3], config=cfg)


def test_unknown_object_is_a_clear_error(tmp_path):
    sim = simulate_grasps(TABLE.K.iloc[:2], 3, random_state=0)
    renamed = [g.__class__(g.grasp_id, "teapot", g.source, g.fingers, g.joints) for g in sim.grasps]
    with pytest.raises(DataFileError, match="teapot"):
        run_hand_study(renamed, TABLE, tmp_path, seeds=[0], config=CONFIG)


@pytest.mark.parametrize("bad", [{"max_T": 0}, {"n_sequences": -1}, {"model": {"material_attributes": []}}])
def test_bad_config(bad):
    """Impossible settings are refused by the schema, before any study runs."""
    with pytest.raises(ValidationError, match=next(iter(bad))):
        study_settings(HandSettings, **bad)


def test_a_failing_seed_is_recorded_and_the_others_complete(folder, tmp_path, monkeypatch):
    import tzsl.studies.hand.study as hand
    from tzsl.exceptions import SplitError
    from tzsl.studies.outputs.failures import table_failures

    real = hand._evaluate_seed

    def fails_on_seed_1(features, table, config, seed, notes):
        if seed == 1:
            raise SplitError("simulated: too few grasps for this seed")
        return real(features, table, config, seed, notes)

    monkeypatch.setattr(hand, "_evaluate_seed", fails_on_seed_1)
    result = run_hand_study(folder, TABLE, tmp_path / "res", seeds=[0, 1], config=CONFIG)
    t5 = result.table5
    failed = t5[t5["seed"].astype(str) == "1"]
    assert len(failed) == 3 and failed["all"].isna().all()
    assert (failed["error"] == "SplitError: simulated: too few grasps for this seed").all()
    done = t5[t5["seed"].astype(str) == "0"]
    assert done["all"].between(0, 1).all() and (done["error"] == "").all()
    assert len(table_failures({"table5": t5})) == 3
    with pytest.raises(SplitError, match="simulated"):  # every seed failed: the error ends the run
        run_hand_study(folder, TABLE, tmp_path / "res2", seeds=[1], config=CONFIG)
