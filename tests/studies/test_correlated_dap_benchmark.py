"""experiments/benchmarks/phac2_correlated_dap.py on SIMULATED data (it measures nothing here): its pieces do what
they say."""

from __future__ import annotations

import numpy as np
import pytest

from tests.benchmark_scripts import benchmark_script
from tests.studies.test_phac2_dap import synthetic_features
from tzsl.models import AttributeClassifierBank


@pytest.fixture(scope="module")
def bench():
    with benchmark_script("phac2_correlated_dap.py") as module:  # imports its sibling phac2_detectors_confirm
        yield module


def test_held_out_logits_score_every_trial_even_of_an_attribute_with_two_positive_objects(bench):
    """The failure the first run met: a fold holding out one of 2 positive objects left 1 (the bank refuses 1)."""
    features = synthetic_features(n_objects=24, n_attributes=6, trials=4)
    A = features.attributes.loc[features.objects].to_numpy(dtype=int).copy()
    positives = np.unique(features.objects[A[:, 0] == 1])
    A[:, 0] = np.isin(features.objects, positives[:2]).astype(int)  # attribute 0: exactly 2 positive objects
    S = bench.held_out_logits(AttributeClassifierBank(detector="logistic-c1"), features.X, A, features.objects)
    assert S.shape == A.shape
    assert np.isfinite(S[A[:, 0] == 1, 0]).all()
    mu, fallbacks = bench.class_means(S, A, features.objects, S_fit=np.zeros_like(S))
    assert fallbacks == 0 and mu.shape == (2, A.shape[1]) and (mu[1, 1:] > mu[0, 1:]).all()  # 1:, the encoded ones


def _simulated_logits(rng, K, objects_per_class, trials, shared):
    """Logits of trials of ``K``'s classes: +-1 means, one error shared by all attributes (sd ``shared``), noise 0.5."""
    rows = np.repeat(np.arange(K.shape[0]), objects_per_class * trials)
    objects = np.repeat(np.arange(K.shape[0] * objects_per_class), trials)
    common = shared * rng.normal(size=(objects.max() + 1, 1))[objects]
    S = (2.0 * K[rows] - 1) + common + 0.5 * rng.normal(size=(rows.size, K.shape[1]))
    return S, K[rows], objects, rows


def test_the_correlated_rule_beats_the_diagonal_one_when_errors_are_shared(bench):
    rng = np.random.default_rng(0)
    K_train, K_test = rng.integers(0, 2, size=(40, 12)), rng.integers(0, 2, size=(10, 12))
    S, A, objects, _ = _simulated_logits(rng, K_train, 1, 10, shared=2.0)
    S_test, _, _, y = _simulated_logits(rng, K_test, 1, 10, shared=2.0)
    mu, _ = bench.class_means(S, A, objects, S_fit=S)
    R = bench.residuals(S, A, mu)
    accuracy = {kind: np.mean(bench.gaussian_scores(S_test, K_test, mu, bench.covariance(R, objects, kind)).argmax(1)
                              == y)
                for kind in ("trial", "diagonal")}
    assert accuracy["trial"] > accuracy["diagonal"] + 0.1, accuracy


def test_error_structure_tells_object_effects_from_trial_noise(bench):
    rng = np.random.default_rng(1)
    K = rng.integers(0, 2, size=(30, 8))
    S, A, objects, _ = _simulated_logits(rng, K, 1, 10, shared=3.0)
    shared = bench.error_structure(S, bench.residuals(S, A, np.array([[-1.0] * 8, [1.0] * 8])), A, objects)
    independent = 2.0 * A - 1 + 0.5 * rng.normal(size=S.shape)
    noise = bench.error_structure(independent, independent - (2.0 * A - 1), A, objects)
    assert shared["between_share"] > 0.8 and noise["between_share"] < 0.3
    assert shared["obj_corr"] > 0.8 and abs(noise["obj_corr"]) < 0.2
    assert abs(shared["within_corr"]) < 0.2
    assert shared["error_dispersion"] > 1.5 and 0.7 < noise["error_dispersion"] < 1.3  # errors piling onto trials
