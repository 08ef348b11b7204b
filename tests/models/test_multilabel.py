"""MultiLabelAttributeClassifier: a classifier chain producing DAP-ready (n, s, m) posteriors."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from tzsl.exceptions import ConfigError
from tzsl.models import AttributeSVM, DAPRule, MultiLabelAttributeClassifier, ZeroShotClassifier

_spec = importlib.util.spec_from_file_location("_svm_tests", Path(__file__).with_name("test_attribute_svm.py"))
_mod = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_mod)
make_problem, TINY = _mod.make_problem, _mod.TINY


def test_chain_shapes_order_and_inputs():
    X, A, g = make_problem(n_attributes=3)
    ml = MultiLabelAttributeClassifier(estimator=AttributeSVM(**TINY), order=[2, 0, 1], memory=None, random_state=0)
    ml.fit(X, A, g)
    np.testing.assert_array_equal(ml.order_, [2, 0, 1])
    # link t sees the sensor's features plus the t previous attributes
    assert [ml.estimators_[t][0].n_features_in_ for t in range(3)] == [5, 6, 7]
    P = ml.predict_proba(X[:7])
    assert P.shape == (7, 2, 3) and np.all((P >= 0) & (P <= 1))


def test_chain_posteriors_depend_on_earlier_attributes():
    X, A, g = make_problem(n_attributes=3, seed=3)
    ml = MultiLabelAttributeClassifier(estimator=AttributeSVM(**TINY), order=[0, 1, 2], memory=None,
                                       random_state=0).fit(X, A, g)
    P = ml.predict_proba(X)
    # recompute the last link by hand with the chained inputs replaced by zeros: it must differ
    last = ml.estimators_[2][0]
    with_chain = last.predict_proba(np.hstack([X[:, 0, :], P[:, 0, :2]]))[:, 1]
    np.testing.assert_allclose(with_chain, P[:, 0, 2])
    without = last.predict_proba(np.hstack([X[:, 0, :], np.zeros((len(X), 2))]))[:, 1]
    assert not np.allclose(with_chain, without)


def test_random_order_is_seeded_and_dap_ready(tmp_path):
    X, A, g = make_problem(n_attributes=3, n_sensors=1)
    a = MultiLabelAttributeClassifier(estimator=AttributeSVM(**TINY), memory=tmp_path, random_state=4).fit(X, A, g)
    b = MultiLabelAttributeClassifier(estimator=AttributeSVM(**TINY), memory=None, random_state=4).fit(X, A, g)
    np.testing.assert_array_equal(a.order_, b.order_)
    np.testing.assert_array_equal(a.predict_proba(X), b.predict_proba(X))
    # clone refit: from cache
    dap = ZeroShotClassifier(attribute_model=a, decision_rule=DAPRule(prior="uni")).fit(X, A, g)
    K = np.unique(A, axis=0)
    proba = dap.predict_proba(X, K)
    np.testing.assert_allclose(proba.sum(1), 1.0)


def test_bad_order():
    X, A, g = make_problem(n_attributes=3)
    with pytest.raises(ConfigError, match="permutation"):
        MultiLabelAttributeClassifier(estimator=AttributeSVM(**TINY), order=[0, 0, 1], memory=None).fit(X, A, g)
