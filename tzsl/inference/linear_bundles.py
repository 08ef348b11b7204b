"""Linear zero-shot models stored as arrays: a bundle that ``tzsl predict`` loads with numpy alone.

A ``"zero-shot"`` bundle (:mod:`tzsl.inference.model_bundles`) whose attribute model is a linear
map of standardised features (ESZSL, SAE, ALE, SJE, DeViSE: their ``linear_map()``) and whose
decision rule compares attribute-space scores with class rows by dot product or distance
(:class:`~tzsl.models.CompatibilityRule`, :class:`~tzsl.models.NearestAttributeRule`) is saved as
an ``.npz`` payload instead of a skops one::

    linear/weights    (n_features, n_attributes) float64
    linear/mean       (n_features,) float64      # the training standardisation (absent: none)
    linear/scale      (n_features,) float64
    rule/name         str: one of LINEAR_RULES
    calibration/...   0-d arrays: the calibrator's record (temperature, how it was fitted); absent: none

Loading it builds a :class:`LinearAttributeModel` and a :class:`LinearRule`, which compute with
the same functions as the estimators (:mod:`tzsl.models.protocol`: ``linear_embedding``,
``compatibility_scores``, ``squared_distances``, ``cosine_similarities``), so the ranking is the
estimator's, without importing scikit-learn (most of a cold ``tzsl predict``). Like every
bundle payload, it runs no code when read (``allow_pickle=False``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from tzsl._scoring import compatibility_scores, cosine_similarities, linear_embedding, squared_distances
from tzsl.exceptions import ConfigError, ModelBundleError

__all__ = ["LINEAR_RULES", "LinearAttributeModel", "LinearRule", "linear_payload", "read_calibration",
           "read_linear_payload", "stored_name"]

#: Decision rules a linear bundle can hold: :class:`~tzsl.models.CompatibilityRule` and the two
#: metrics of :class:`~tzsl.models.NearestAttributeRule`.
LINEAR_RULES: tuple[str, ...] = ("compatibility", "nearest-sqeuclidean", "nearest-cosine")


@dataclass(frozen=True)
class LinearAttributeModel:
    """Attribute-space scores ``((X - mean) / scale) @ weights`` of a linear attribute model.

    Attributes
    ----------
    weights : ndarray of shape (n_features, n_attributes)
    mean, scale : ndarray of shape (n_features,) or None
        The training standardisation (None: features used as they are).
    name : str
        The estimator it was exported from (shown by ``tzsl predict``).
    """

    weights: np.ndarray
    mean: np.ndarray | None
    scale: np.ndarray | None
    name: str = "linear"

    @property
    def n_features_in_(self) -> int:
        return int(self.weights.shape[0])

    def attribute_scores(self, X: np.ndarray) -> np.ndarray:
        """Attribute-space scores of the trials.

        Parameters
        ----------
        X : ndarray of shape (n_trials, n_features)
            Features in the units of training (the bundle's feature schema, ``ndim`` 2).

        Returns
        -------
        ndarray of shape (n_trials, n_attributes)
        """
        X = np.asarray(X, dtype=np.float64)
        if X.ndim != 2 or X.shape[1] != self.n_features_in_:
            raise ConfigError(f"{self.name}: features must have shape (n_trials, {self.n_features_in_}), got {X.shape}")
        return linear_embedding(X, self.weights, self.mean, self.scale)


@dataclass(frozen=True)
class LinearRule:
    """Class scores of attribute-space scores against class rows (one of :data:`LINEAR_RULES`).

    Attributes
    ----------
    name : str
        ``"compatibility"`` (``F K^T``), ``"nearest-sqeuclidean"`` (``-||f - k||^2``) or
        ``"nearest-cosine"`` (cosine similarity).
    n_attributes_ : int
    """

    name: str
    n_attributes_: int

    def decision_function(self, scores: np.ndarray, class_attributes: np.ndarray) -> np.ndarray:
        """Class scores, larger is better.

        Parameters
        ----------
        scores : ndarray of shape (n_trials, n_attributes)
        class_attributes : ndarray of shape (n_classes, n_attributes)

        Returns
        -------
        ndarray of shape (n_trials, n_classes)
        """
        F = np.asarray(scores, dtype=np.float64)
        K = np.asarray(class_attributes, dtype=np.float64)
        if F.ndim != 2 or F.shape[1] != self.n_attributes_ or K.ndim != 2 or K.shape[1] != self.n_attributes_:
            raise ConfigError(f"{self.name} rule: scores {F.shape} and class table {K.shape} must both have "
                              f"{self.n_attributes_} attribute columns")
        if self.name == "compatibility":
            return compatibility_scores(F, K)
        if self.name == "nearest-sqeuclidean":
            return -squared_distances(F, K)
        return cosine_similarities(F, K)


def linear_payload(model: Any, decision_rule: Any, calibration: dict | None = None) -> dict | None:
    """The ``.npz`` payload of a fitted zero-shot model, or None when it is not linear.

    Parameters
    ----------
    model : fitted :class:`~tzsl.models.ZeroShotClassifier` (or another model with ``attribute_scores``)
    decision_rule : fitted DecisionRule
    calibration : dict, optional
        The calibrator's record (scalars), stored beside the arrays.

    Returns
    -------
    dict or None
        The array tree of the module docstring; None when the attribute model has no
        ``linear_map()`` or the rule is not one of :data:`LINEAR_RULES`.
    """
    from tzsl.models import CompatibilityRule, NearestAttributeRule  # noqa: PLC0415 - only when saving

    attribute_model = getattr(model, "attribute_model_", None)
    export = getattr(attribute_model, "linear_map", None)
    if not callable(export) or getattr(attribute_model, "score_kind", None) != "embedding":
        return None
    if type(decision_rule) is CompatibilityRule:
        rule = "compatibility"
    elif type(decision_rule) is NearestAttributeRule:
        rule = f"nearest-{decision_rule.metric}"
    else:
        return None
    arrays = {k: np.asarray(v, dtype=np.float64) for k, v in export().items()}
    payload: dict = {"linear": arrays, "rule": {"name": np.asarray(rule)},
                     "estimator": {"name": np.asarray(type(attribute_model).__name__)}}
    if calibration is not None:
        payload["calibration"] = {k: np.asarray(v) for k, v in calibration.items()}
    return payload


def stored_name(tree: dict, default: str) -> str:
    """The ``estimator/name`` text of an array payload (``default`` when absent or not one text)."""
    group = tree.get("estimator")
    value = np.asarray(group.get("name", "")) if isinstance(group, dict) else np.asarray("")
    return str(value) if value.dtype.kind == "U" and value.ndim == 0 and str(value) else default


def read_calibration(tree: dict, fail: Callable[[str], Exception]) -> dict | None:
    """The calibrator's record of an array payload (``calibration/...``: 0-d arrays), None when absent.

    Raises
    ------
    Exception
        ``fail(problem)`` when the group is not a set of single numbers or texts.
    """
    group = tree.get("calibration")
    if group is None:
        return None
    values = {k: np.asarray(v) for k, v in group.items()} if isinstance(group, dict) else None
    if values is None or any(v.ndim or v.dtype.kind not in "biufU" for v in values.values()):
        raise fail("calibration must hold single numbers or texts")
    return {k: v.item() for k, v in values.items()}


def read_linear_payload(tree: dict, n_attributes: int, where: str) -> tuple[LinearAttributeModel, LinearRule,
                                                                               dict | None]:
    """The model, rule and calibration of a linear bundle's arrays, checked.

    Parameters
    ----------
    tree : dict
        The payload as :func:`tzsl.inference.bundle.load_bundle` returns it (nested dict of arrays).
    n_attributes : int
        The bundle's attribute count (its metadata's ``attribute_names``).
    where : str
        The bundle, for messages.

    Raises
    ------
    ModelBundleError
        Missing or misshapen arrays, an unknown rule (one line naming the bundle).
    """
    def fail(problem: str) -> ModelBundleError:
        return ModelBundleError(f"{where}: linear model arrays: {problem}")

    linear, rule = tree.get("linear"), tree.get("rule")
    if not isinstance(linear, dict) or "weights" not in linear or not isinstance(rule, dict) or "name" not in rule:
        raise fail("the payload needs linear/weights and rule/name")
    weights = np.asarray(linear["weights"])
    if weights.ndim != 2 or weights.shape[1] != n_attributes or weights.dtype.kind != "f":
        raise fail(f"weights of shape {weights.shape} ({weights.dtype}) for {n_attributes} attributes")
    mean, scale = linear.get("mean"), linear.get("scale")
    if (mean is None) != (scale is None):
        raise fail("mean and scale come together")
    if mean is not None and scale is not None and not (np.shape(mean) == np.shape(scale) == (weights.shape[0],)
                                 and np.all(np.asarray(scale) > 0)):
        raise fail(f"mean {np.shape(mean)} and scale {np.shape(scale)} must be ({weights.shape[0]},), scale > 0")
    if not all(np.isfinite(a).all() for a in (weights, mean, scale) if a is not None):
        raise fail("NaN or infinite values")
    name = str(np.asarray(rule["name"]).item())
    if name not in LINEAR_RULES:
        raise fail(f"unknown rule {name!r}; known: {list(LINEAR_RULES)}")
    estimator = stored_name(tree, "linear")
    calibration = read_calibration(tree, fail)
    model = LinearAttributeModel(weights.astype(np.float64), None if mean is None else np.asarray(mean, np.float64),
                                 None if scale is None else np.asarray(scale, np.float64), estimator)
    return model, LinearRule(name, n_attributes), calibration
