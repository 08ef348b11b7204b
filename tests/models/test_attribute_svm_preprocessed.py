"""AttributeSVM fits on equal features share one preprocessing (fitted preprocessor, Z, distances): same numbers."""

from __future__ import annotations

import numpy as np

from tzsl.models import AttributeSVM
from tzsl.models.detectors import _attribute_svm

TINY = dict(n_C=2, n_gamma=2, n_draws=2, cv=3)


def _problem(seed=0):
    rng = np.random.default_rng(seed)
    groups = np.repeat(np.arange(12), 4)
    X = rng.normal(size=(groups.size, 6)) + np.repeat(rng.normal(size=(12, 6)), 4, axis=0)
    y1 = np.repeat(np.arange(12) % 3 == 0, 4).astype(int)
    y2 = np.repeat(np.arange(12) % 2 == 0, 4).astype(int)
    return X, y1, y2, groups


def test_a_second_attribute_on_the_same_features_reuses_the_preprocessing_with_equal_results():
    X, y1, y2, groups = _problem()
    _attribute_svm._PREPROCESSED.clear()
    first = AttributeSVM(random_state=0, **TINY).fit(X, y1, groups)
    reused = AttributeSVM(random_state=1, **TINY).fit(X, y2, groups)  # same features: preprocessed once
    assert len(_attribute_svm._PREPROCESSED) == 1
    _attribute_svm._PREPROCESSED.clear()
    fresh = AttributeSVM(random_state=1, **TINY).fit(X, y2, groups)
    np.testing.assert_array_equal(reused.predict_proba(X), fresh.predict_proba(X))
    np.testing.assert_array_equal(reused.oof_scores_, fresh.oof_scores_)
    assert reused.preprocessor_ is not first.preprocessor_  # each fit owns its preprocessor
    np.testing.assert_array_equal(reused.train_features_[0], fresh.train_features_[0])


def test_other_features_or_preprocessor_are_not_reused():
    X, y1, _, groups = _problem()
    _attribute_svm._PREPROCESSED.clear()
    AttributeSVM(random_state=0, **TINY).fit(X, y1, groups)
    AttributeSVM(random_state=0, **TINY).fit(X + 1.0, y1, groups)
    from tzsl.features import VariancePCA

    AttributeSVM(preprocessor=VariancePCA(0.9), random_state=0, **TINY).fit(X, y1, groups)
    assert len(_attribute_svm._PREPROCESSED) == 3
