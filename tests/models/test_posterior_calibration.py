"""A temperature fitted on pseudo-unseen training classes (issue 21, items 2 and 5).

SIMULATED data: classes with random attribute rows, features a noisy image of the rows. A
method is made over-confident on purpose (its posterior raised to a power); the calibrator must
find a temperature above 1 on the training classes alone and bring the ECE on unseen classes
down, without changing a single prediction.
"""

from __future__ import annotations

import numpy as np
from scipy.special import softmax
from sklearn.base import BaseEstimator, clone

from tzsl.datasets import synthetic_dataset_arrays
from tzsl.evaluation import expected_calibration_error, top_label
from tzsl.models import AttributeSVM, TemperatureCalibratedZSL, build_method, fit_temperature


class Overconfident(BaseEstimator):
    """A zero-shot method whose posterior is raised to ``power`` (over-confident on purpose)."""

    def __init__(self, estimator=None, power: float = 4.0):
        self.estimator = estimator
        self.power = power

    def fit(self, X, Y, groups=None):
        self.estimator_ = clone(self.estimator).fit(X, Y, groups)
        return self

    def predict_proba(self, X, class_attributes):
        P = self.estimator_.predict_proba(X, class_attributes) ** self.power
        return P / P.sum(axis=1, keepdims=True)

    def predict(self, X, class_attributes):
        return self.estimator_.predict(X, class_attributes)


def _data(seed: int = 0):
    K, cls, X = synthetic_dataset_arrays(480, n_classes=40, n_attributes=12, n_sensors=1, n_features=10,
                                         noise=1.0, seed=seed)
    return K, cls, X[:, 0, :]


def test_fit_temperature_recovers_a_known_temperature():
    rng = np.random.default_rng(1)
    logits = 2.0 * rng.normal(size=(4000, 5))
    y = np.array([rng.choice(5, p=p) for p in softmax(logits, axis=1)])  # calibrated at T = 1
    sharpened = 3.0 * logits  # = logits / T with T = 1/3: the fit must undo it
    assert abs(fit_temperature([sharpened], [y]) - 3.0) < 0.3


def _split():
    K, cls, X = _data()
    train = cls < 28  # 28 seen classes to fit on, 12 unseen to test on
    unseen = np.unique(cls[~train])
    return K, cls, X, train, unseen, np.searchsorted(unseen, cls[~train])


def test_dap_overconfidence_is_detected_on_training_classes_and_corrected_on_unseen_ones():
    """DAP multiplies attribute posteriors as if independent: over-confident by nature; the
    temperature found on training classes alone lowers the ECE on the unseen ones."""
    K, cls, X, train, unseen, y = _split()
    X3 = X[:, None, :]  # one sensor
    quick = AttributeSVM(n_C=1, n_gamma=1, n_draws=1, cv=3)  # one hyper-parameter pair: a quick fit
    calibrated = TemperatureCalibratedZSL(estimator=build_method("dap-avg", estimator=quick), n_folds=3)
    calibrated.fit(X3[train], K[cls[train]], cls[train])
    assert calibrated.temperature_ > 1.0 and calibrated.n_pseudo_unseen_ == 28  # over-confident: softened
    raw = calibrated.estimator_.predict_proba(X3[~train], K[unseen])
    tempered = calibrated.predict_proba(X3[~train], K[unseen])
    np.testing.assert_allclose(tempered.sum(axis=1), 1.0)
    assert (tempered.argmax(axis=1) == raw.argmax(axis=1)).all()  # no prediction changes
    before = expected_calibration_error(*top_label(raw, y))
    after = expected_calibration_error(*top_label(tempered, y))
    assert after < before


def test_a_method_made_overconfident_on_purpose_gets_the_matching_temperature():
    """Raising a posterior to the power a multiplies its log by a: the fitted T must follow."""
    K, cls, X, train, unseen, y = _split()
    fitted = {power: TemperatureCalibratedZSL(estimator=Overconfident(estimator=build_method("eszsl"), power=power))
              .fit(X[train], K[cls[train]], cls[train]) for power in (1.0, 4.0)}
    assert abs(fitted[4.0].temperature_ / fitted[1.0].temperature_ - 4.0) < 0.1
    sharp = fitted[4.0]
    raw = sharp.estimator_.predict_proba(X[~train], K[unseen])
    tempered = sharp.predict_proba(X[~train], K[unseen])
    np.testing.assert_allclose(tempered, fitted[1.0].predict_proba(X[~train], K[unseen]), atol=1e-3)
    assert (sharp.predict(X[~train], K[unseen]) == sharp.estimator_.predict(X[~train], K[unseen])).all()
    assert expected_calibration_error(*top_label(tempered, y)) <= expected_calibration_error(*top_label(raw, y))


def test_a_study_entry_can_ask_for_tempered_posteriors():
    """``{name = "eszsl", calibration = "temperature"}`` in [methods] compare (issue 21, item 2)."""
    import pytest  # noqa: PLC0415

    from tzsl.experiments.config import method_label  # noqa: PLC0415
    from tzsl.experiments.config._common import methods_ok  # noqa: PLC0415
    from tzsl.experiments.study_methods import study_estimator  # noqa: PLC0415

    specs = methods_ok(["eszsl", {"name": "eszsl", "calibration": "temperature"}])
    assert [method_label(s) for s in specs] == ["eszsl", "eszsl_calibration_temperature"]
    model = study_estimator(specs[1], seed=0)
    assert isinstance(model, TemperatureCalibratedZSL) and not isinstance(study_estimator(specs[0], 0),
                                                                        TemperatureCalibratedZSL)
    with pytest.raises(ValueError, match="the one calibration is 'temperature'"):
        methods_ok([{"name": "sae", "calibration": "isotonic"}])


def test_the_estimator_contract():
    """Outside check_estimator (listed in NOT_CHECKED with the reason): validation, clone, get_params."""
    import pytest  # noqa: PLC0415

    from tzsl.models._validation import ParameterError  # noqa: PLC0415

    model = TemperatureCalibratedZSL(estimator=build_method("eszsl"), n_folds=4, random_state=0)
    assert clone(model).get_params()["n_folds"] == 4 and "estimator__attribute_model" in model.get_params()
    K, cls, X = _data()
    with pytest.raises(ParameterError, match="n_folds"):
        TemperatureCalibratedZSL(estimator=build_method("eszsl"), n_folds=1).fit(X, K[cls], cls)
    with pytest.raises(ParameterError, match="estimator"):
        TemperatureCalibratedZSL().fit(X, K[cls], cls)
