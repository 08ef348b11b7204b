"""experiments/benchmarks/phac2_stacked_detectors.py on SIMULATED data (it measures nothing here): its pieces do
what they say."""

from __future__ import annotations

import numpy as np
import pytest

from tests.benchmark_scripts import benchmark_script
from tests.studies.test_phac2_dap import synthetic_features
from tests.study_settings import study_settings
from tzsl.models import AttributeClassifierBank
from tzsl.studies.config import ZeroShotSettings
from tzsl.studies.zero_shot.study import make_splits


@pytest.fixture(scope="module")
def bench():
    with benchmark_script("phac2_stacked_detectors.py") as module:  # imports phac2_correlated_dap and its siblings
        yield module


def _sparse_problem(rng, n_objects=30, trials=5, d=40):
    """Trials of objects whose attribute is read from feature 0 alone; 39 noise features, object offsets on all."""
    label = np.arange(n_objects) % 2
    groups = np.repeat(np.arange(n_objects), trials)
    offsets = rng.normal(size=(n_objects, d))
    X = offsets[groups] + 0.5 * rng.normal(size=(groups.size, d))
    X[:, 0] += 3.0 * label[groups]
    return X, label[groups], groups


def test_sparse_detector_chooses_C_on_objects_and_keeps_few_features(bench):
    X, y, groups = _sparse_problem(np.random.default_rng(0))
    est = bench.SparseLogisticAttribute(random_state=0).fit(X, y, groups)
    assert est.cv_log_loss_.shape == (len(bench.SPARSE_C_GRID),) and np.isfinite(est.cv_log_loss_).all()
    assert est.C_ == bench.SPARSE_C_GRID[int(np.argmin(est.cv_log_loss_))]
    assert est.n_nonzero_ < X.shape[1] // 2  # the signal is one feature: L1 drops most of the 40
    assert est.predict_proba(X).shape == (y.size, 2) and np.mean(est.predict(X) == y) > 0.9
    with pytest.raises(ValueError, match="groups"):
        bench.SparseLogisticAttribute().fit(X, y)


def test_pinned_bank_refits_every_detector_at_its_chosen_C_without_a_search(bench):
    features = synthetic_features(n_objects=24, n_attributes=4, trials=4)
    A = features.attributes.loc[features.objects].to_numpy(dtype=int)
    bank = AttributeClassifierBank(estimator=bench.SparseLogisticAttribute(), solver="exact", memory=False,
                                   random_state=0).fit(features.X, A, features.objects)
    again = bench.pinned(bank).fit(features.X, A)  # no groups: a one-value grid needs none
    for before, after in zip(sum(bank.estimators_, []), sum(again.estimators_, []), strict=True):
        assert after.C_ == before.C_ and np.isnan(after.cv_log_loss_).all()
    np.testing.assert_allclose(again.predict_proba(features.X), bank.predict_proba(features.X), atol=1e-6)


def test_stack_reads_an_attribute_from_another_attributes_detector(bench):
    """Attribute 1 always equals attribute 0; only attribute 0's detector is informative: the stack recovers 1."""
    rng = np.random.default_rng(2)
    n_objects, trials = 40, 6
    groups = np.repeat(np.arange(n_objects), trials)
    a0 = (np.arange(n_objects) % 2)[groups]
    A = np.column_stack([a0, a0, rng.integers(0, 2, n_objects)[groups]])
    S = np.column_stack([3.0 * (2 * a0 - 1), np.zeros_like(a0, dtype=float), np.zeros_like(a0, dtype=float)])
    S += rng.normal(size=S.shape)
    test = rng.integers(0, 2, 200)
    S_test = np.column_stack([3.0 * (2 * test - 1), np.zeros(200), np.zeros(200)]) + rng.normal(size=(200, 3))
    full = bench.stacked(S, A, groups, S_test, own=False)
    own = bench.stacked(S, A, groups, S_test, own=True)
    accuracy = {name: np.mean((r["P_test"][:, 1] >= 0.5) == test) for name, r in (("full", full), ("own", own))}
    assert accuracy["full"] > 0.95 and accuracy["own"] < 0.75, accuracy
    assert full["C"] in bench.STACK_C_GRID and full["P_oof"].shape == A.shape and full["cv_log_loss"].shape == (3,)


def test_one_split_scores_every_method_and_its_dap_is_the_registered_one(bench, tmp_path):
    features = synthetic_features(n_objects=24, n_attributes=6, trials=4)
    split = make_splits(features, "random", study_settings(ZeroShotSettings, "phac2-dap", n_splits=1, n_test=5))[0][0]
    table, info = bench.score_split(features, split, 0, False, tmp_path)
    assert set(table["method"]) == {bench.DETECTOR_METHOD, "stack", "stack-own", "sparse"}
    # the script's DAP on the reference's detectors predicts as the registered method
    assert info["c1_dap_agreement"] == 1.0
    assert (tmp_path / f"{split.name}.npz").exists()
    assert 0.0 <= info["sparse_test_between_share"] <= 1.0 and info["stack_C"] in bench.STACK_C_GRID
