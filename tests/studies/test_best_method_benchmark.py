"""experiments/benchmarks/phac2_best_method.py on a SIMULATED table (it measures nothing here)."""

from __future__ import annotations

import warnings

import pytest

from tests.benchmark_scripts import benchmark_script
from tests.studies.test_phac2_dap import TINY_SVM, synthetic_features


@pytest.fixture(scope="module")
def bench():
    with benchmark_script("phac2_best_method.py") as module:
        yield module


def test_choice_on_selection_numbers_from_confirmation(bench):
    features = synthetic_features(n_objects=24, n_attributes=6)
    run = {"seed": 3, "n_splits": 2, "kinds": bench.KINDS, "methods": [{"name": "eszsl"}], "n_jobs": 1,
           "echo": lambda _: None, "splits": {"n_test": 5}, "svm": dict(TINY_SVM), "compute": {"cache": False}}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        selection = bench.comparison(features, "select", **run)
        confirmation = bench.comparison(features, "confirm", **run)
    assert set(selection["purpose"]) == {"select"} and set(confirmation["purpose"]) == {"confirm"}
    assert set(selection["kind"]) == set(confirmation["kind"]) == {"random", "challenging"}
    decision = bench.decide(selection, confirmation, seed=3).set_index("kind")
    for kind in ("random", "challenging"):
        chosen = decision.loc[kind, "chosen"]
        picked = selection[(selection["kind"] == kind)].set_index("method")["accuracy"]
        assert picked[chosen] == picked.max()
        shown = confirmation[(confirmation["kind"] == kind) & (confirmation["method"] == chosen)].iloc[0]
        assert decision.loc[kind, "accuracy"] == pytest.approx(shown["accuracy"])
    assert "not confirmed on other splits" in decision.loc["challenging", "note"]
    assert decision["beats_reference"].dtype == bool
