"""The method registry: built-in methods, a toy method registered in one line, all_estimators()."""

from __future__ import annotations

import importlib
import inspect
import pkgutil

import numpy as np
import pytest
from sklearn.base import BaseEstimator
from sklearn.utils.validation import check_is_fitted, validate_data

import tzsl.models
from tzsl.exceptions import ConfigError
from tzsl.models import (
    ESZSLCV,
    AttributeClassifierBank,
    DAPRule,
    DecisionRule,
    NearestAttributeRule,
    ZeroShotClassifier,
    all_estimators,
    available_methods,
    build_method,
    get_method,
    method_aliases,
    register_method,
    unregister_method,
)
from tzsl.models.calibration import MAX_CALIBRATION_TRIALS
from tzsl.models.protocol import training_classes


@pytest.fixture
def toy_method():
    @register_method("toy-ncm", family="embedding", paper="a test", decision_rule=NearestAttributeRule,
                     description="nearest class mean -> its attribute row")
    class NearestClassMeanAttributes(BaseEstimator):
        """Toy attribute model: the attribute row of the nearest training-class mean."""

        score_kind = "embedding"

        def __init__(self, *, shrink=0.0):
            self.shrink = shrink

        def fit(self, X, A, groups=None):
            X, A = validate_data(self, X, A, multi_output=True)
            self.rows_, y = training_classes(np.asarray(A, float).reshape(len(X), -1), "toy", groups)
            self.means_ = np.stack([X[y == c].mean(axis=0) for c in range(len(self.rows_))])
            return self

        def decision_function(self, X):
            check_is_fitted(self)
            X = validate_data(self, X, reset=False)
            d = ((X[:, None, :] - self.means_[None]) ** 2).sum(-1)
            return (1 - self.shrink) * self.rows_[d.argmin(axis=1)] + self.shrink * 0.5

    yield NearestClassMeanAttributes
    unregister_method("toy-ncm")


def test_toy_method_fits_and_predicts_through_the_registry(toy_method):
    assert "toy-ncm" in available_methods()
    method = get_method("toy-ncm")
    assert method.attribute_model is toy_method and method.parameters() == {
        "shrink": 0.0, "metric": "sqeuclidean", "random_state": None, "calibration": "temperature",
        "calibration_folds": 3, "calibration_max_trials": MAX_CALIBRATION_TRIALS, "calibration_refit": "pinned"}
    rng = np.random.default_rng(0)
    rows = np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 0], [0, 1, 1]], float)
    y = np.repeat(np.arange(5), 10)
    X = rows[y] @ rng.normal(size=(3, 4)) * 3 + 0.2 * rng.normal(size=(50, 4))
    clf = build_method("toy-ncm", shrink=0.1, random_state=0, calibration="none")
    assert isinstance(clf, ZeroShotClassifier)
    clf.fit(X[y < 3], rows[y[y < 3]], y[y < 3])
    # default table: the training classes (clf.class_attributes_)
    np.testing.assert_array_equal(clf.class_attributes_[clf.predict(X[y < 3])], rows[y[y < 3]])
    assert clf.predict(X, rows).shape == (50,)


def test_builtin_methods_and_their_parameters():
    names = available_methods()
    for name in ("dap", "multilabel-dap", "ldap", "eszsl", "embedding", "cnn-lstm"):
        assert name in names
    assert not set(method_aliases()) & set(names)  # dap-avg, dap-max, ...: aliases, not methods
    dap_max = get_method("dap-max")
    params = dap_max.parameters()
    # the SVMs' balanced Platt posteriors pair with the uniform prior (a train prior would correct twice)
    assert "fusion" not in params and "prior" not in params and params["backend"] == "loky"
    # defaults are read from the signatures, not written twice
    iap_params = get_method("iap").parameters()
    assert iap_params["prior"] == inspect.signature(DAPRule.__init__).parameters["prior"].default
    clf = build_method("dap-max", n_jobs=1, random_state=3).estimator  # inside its calibrator
    assert isinstance(clf.attribute_model, AttributeClassifierBank) and clf.attribute_model.random_state == 3
    assert clf.decision_rule.get_params() == {"fusion": "max", "prior": "uni", "eps": 1e-6}
    with pytest.raises(ConfigError, match="fixed"):
        build_method("dap-avg", prior="train")
    eszsl = build_method("eszsl", cv=3, calibration="none")
    assert isinstance(eszsl.attribute_model, ESZSLCV) and eszsl.attribute_model.cv == 3
    assert build_method("ldap").fusion == "ldap"
    with pytest.raises(ConfigError, match="fixed"):
        build_method("dap-max", fusion="avg")
    with pytest.raises(ConfigError, match="unknown parameter"):
        build_method("eszsl", gamma=1.0)
    with pytest.raises(ConfigError, match="unknown method 'nope'"):
        get_method("nope")
    with pytest.raises(ConfigError, match="already registered"):
        register_method("eszsl", family="compatibility", paper="x", attribute_model=ESZSLCV,
                        decision_rule=NearestAttributeRule)


def _room_estimators() -> set[str]:
    """Estimator classes the rooms of tzsl.models list (every subpackage's ``__all__``), read, not typed here."""
    names = set()
    for info in pkgutil.walk_packages(tzsl.models.__path__, "tzsl.models."):
        if info.ispkg:
            room = importlib.import_module(info.name)
            names |= {n for n in room.__all__ if inspect.isclass(cls := getattr(room, n))
                      and issubclass(cls, BaseEstimator) and not issubclass(cls, DecisionRule)}
    return names


def test_all_estimators_lists_public_estimator_classes():
    names = [n for n, _ in all_estimators()]
    assert names == sorted(names)
    # every estimator a room lists, and the protocol's own classifier: a new estimator needs no edit here,
    # only its room's and the package's __all__
    assert set(names) == _room_estimators() | {"ZeroShotClassifier"}
    # the papers' estimators among them
    assert {"AttributeClassifierBank", "AttributeSVM", "ESZSLCV", "EmbeddingZSL", "DeepAttributeEmbedding",
            "HandDAPClassifier", "PerEPAttributeModel"} <= set(names)
    for _, cls in all_estimators():  # keyword-only __init__ everywhere
        params = list(inspect.signature(cls.__init__).parameters.values())[1:]
        assert all(p.kind is p.KEYWORD_ONLY for p in params), cls
        assert isinstance(cls._parameter_constraints, dict) and set(cls._parameter_constraints) == {
            p.name for p in params}, cls
