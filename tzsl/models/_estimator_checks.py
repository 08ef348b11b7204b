"""What ``sklearn.utils.estimator_checks.check_estimator`` is run on, and the checks left out.

:func:`tzsl.models.all_estimators` lists every public estimator. Each one that takes a 2-D
feature matrix in ``fit(X, y)`` is held to ``check_estimator`` on the instance of
:func:`check_instance` (small grids so the suite stays fast), except for the checks in
:data:`EXPECTED_FAILED_CHECKS` (at most 3 per estimator, each with its reason). Estimators that
take something else are in :data:`NOT_CHECKED` with the reason and are held to the same
contract (parameter validation, clone, get_params) by their own tests.
"""

from __future__ import annotations

from sklearn.base import BaseEstimator

__all__ = ["EXPECTED_FAILED_CHECKS", "NOT_CHECKED", "check_instance"]

#: Estimators outside ``check_estimator``, with the reason.
NOT_CHECKED: dict[str, str] = {
    "AttributeClassifierBank": "takes per-sensor features (n_trials, n_sensors, n_features); its "
    "per-(attribute, sensor) AttributeSVM passes check_estimator",
    "MultiLabelAttributeClassifier": "takes per-sensor features (n_trials, n_sensors, n_features); "
    "its links are AttributeSVMs, which pass check_estimator",
    "DeepAttributeEmbedding": "takes frame sequences (n, frames, H, W, C); tested in tests/models/test_deep.py",
    "PerEPAttributeModel": "takes per-sensor features (n_trials, n_sensors, n_features) split into EP "
    "column blocks by feature name; its per-EP LogisticAttribute passes check_estimator; tested in "
    "tests/models/test_active_touch.py",
    "HandDAPClassifier": "takes the packed grasp layout and a class-attribute DataFrame in fit(X, y, K); "
    "tested in tests/models/test_hand_dap.py",
}

#: ``{estimator name: {check name: reason}}``; at most 3 per estimator.
EXPECTED_FAILED_CHECKS: dict[str, dict[str, str]] = {}

_SMALL_SVM = {"n_C": 2, "n_gamma": 2, "n_draws": 2, "cv": 3}


def check_instance(name: str, cls: type) -> BaseEstimator:
    """The instance ``check_estimator`` runs on: defaults, or small grids where fits are slow.

    Parameters
    ----------
    name : str
        Name from :func:`tzsl.models.all_estimators`.
    cls : type

    Returns
    -------
    estimator
    """
    from tzsl.models import ESZSL, CompatibilityRule, ZeroShotClassifier  # noqa: PLC0415 (the package imports us)

    if name == "AttributeSVM":
        return cls(**_SMALL_SVM, random_state=0)
    if name == "LinearAttribute":  # robust weighting exercises every fit path the other options use
        return cls(weighting="robust", robust_rounds=2, cv=3, random_state=0)
    if name == "EmbeddingZSL":  # the checks' data have 2-3 classes: too few to hold one out
        return cls(early_stopping=False, max_iter=50, random_state=0)
    if name == "ESZSLCV":  # class-grouped CV needs >= 4 classes, the checks' data have 2-3:
        return cls(gammas=(0.5,), lams=(2.0,))  # one pair, fitted without CV (the CV has its own tests)
    if name == "ScalableAttributeClassifier":
        return cls(n_gamma=2, n_C=2, n_components=32, random_state=0)
    if name in ("ALE", "SJE", "DeViSE"):  # few SGD epochs: the checks test the contract, not convergence
        return cls(n_epochs=3, random_state=0)
    if name == "ScoreEnsembleZSL":  # DAP needs 0/1 attributes and ESZSLCV/SAECV >= 4 classes: fixed ridges
        return cls(methods=({"name": "eszsl", "gammas": (0.5,), "lams": (2.0,)}, {"name": "embedding", "lam": 1.0,
                   "early_stopping": False, "max_iter": 50}), random_state=0)
    if name == "ZeroShotClassifier":
        return cls(attribute_model=ESZSL(), decision_rule=CompatibilityRule(), random_state=0)
    if name == "CalibratedZeroShotClassifier":
        return cls(estimator=ZeroShotClassifier(attribute_model=ESZSL(), decision_rule=CompatibilityRule(),
                                                random_state=0), random_state=0)
    return cls()
