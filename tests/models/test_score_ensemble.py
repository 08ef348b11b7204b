"""ScoreEnsembleZSL: mean of trial-wise z-scored class scores of registry methods (synthetic data)."""

from __future__ import annotations

import numpy as np
import pytest

from tzsl.exceptions import ConfigError
from tzsl.models import AttributeSVM, ScoreEnsembleZSL, build_method, get_method
from tzsl.models.protocol import zscore_rows

FAST_EMBEDDINGS = ({"name": "eszsl"}, {"name": "sae"})


def make_zsl(n_objects=16, trials=6, n_sensors=2, n_features=6, n_attributes=8, noise=0.4, seed=0):
    """Objects with distinct 0/1 attribute rows; features of each sensor are linear in the row plus noise.

    Returns X (n, s, d), rows (n_objects, m), objects (n,) with object ``o`` = class ``o``.
    """
    rng = np.random.default_rng(seed)
    rows = np.unique(rng.integers(0, 2, size=(4 * n_objects, n_attributes)), axis=0)
    rows = rows[rng.permutation(len(rows))[:n_objects]]
    W = rng.normal(size=(n_sensors, n_attributes, n_features))
    objects = np.repeat(np.arange(n_objects), trials)
    X = (np.einsum("om,smd->osd", rows.astype(float), W)[objects]
         + noise * rng.normal(size=(objects.size, n_sensors, n_features)))
    return X, rows, objects


def split(X, rows, objects, n_test=4):
    test_objects = np.arange(rows.shape[0] - n_test, rows.shape[0])
    te = np.isin(objects, test_objects)
    return X[~te], rows[objects[~te]], objects[~te], X[te], rows[test_objects], objects[te] - test_objects[0]


def test_zscore_rows():
    S = np.array([[1.0, 2.0, 3.0], [5.0, 5.0, 5.0]])
    Z = zscore_rows(S)
    np.testing.assert_allclose(Z[0], [-np.sqrt(1.5), 0.0, np.sqrt(1.5)])
    np.testing.assert_array_equal(Z[1], 0.0)


def test_recognises_unseen_classes_and_is_the_mean_of_its_members():
    X, rows, objects = make_zsl()
    X_tr, A_tr, g_tr, X_te, K, y = split(X, rows, objects)
    ens = ScoreEnsembleZSL(methods=FAST_EMBEDDINGS, random_state=0).fit(X_tr, A_tr, g_tr)
    assert (ens.predict(X_te, K) == y).mean() >= 0.9  # 4 unseen classes: chance 0.25
    # the ensemble score is exactly the weighted mean of the members' row-z-scored scores
    flat = X_te.reshape(len(X_te), -1)
    members = [zscore_rows(est.decision_function(flat, K)) for est in ens.estimators_]
    np.testing.assert_allclose(ens.decision_function(X_te, K), 0.5 * members[0] + 0.5 * members[1])
    np.testing.assert_allclose(ens.predict_proba(X_te, K).sum(1), 1.0)
    # weights (1, 0) give the first member's predictions
    only = ScoreEnsembleZSL(methods=FAST_EMBEDDINGS, weights=(1.0, 0.0)).fit(X_tr, A_tr, g_tr)
    alone = build_method("eszsl").fit(X_tr.reshape(len(X_tr), -1), A_tr, g_tr)
    np.testing.assert_array_equal(only.predict(X_te, K), alone.predict(flat, K))


def test_default_members_with_dap_on_per_sensor_input():
    X, rows, objects = make_zsl(n_objects=14, seed=2)
    X_tr, A_tr, g_tr, X_te, K, y = split(X, rows, objects)
    small_dap = {"name": "dap-avg", "estimator": AttributeSVM(n_C=2, n_gamma=2, n_draws=1, cv=3)}
    ens = ScoreEnsembleZSL(methods=(small_dap, "eszsl", "sae"), random_state=0).fit(X_tr, A_tr, g_tr)
    assert ens.n_sensors_ == 2 and ens.n_features_in_ == 6
    assert ens.estimators_[0].attribute_model_.n_sensors_ == 2  # DAP kept the sensors apart
    assert (ens.predict(X_te, K) == y).mean() >= 0.9
    with pytest.raises(ValueError, match="sensors"):
        ens.predict(X_te[:, :1], K)


def test_registered_and_bad_parameters():
    method = get_method("ensemble")
    assert method.family == "ensemble" and method.input_ndim == 3
    default = method.parameters()["methods"]
    assert default == ("dap-avg", "eszsl", "sae")  # the registered methods with their defaults (issue 43)
    # balanced Platt posteriors: the train prior would correct twice, so dap-avg fixes the uniform one
    assert get_method("dap-avg").preset["prior"] == "uni"
    X, rows, objects = make_zsl()
    with pytest.raises(ConfigError, match="weights"):
        ScoreEnsembleZSL(methods=FAST_EMBEDDINGS, weights=(1.0,)).fit(X, rows[objects], objects)
    with pytest.raises(ConfigError, match="unknown method"):
        ScoreEnsembleZSL(methods=("nope",)).fit(X, rows[objects], objects)
