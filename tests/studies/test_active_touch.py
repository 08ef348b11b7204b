"""Active-touch study: the written tables and figure, and a real PHAC-2 split."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from tests.study_settings import study_settings
from tzsl.datasets import FeatureSet
from tzsl.evaluation import random_object_splits
from tzsl.exceptions import ConfigError
from tzsl.studies.active_touch.stopping import DECIDED_COLUMNS, stop_outcomes
from tzsl.studies.active_touch.study import evaluate_split, run_active_touch_study
from tzsl.studies.config import ActiveTouchStudy
from tzsl.studies.outputs.results_folder import ResultsDir

EPS = ("squeeze", "hold", "slow_slide", "fast_slide")


def _feature_set(n_objects=24, n_trials=3, n_attributes=6, seed=0) -> FeatureSet:
    """Synthetic PHAC-2-like features: the hold block carries the attributes, the others are noise."""
    rng = np.random.default_rng(seed)
    K = (rng.random((n_objects, n_attributes)) < 0.5).astype(int)
    K[:6] = np.eye(6, n_attributes, dtype=int)
    K[6:12] = 1 - K[:6]
    objects = np.repeat([f"obj_{i:03d}" for i in range(n_objects)], n_trials)
    codes = np.repeat(np.arange(n_objects), n_trials)
    X = rng.normal(size=(codes.size, 2, 4 * n_attributes))
    hold = slice(n_attributes, 2 * n_attributes)
    X[:, :, hold] += 3.0 * (K[codes] - 0.5)[:, None, :]
    trial_ids = [f"{o}_{t}" for o, t in zip(objects, np.tile(np.arange(n_trials), n_objects), strict=True)]
    trials = pd.DataFrame({"trial_id": trial_ids,
                           "object_id": codes, "object_name": objects,
                           "trial_index": np.tile(np.arange(1, n_trials + 1), n_objects)})
    attributes = pd.DataFrame(K, index=pd.Index([f"obj_{i:03d}" for i in range(n_objects)], name="object_name"),
                              columns=[f"a{j}" for j in range(n_attributes)])
    names = tuple(f"{ep}:f{j}" for ep in EPS for j in range(n_attributes))
    return FeatureSet(X=X, trials=trials, sensors=("finger_0", "finger_1"), feature_names=names,
                      attributes=attributes, dataset="synthetic")


def test_study_writes_table_and_figure(tmp_path, monkeypatch):
    monkeypatch.delenv("TZSL_CACHE_DIR", raising=False)
    fs = _feature_set()
    config = study_settings(ActiveTouchStudy, kinds=("random",), n_splits=2, thresholds=(0.5, 0.9),
                            decided_thresholds=(0.5, 0.9), **{"methods.cv": 3}, n_samples=32, n_boot=200)
    tables = run_active_touch_study(fs, ResultsDir(tmp_path), config)
    assert {"active_touch.csv", "active_touch_curves.csv", "active_touch_stop.csv", "active_touch_decided.csv",
            "active_touch.png", "active_touch_stopping.png"} == {
        p.name for p in tmp_path.iterdir()}
    table = tables["active_touch_curves"]
    written = pd.read_csv(tmp_path / "active_touch_curves.csv")
    assert len(written) == len(table) and (written["data"] == "real").all()
    eps_rows = table[table["x_kind"] == "eps"]
    strategies = set(eps_rows["strategy"])
    assert {"active", "active_per_second", "random", "paper", "best_fixed_train",
            "best_fixed_test_optimistic"} <= strategies
    assert {f"first:{ep}" for ep in EPS} <= strategies
    assert sum(s.startswith("order:") for s in strategies) == 24
    assert (eps_rows.groupby("strategy").size() == 4).all()
    ok = (table["ci95_low"] <= table["accuracy"] + 1e-12) & (table["accuracy"] <= table["ci95_high"] + 1e-12)
    assert ok.all()
    # each first:<ep> order starts with its EP
    chosen = table.attrs["chosen"]
    assert all(chosen[split][f"first:{ep}"].startswith(f"order:{short}")
               for split in chosen for ep, short in zip(EPS, ("sq", "ho", "ss", "fs"), strict=True))
    # the hold block is the informative one: the active policy explores it first and beats chance
    first = eps_rows[(eps_rows["strategy"] == "active") & (eps_rows["x"] == 1)]
    assert first["first_hold"].iloc[0] == 1.0
    assert first["accuracy"].iloc[0] > 2 * first["chance"].iloc[0]
    # random order is the mean of the 24 fixed orders
    orders = eps_rows[eps_rows["strategy"].str.startswith("order:")].groupby("x")["accuracy"].mean()
    np.testing.assert_allclose(eps_rows[eps_rows["strategy"] == "random"].set_index("x")["accuracy"], orders)
    stop = tables["active_touch_stop"]
    assert set(stop["strategy"]) == {"active", "active_per_second", "best_fixed_train", "paper", "random"}
    assert ((stop["mean_eps"] >= 1) & (stop["mean_eps"] <= 4)).all()
    np.testing.assert_allclose(stop["eps_saved"], 4 - stop["mean_eps"])
    np.testing.assert_allclose(stop["difference"], stop["accuracy"] - stop["all_eps_accuracy"], atol=1e-12)
    for _, g in stop.groupby("strategy"):  # a higher threshold never stops earlier
        assert g.sort_values("threshold")["mean_eps"].is_monotonic_increasing
    assert (stop["posterior"] == "tempered").all()
    _check_decided_table(tables["active_touch_decided"], pd.read_csv(tmp_path / "active_touch_decided.csv"))
    assert len(table.attrs["exponents"]) == 2 and all(len(v) == 16 for v in table.attrs["exponents"].values())
    summary = tables["active_touch"]
    assert list(summary["strategy"][:3]) == ["active", "active_per_second", "best_fixed_train"]
    assert list(summary.columns[:7]) == ["split_kind", "strategy", "acc_1ep", "acc_1ep_ci95_low", "acc_1ep_ci95_high",
                                         "acc_2ep", "acc_2ep_ci95_low"]
    assert summary.columns[-4:].tolist() == ["acc_mean_over_seconds", "acc_mean_over_seconds_ci95_low",
                                             "acc_mean_over_seconds_ci95_high", "purpose"]
    assert summary.loc[summary["strategy"] == "chance", "acc_1ep"].iloc[0] == pytest.approx(table["chance"].iloc[0])
    with pytest.raises(ConfigError, match="already exists"):
        run_active_touch_study(fs, ResultsDir(tmp_path), config)


def test_random_splits_belong_to_the_purpose_and_seed_nothing_else():
    """[splits] purpose: the random splits' test sets are that purpose's, and the purposes share none."""
    from tzsl.evaluation import split_purpose
    from tzsl.studies.active_touch.study import make_active_splits

    fs = _feature_set()
    made = {p: make_active_splits(fs, "random", study_settings(ActiveTouchStudy, n_splits=6, purpose=p))
            for p in ("select", "confirm")}
    for purpose, splits in made.items():
        assert {split_purpose(s.test_objects) for s in splits} == {purpose}
    assert not {s.test_objects for s in made["select"]} & {s.test_objects for s in made["confirm"]}


def _check_decided_table(dec: pd.DataFrame, written: pd.DataFrame) -> None:
    assert tuple(dec.columns) == (*DECIDED_COLUMNS, "purpose") and list(written.columns) == list(dec.columns)
    assert set(dec["purpose"]) == {"confirm"}  # the default: reported on confirmation splits
    assert set(dec["posterior"]) == {"tempered", "untempered"} and set(dec["strategy"]) == {"active", "random"}
    assert len(dec) == 2 * 2 * 2  # posteriors x strategies x thresholds (0.5, 0.9)
    assert dec["decided_share"].between(0, 1).all()
    some = dec["decided_share"] > 0
    assert (dec.loc[some, "decided_accuracy_ci95_low"] <= dec.loc[some, "decided_accuracy"] + 1e-12).all()
    assert (dec.loc[some, "decided_accuracy"] <= dec.loc[some, "decided_accuracy_ci95_high"] + 1e-12).all()
    assert dec.loc[~some, "decided_accuracy"].isna().all()
    np.testing.assert_allclose(dec["decided_gap"], dec["decided_accuracy"] - dec["threshold"])
    np.testing.assert_allclose(dec["eps_saved"], 4 - dec["mean_eps"])
    np.testing.assert_allclose(dec["difference"], dec["accuracy"] - dec["all_eps_accuracy"], atol=1e-12)
    for _, g in dec.groupby(["posterior", "strategy"]):  # a higher threshold decides fewer trials, later
        g = g.sort_values("threshold")
        assert g["decided_share"].is_monotonic_decreasing and g["mean_eps"].is_monotonic_increasing
    active, random = dec[dec["strategy"] == "active"], dec[dec["strategy"] == "random"]
    assert random["active_minus_random"].isna().all() and active["active_minus_random"].notna().all()
    merged = active.merge(random, on=["posterior", "threshold"], suffixes=("", "_r"))
    np.testing.assert_allclose(merged["active_minus_random"], merged["accuracy"] - merged["accuracy_r"], atol=1e-12)
    np.testing.assert_allclose(merged["active_minus_random_eps"], merged["mean_eps"] - merged["mean_eps_r"])


def test_stop_outcomes_stops_at_the_first_confident_ep():
    top = np.array([[0.3, 0.95, 0.99], [0.2, 0.4, 0.6], [0.91, 0.5, 0.99]])
    correct = np.array([[0, 1, 1], [0, 0, 1], [1, 0, 0]])
    seconds = np.array([[1.0, 3.0, 6.0], [2.0, 3.0, 6.0], [3.0, 5.0, 6.0]])
    out = stop_outcomes(top, correct, seconds, 0.9)
    np.testing.assert_array_equal(out, [[1, 1, 2, 3.0], [0, 1, 3, 6.0], [1, 1, 1, 3.0]])


@pytest.mark.slow
@pytest.mark.realdata
def test_one_real_phac2_split(data_dir, monkeypatch):
    from tzsl.features import dataset_features

    monkeypatch.delenv("TZSL_CACHE_DIR", raising=False)
    fs = dataset_features("phac2-penn", data_dir=data_dir)
    split = random_object_splits(fs.attributes, n_test=10, n_splits=1, random_state=0)[0]
    res = evaluate_split(fs, split, seed=0, update="dap", cv=3, n_samples=32,
                         tempering=ActiveTouchStudy().methods.tempering)
    assert res["eps"] == EPS
    n = len(res["objects"])
    assert n == 100 and set(res["objects"]) == set(split.test_objects)
    for s in ("active", "random", "paper", "best_fixed_train"):
        assert res["correct"][s].shape == (n, 4)
    # after all four EPs every order sees the same evidence, so the accuracies agree
    finals = {s: res["correct"][s][:, -1].mean() for s in res["orders"]}
    assert max(finals.values()) - min(finals.values()) < 0.05
    assert res["correct"]["active"][:, -1].mean() > 1.5 / res["n_classes"]  # above chance with all EPs


TINY_ACTIVE = """
study = "active-touch"
[dataset]
data_dir = "{data_dir}"
[methods]
cv = 2
n_samples = 8
thresholds = [0.9]
n_boot = 50
[splits]
kinds = ["random"]
n_splits = 1
[hand]
seeds = [0]
n_sequences = 2
max_grasps = 2
cv = 2
[compute]
progress = false
"""


@pytest.mark.slow
@pytest.mark.realdata
def test_tzsl_run_active_touch_writes_every_table(tmp_path, data_dir, monkeypatch):
    from tzsl.studies.engine import run_experiment

    monkeypatch.delenv("TZSL_CACHE_DIR", raising=False)
    path = tmp_path / "active.toml"
    path.write_text(TINY_ACTIVE.format(data_dir=data_dir))
    results, run = run_experiment(path, out=tmp_path / "out")
    written = {p.name for p in (tmp_path / "out").iterdir()}
    assert written == {"active_touch.csv", "active_touch_curves.csv", "active_touch_stop.csv", "active_touch.png",
                       "active_touch_decided.csv", "active_touch_stopping.png",
                       "active_touch_hand.csv", "active_touch_hand_stop.csv", "active_touch_hand.png", "manifest.json"}
    assert set(run.tables) == {n.removesuffix(".csv") for n in written if n.endswith(".csv")}
    assert run.record["hand"]["hand_data"] == "simulated"
    assert (pd.read_csv(tmp_path / "out" / "active_touch_hand.csv")["data"] == "simulated").all()
