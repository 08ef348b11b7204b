"""IAP, indirect attribute prediction (Lampert et al. CVPR 2009)."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.model_selection import GridSearchCV, GroupKFold
from sklearn.naive_bayes import GaussianNB
from sklearn.svm import LinearSVC
from sklearn.utils._param_validation import InvalidParameterError

from tzsl.models import ZSLInputError, build_method
from tzsl.models.detectors._iap import IAP, default_iap_classifier


def test_attribute_posteriors_are_class_posterior_weighted_rows(zero_shot_problem):
    p = zero_shot_problem(seed=0)
    model = IAP().fit(p.X_train, p.A_train)
    P = model.predict_proba(p.X_test)
    assert P.shape == (p.X_test.shape[0], p.S.shape[1])
    assert P.min() >= 0.0 and P.max() <= 1.0
    # the same classifier fitted by hand on the training classes (rows of np.unique, in order)
    rows, z = np.unique(p.A_train, axis=0, return_inverse=True)
    clf = default_iap_classifier().fit(p.X_train, z.ravel())
    np.testing.assert_allclose(P, clf.predict_proba(p.X_test) @ rows, atol=1e-10)
    np.testing.assert_array_equal(model.class_attributes_, rows)
    np.testing.assert_array_equal(model.predict(p.X_test), (P >= 0.5).astype(int))
    assert model.score_kind == "probability"


def test_rows_follow_the_classifier_class_order():
    # a classifier that only ever saw classes 1 and 2 of 3 would reorder columns; IAP maps
    # predict_proba columns through classifier_.classes_, so each column meets its own row
    X = np.array([[0.0], [0.1], [5.0], [5.1], [10.0], [10.1]])
    A = np.array([[1, 0], [1, 0], [0, 1], [0, 1], [1, 1], [1, 1]], dtype=float)
    model = IAP(classifier=GaussianNB()).fit(X, A)
    P = model.predict_proba([[0.05], [5.05], [10.05]])
    np.testing.assert_allclose(P, [[1, 0], [0, 1], [1, 1]], atol=1e-6)


def test_recognises_unseen_classes(zero_shot_problem):
    accuracies = []
    for seed in range(3):
        p = zero_shot_problem(seed=seed)
        method = build_method("iap", prior="uni", eps=1e-3).fit(p.X_train, p.A_train)  # IAP + DAP
        pred = method.predict(p.X_test, p.S_test)
        accuracies.append(np.mean(pred == p.y_test))
    # IAP can only express an unseen class through training classes; still far above chance 0.125
    assert np.mean(accuracies) >= 0.7, accuracies


def test_any_probabilistic_classifier_composes(zero_shot_problem):
    p = zero_shot_problem(seed=1)
    model = IAP(classifier=GaussianNB()).fit(p.X_train, p.A_train)
    rows, z = np.unique(p.A_train, axis=0, return_inverse=True)
    expected = GaussianNB().fit(p.X_train, z.ravel()).predict_proba(p.X_test) @ rows
    np.testing.assert_allclose(model.predict_proba(p.X_test), expected)


def test_groups_reach_a_classifier_that_takes_them(zero_shot_problem):
    p = zero_shot_problem(seed=2, per_class=6)
    objects = np.arange(p.X_train.shape[0]) // 3  # two objects per class
    search = GridSearchCV(GaussianNB(), {"var_smoothing": [1e-9, 1e-3]}, cv=GroupKFold(4))
    model = IAP(classifier=search, classifier_groups=True)
    model.fit(p.X_train, p.A_train, groups=objects)
    folds = list(model.classifier_.cv.split(p.X_train, None, objects))
    assert all(not set(objects[tr]) & set(objects[te]) for tr, te in folds)
    assert model.classifier_.best_params_["var_smoothing"] in (1e-9, 1e-3)
    # without classifier_groups the groups are not forced on a classifier that takes none
    IAP().fit(p.X_train, p.A_train, groups=objects)
    with pytest.raises(ValueError, match="groups"):
        IAP(classifier_groups=True).fit(p.X_train, p.A_train, groups=objects)


def test_fit_does_not_change_the_given_classifier(zero_shot_problem):
    p = zero_shot_problem(seed=0)
    clf = GaussianNB()
    model = IAP(classifier=clf).fit(p.X_train, p.A_train)
    assert model.classifier_ is not clf and not hasattr(clf, "classes_")
    assert model.classifier is clf


def test_bad_parameters_raise_invalid_parameter_error():
    X = np.random.default_rng(0).normal(size=(10, 3))
    A = np.eye(2)[np.arange(10) % 2]
    for bad in (LinearSVC(), "logistic", 3):  # LinearSVC has no predict_proba
        with pytest.raises(InvalidParameterError):
            IAP(classifier=bad).fit(X, A)
    with pytest.raises(InvalidParameterError):
        IAP(classifier_groups="yes").fit(X, A)


def test_one_training_class_is_refused():
    X = np.random.default_rng(0).normal(size=(10, 3))
    with pytest.raises(ZSLInputError, match="one class"):
        IAP().fit(X, np.ones((10, 4)))
