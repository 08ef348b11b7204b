"""DAP's detector is a parameter of one method, ``dap``; the older names are aliases (issue 43, item 3).

An alias names one configuration of a method: it builds the same estimator as its canonical entry
(``method_aliases()[alias]``), predicts the same, keeps the parameters it fixes fixed and leaves the others
settable; ``available_methods()`` lists methods only. The values a string parameter takes are read from
the estimators' parameter constraints and checked when a method is built.
"""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.base import BaseEstimator

from tzsl.exceptions import ConfigError
from tzsl.models import (
    DAP_METHOD,
    AttributeClassifierBank,
    DAPRule,
    available_methods,
    build_method,
    get_method,
    method_aliases,
    register_alias,
    register_method,
    unregister_method,
)
from tzsl.models.detectors import DETECTORS
from tzsl.value_lists import FUSIONS, PRIORS

#: Every name a DAP configuration was registered under before it became a parameter.
OLD_NAMES = ("dap-avg", "dap-max", "dap-avg-logistic", "dap-avg-linear-svm", "dap-avg-robust-logistic",
             "dap-avg-logistic-c1")


def _params(estimator) -> dict:
    """``get_params(deep=True)`` without the nested estimator objects (compared through their own params)."""
    return {k: v for k, v in estimator.get_params(deep=True).items() if not isinstance(v, BaseEstimator)}


def _toy(seed: int = 0):
    """Six classes of three attributes (the first four each attribute's two positives and negatives), two
    sensors, trials that follow their class's attributes."""
    rng = np.random.default_rng(seed)
    rows = np.array([[1, 0, 1], [0, 1, 0], [1, 1, 0], [0, 0, 1], [0, 1, 1], [1, 0, 0]], float)
    y = np.repeat(np.arange(6), 8)
    X = np.stack([rows[y] * 2 + rng.normal(0, 0.5, (48, 3)) + k for k in range(2)], axis=1)
    return X, rows, y


def test_dap_is_one_method_and_the_old_names_are_its_aliases():
    assert DAP_METHOD in available_methods()
    assert not set(OLD_NAMES) & set(available_methods())
    aliases = method_aliases()
    assert set(OLD_NAMES) <= set(aliases)
    for name in OLD_NAMES:
        entry = aliases[name]
        assert entry["name"] == DAP_METHOD and entry["prior"] == "uni"
        method = get_method(name)
        assert method.alias_of == DAP_METHOD and method.name == name and method.input_ndim == 3
        assert dict(method.preset) == {k: v for k, v in entry.items() if k != "name"}
    assert aliases["dap-avg-logistic-c1"] == {"name": "dap", "detector": "logistic-c1", "fusion": "avg",
                                              "prior": "uni"}


@pytest.mark.parametrize("alias", OLD_NAMES)
def test_an_alias_builds_the_estimator_of_its_canonical_entry(alias):
    entry = dict(method_aliases()[alias])
    name = entry.pop("name")
    built, canonical = build_method(alias, random_state=3), build_method(name, random_state=3, **entry)
    assert _params(built) == _params(canonical) and repr(built) == repr(canonical)


def test_dap_defaults_are_the_papers_dap_avg():
    """``dap`` without parameters is ``dap-avg``: the paper's RBF-SVM detectors, AVGDAP, the uniform prior."""
    params = get_method("dap").parameters()
    assert (params["detector"], params["fusion"], params["prior"]) == ("rbf-svm", "avg", "uni")
    assert _params(build_method("dap")) == _params(build_method("dap-avg"))
    # the uniform prior is the method's default, not DAPRule's (whose default IAP keeps)
    assert DAPRule().prior != "uni" and get_method("iap").parameters()["prior"] == DAPRule().prior


