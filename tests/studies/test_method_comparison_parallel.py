"""The PHAC-2 / zero-shot method comparison runs its (split, method) fits in n_jobs workers (issue 22)."""

from __future__ import annotations

import pandas as pd

from tests.studies.test_phac2_dap import _config, synthetic_features
from tzsl.studies.zero_shot.methods import method_comparison
from tzsl.studies.zero_shot.study import fit_splits, make_splits

METHODS = ({"name": "eszsl"}, {"name": "sae"}, {"name": "embedding", "lam": 1.0}, {"name": "no-such-method"})


def test_parallel_fits_give_the_serial_tables_and_record_failures_alike():
    features = synthetic_features(n_objects=20)
    config = _config(n_test=5)
    splits, _ = make_splits(features, "random", config)
    results = fit_splits(features, splits, config)
    serial = method_comparison(features, results, seed=3, methods=METHODS, n_jobs=1)
    parallel = method_comparison(features, results, seed=3, methods=METHODS, n_jobs=2)
    assert serial.keys() == parallel.keys()
    for name, table in serial.items():
        left, right = table.drop(columns=["fit_seconds"], errors="ignore"), parallel[name].drop(
            columns=["fit_seconds"], errors="ignore")
        pd.testing.assert_frame_equal(left, right, check_exact=True, obj=name)
    per_split = serial["methods_per_split"]
    assert per_split["error"].str.contains("no-such-method").sum() == len(splits)  # recorded, not raised


def test_a_plugin_method_is_fitted_in_this_process_where_it_is_registered():
    from tests.studies.test_method_wiring import NearestMeanAttributes
    from tzsl.models import NearestAttributeRule, register_method, unregister_method
    from tzsl.studies.zero_shot.methods import _is_builtin

    register_method("plugin-x", family="embedding", paper="test only", attribute_model=NearestMeanAttributes,
                    decision_rule=NearestAttributeRule, description="test")
    try:
        assert not _is_builtin({"name": "plugin-x"})
        features = synthetic_features(n_objects=20)
        config = _config(n_test=5, n_splits=1)
        results = fit_splits(features, make_splits(features, "random", config)[0], config)
        table = method_comparison(features, results, methods=({"name": "plugin-x"},), n_jobs=2)["methods_per_split"]
        fitted = table[~table["split"].isin(["mean", "std"])]
        assert fitted["error"].fillna("").eq("").all() and fitted["plugin-x"].notna().all()
    finally:
        unregister_method("plugin-x")
    assert _is_builtin({"name": "eszsl"}) and not _is_builtin({"name": "no-such-method"})


def test_every_random_part_of_a_study_estimator_is_seeded():
    """ESZSL, SAE and IAP have no random step of their own, but their calibrator deals pseudo-unseen
    folds at random: a study seeds every ``random_state`` of what it fits, so a rerun reproduces
    every posterior (before, those three were left unseeded and their ECE moved between runs)."""
    from tzsl.models import available_methods, get_method
    from tzsl.studies.comparison.method_runs import study_estimator

    for name in available_methods():
        if get_method(name).input_kind != "features":
            continue
        params = study_estimator({"name": name}, 7).get_params(deep=True)
        unseeded = [k for k, v in params.items() if k.endswith("random_state") and v is None]
        assert not unseeded, (name, unseeded)


#: BLAS threads each fit of :class:`_ThreadCounting` saw (tests only).
_SEEN_THREADS: list[int] = []


def test_the_methods_fits_in_this_process_use_one_blas_thread():
    """Many small fits: threaded BLAS only spins (tzsl._parallel.one_blas_thread), so the comparison fits in one
    BLAS thread in this process too (joblib's workers have one already), whatever the caller's limit."""
    from threadpoolctl import threadpool_info, threadpool_limits

    from tests.studies.test_method_wiring import NearestMeanAttributes
    from tzsl.models import NearestAttributeRule, register_method, unregister_method

    class _ThreadCounting(NearestMeanAttributes):
        def fit(self, X, Y, groups=None):
            _SEEN_THREADS.extend(lib["num_threads"] for lib in threadpool_info() if lib["user_api"] == "blas")
            return super().fit(X, Y, groups)

    register_method("plugin-threads", family="embedding", paper="test only", attribute_model=_ThreadCounting,
                    decision_rule=NearestAttributeRule, description="test")
    try:
        features = synthetic_features(n_objects=20)
        config = _config(n_test=5, n_splits=1)
        results = fit_splits(features, make_splits(features, "random", config)[0], config)
        _SEEN_THREADS.clear()
        with threadpool_limits(limits=2, user_api="blas"):
            method_comparison(features, results, methods=({"name": "plugin-threads"},), n_jobs=1)
    finally:
        unregister_method("plugin-threads")
    assert _SEEN_THREADS and set(_SEEN_THREADS) == {1}



def test_long_fits_are_dispatched_first_and_the_order_does_not_change_a_table(monkeypatch):
    """Every method but the ensembles, then the ensembles (whose members can be those methods' fits); in each
    phase the per-sensor attribute-bank methods and ensembles, then the feature methods (each in split order):
    the long fits start first, so no worker runs one alone at the end; dispatching in the listed order instead
    gives the same tables."""
    from tzsl.studies.zero_shot import methods as comparison

    specs = [{"name": "eszsl"}, {"name": "dap-avg-logistic"}, {"name": "ensemble"}, {"name": "no-such-method"}]
    phases = comparison._phases([(split, spec) for split in (1, 0) for spec in specs])
    assert [[(split, spec["name"]) for split, spec in phase] for phase in phases] == [
        [(0, "dap-avg-logistic"), (1, "dap-avg-logistic"), (0, "eszsl"), (0, "no-such-method"), (1, "eszsl"),
         (1, "no-such-method")], [(0, "ensemble"), (1, "ensemble")]]
    assert comparison._phases([(0, {"name": "eszsl"})]) == [[(0, {"name": "eszsl"})]]  # no empty phase
    features = synthetic_features(n_objects=20)
    config = _config(n_test=5, n_splits=2)
    results = fit_splits(features, make_splits(features, "random", config)[0], config)
    methods = ({"name": "eszsl"}, {"name": "dap-avg-logistic"}, {"name": "sae"})
    longest_first = method_comparison(features, results, seed=3, methods=methods, n_jobs=2)
    monkeypatch.setattr(comparison, "_longest_first", lambda job: 0)  # a stable sort: the listed order
    listed = method_comparison(features, results, seed=3, methods=methods, n_jobs=2)
    assert longest_first.keys() == listed.keys()
    for name, table in longest_first.items():
        pd.testing.assert_frame_equal(table.drop(columns=["fit_seconds"], errors="ignore"),
                                      listed[name].drop(columns=["fit_seconds"], errors="ignore"),
                                      check_exact=True, obj=name)