@pytest.mark.parametrize(("alias", "fixed"), [("dap-avg-logistic-c1", {}), ("dap-max", {"detector": "logistic-c1"})])
def test_an_alias_and_its_canonical_form_predict_the_same(alias, fixed):
    X, rows, y = _toy()
    train = y < 4
    entry = {**method_aliases()[alias], **fixed}
    name = entry.pop("name")
    by_alias = build_method(alias, calibration="none", random_state=0, n_jobs=1, **fixed)
    by_name = build_method(name, calibration="none", random_state=0, n_jobs=1, **entry)
    for clf in (by_alias, by_name):
        clf.fit(X[train], rows[y[train]], y[train])
    np.testing.assert_array_equal(by_alias.decision_function(X, rows), by_name.decision_function(X, rows))
    np.testing.assert_array_equal(by_alias.predict(X, rows), by_name.predict(X, rows))
    assert by_alias.decision_rule.fusion == (entry["fusion"])


def test_an_alias_keeps_what_it_fixes_and_leaves_the_rest_settable():
    with pytest.raises(ConfigError, match=r"\['fusion'\] are fixed"):
        build_method("dap-max", fusion="avg")
    with pytest.raises(ConfigError, match=r"\['detector'\] are fixed"):
        build_method("dap-avg-logistic", detector="rbf-svm")
    assert "detector" in get_method("dap-max").parameters()  # dap-max names a fusion, not a detector
    assert _params(build_method("dap-max", detector="auto")) == _params(
        build_method("dap", detector="auto", fusion="max"))


def test_string_values_are_read_from_the_constraints_and_checked_at_build():
    options = get_method("dap").options()
    assert options["detector"] == tuple(sorted(DETECTORS))  # AttributeClassifierBank's constraint
    assert options["fusion"] == tuple(sorted(FUSIONS)) and options["prior"] == tuple(sorted(PRIORS))
    assert AttributeClassifierBank._parameter_constraints["detector"][0].options == set(DETECTORS)
    with pytest.raises(ConfigError) as caught:
        build_method("dap", detector="svm")
    assert str(caught.value) == ("method 'dap': detector = 'svm' is not one of auto, linear-svm, logistic, "
                                 "logistic-c1, rbf-svm, robust-logistic")
    with pytest.raises(ConfigError, match="fusion = 'mean' is not one of avg, max"):
        build_method("dap", fusion="mean")
    assert get_method("dap").value_problems({"prior": [0.5, 0.5], "detector": "logistic"}) == {}  # an array prior


def test_register_alias_refuses_what_it_cannot_name(toy_rule_method):
    with pytest.raises(ConfigError, match="a method has that name"):
        register_alias("eszsl", "dap", preset={})
    with pytest.raises(ConfigError, match="'no-such' is not a registered method"):
        register_alias("toy-alias", "no-such", preset={})
    with pytest.raises(ConfigError, match="already registered"):
        register_alias("dap-max", "dap", preset={"fusion": "max"})
    with pytest.raises(ConfigError, match="not settable"):
        register_alias("toy-alias", "dap", preset={"gamma": 1.0})
    with pytest.raises(ConfigError, match="is not one of"):
        register_alias("toy-alias", "dap", preset={"detector": "svm"})
    with pytest.raises(ConfigError, match=r"unknown method 'nope'.*aliases: \[.*'dap-avg'"):
        get_method("nope")
    register_alias("toy-max", toy_rule_method, preset={"fusion": "max"})
    assert method_aliases()["toy-max"] == {"name": toy_rule_method, "fusion": "max"}
    with pytest.raises(ConfigError, match="is an alias of"):
        register_method("toy-max", family="attribute-classifier", paper="x",
                        attribute_model=AttributeClassifierBank, decision_rule=DAPRule)
    unregister_method(toy_rule_method)  # its aliases go with it
    assert "toy-max" not in method_aliases()


@pytest.fixture
def toy_rule_method():
    name = "toy-dap"
    register_method(name, family="attribute-classifier", paper="a test", attribute_model=AttributeClassifierBank,
                    decision_rule=DAPRule, input_ndim=3)
    yield name
    unregister_method(name)
