"""Zero-shot model bundles (kind ``"zero-shot"``): written by the train commands, read by ``tzsl predict``.

Every bundle of kind :data:`ZERO_SHOT_KIND` holds the same three things, whatever the method (any
of ``tzsl methods`` that is an attribute model + decision rule, and the hand's
:class:`~tzsl.models.HandDAPClassifier`):

payload, in one of three file kinds (none runs code when read)
    * linear models (ESZSL, SAE, ALE, SJE, DeViSE with their rule): arrays,
      :mod:`tzsl.inference.linear_bundles`;
    * DAP models (an attribute-detector bank + :class:`~tzsl.models.DAPRule`: ``tzsl
      train-attributes`` by default, and the bank's linear detectors): arrays,
      :mod:`tzsl.inference.detector_bundles`;
    * every other model: ``{"model": fitted estimator, "decision_rule": fitted DecisionRule}``
      stored with skops (:mod:`tzsl.inference.skops_bundles`).

    Array payloads load and rank with numpy alone; skops ones import scikit-learn. Each may hold
    ``calibration`` (the temperature and how it was fitted,
    :attr:`tzsl.models.CalibratedZeroShotClassifier.calibration_info_`) when the model was saved
    from a calibrated method; bundles without it predict with the method's own posteriors
    (``tzsl predict`` says "uncalibrated"). ``model.attribute_scores(X)`` gives the attribute
    scores and ``decision_rule`` turns them and a class-attribute table given at predict time into
    class scores (priors, sensor fusion and tie-breaking live there).
metadata (JSON)
    ``method``: the registry name; ``attribute_names``: list of m str, the rule's attribute axis;
    ``input``: the feature schema :mod:`tzsl.inference.predict_inputs` reads inputs with;
    plus provenance (``training_objects``, ``seed``, ``dataset``, ...).

A skops bundle of a model that array payloads can hold (written before they existed) is turned
into the arrays when it is loaded, so it ranks each grasp as fast as a new one (its loading
still imports scikit-learn: re-save it to load fast too).

The deep CNN + LSTM keeps its own bundle kind ``"deep"`` (:mod:`tzsl.inference.deep_bundles`);
:func:`load_predictor` composes it with a :class:`~tzsl.models.NearestAttributeRule`, so it is
predicted the same way.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from tzsl._scoring import tempered_proba
from tzsl.exceptions import ConfigError, ModelBundleError
from tzsl.inference.bundle import load_bundle, read_bundle_header, save_bundle
from tzsl.inference.bundle_kinds import DEEP_KIND, ZERO_SHOT_KIND
from tzsl.inference.detector_bundles import DAPArrayRule, DetectorBank, detector_payload, read_detector_payload
from tzsl.inference.linear_bundles import LinearAttributeModel, LinearRule, linear_payload, read_linear_payload
from tzsl.inference.predict_inputs import INPUT_FORMATS, describe_inputs, feature_schema

__all__ = ["PREDICT_KINDS", "Predictor", "array_payload", "load_predictor", "save_model_bundle",
           "save_zero_shot_bundle"]

#: Bundle kinds ``tzsl predict`` reads as a model + decision rule.
PREDICT_KINDS: tuple[str, ...] = (ZERO_SHOT_KIND, DEEP_KIND)
#: Keys a skops zero-shot payload may hold (``calibration`` is optional).
_PAYLOAD_KEYS = {"model", "decision_rule", "calibration"}
#: Models and rules computed from arrays with numpy alone.
_ARRAY_MODELS = (LinearAttributeModel, DetectorBank)
_ARRAY_RULES = (LinearRule, DAPArrayRule)


# ---------------------------------------------------------------------------- writing
def array_payload(model: Any, decision_rule: Any, calibration: dict | None = None) -> dict | None:
    """The array payload of a fitted model and rule (linear, or detector bank + DAP), None for others."""
    payload = linear_payload(model, decision_rule, calibration)
    return payload if payload is not None else detector_payload(model, decision_rule, calibration)


def save_model_bundle(path: str | Path, model: Any, decision_rule: Any, *, method: str,
                      attribute_names: Sequence[str], input_schema: dict, force: bool = False,
                      calibration: dict | None = None, **extra) -> Path:
    """Write a ``"zero-shot"`` bundle (layout in the module docstring).

    Parameters
    ----------
    path : str or Path
    model : fitted estimator with ``attribute_scores(X)``
    decision_rule : fitted DecisionRule over ``len(attribute_names)`` attributes
    method : str
        Registry name (shown by ``tzsl predict``).
    attribute_names : sequence of str, length m
    input_schema : dict
        The feature schema (see :func:`~tzsl.inference.predict_inputs.feature_schema`).
    force : bool
    calibration : dict, optional
        How the class posteriors are calibrated (``temperature`` > 0 and how it was fitted);
        stored in the payload. None: the method's own posteriors.
    **extra
        JSON-serialisable provenance.
    """
    from tzsl.models import DecisionRule  # noqa: PLC0415 - a fitted model has imported scikit-learn

    if not callable(getattr(model, "attribute_scores", None)):
        raise ConfigError(f"{type(model).__name__} has no attribute_scores(X); it cannot be saved for 'tzsl predict'")
    if not isinstance(decision_rule, DecisionRule) or not hasattr(decision_rule, "n_attributes_"):
        raise ConfigError("decision_rule must be a fitted tzsl.models.DecisionRule")
    names = [str(a) for a in attribute_names]
    if len(names) != decision_rule.n_attributes_:
        raise ConfigError(f"{len(names)} attribute names for a rule over {decision_rule.n_attributes_} attributes")
    metadata = {"method": method, "attribute_names": names, "input": dict(input_schema), **extra}
    if calibration is not None:
        calibration = {k: (v if isinstance(v, str | int) else float(v)) for k, v in calibration.items()}
    payload = array_payload(model, decision_rule, calibration)  # read with numpy alone
    if payload is None:
        payload = {"model": model, "decision_rule": decision_rule}
        if calibration is not None:
            payload["calibration"] = calibration
    return save_bundle(path, payload, kind=ZERO_SHOT_KIND, metadata=metadata, force=force)


def save_zero_shot_bundle(path: str | Path, classifier: Any, features: Any, *, method: str, ndim: int,
                          force: bool = False, **extra) -> Path:
    """Save a fitted :class:`~tzsl.models.ZeroShotClassifier` (or one inside its calibrator, whose
    temperature is saved too) fitted on ``features`` (a :class:`~tzsl.datasets.FeatureSet`,
    attribute columns in order)."""
    from tzsl.models import CalibratedZeroShotClassifier, ZeroShotClassifier  # noqa: PLC0415

    calibration = None
    if isinstance(classifier, CalibratedZeroShotClassifier):
        classifier, calibration = classifier.estimator_, classifier.calibration_info_
    if not isinstance(classifier, ZeroShotClassifier):
        raise ConfigError(f"{type(classifier).__name__} is not an attribute model + decision rule; it cannot be "
                          "saved for 'tzsl predict'")
    return save_model_bundle(path, classifier, classifier.decision_rule_, method=method, calibration=calibration,
                             attribute_names=list(features.attributes.columns),
                             input_schema=feature_schema(features, ndim), force=force,
                             dataset=features.dataset, **extra)


# ---------------------------------------------------------------------------- reading
@dataclass
class Predictor:
    """A loaded bundle: model + decision rule + attribute names + feature schema.

    Attributes
    ----------
    model : fitted estimator with ``attribute_scores(X)``
        Or, for an array payload, a :class:`~tzsl.inference.linear_bundles.LinearAttributeModel`
        or :class:`~tzsl.inference.detector_bundles.DetectorBank`.
    rule : fitted DecisionRule
        Or, for an array payload, a :class:`~tzsl.inference.linear_bundles.LinearRule` or
        :class:`~tzsl.inference.detector_bundles.DAPArrayRule`.
    attribute_names : list of str, length m
    input : dict
        Feature schema (:mod:`tzsl.inference.predict_inputs`).
    metadata : dict
        The bundle's metadata (with ``bundle``: kind, path, ...).
    calibration : dict or None
        The bundle's calibrator (``temperature`` and how it was fitted, see
        :class:`tzsl.models.CalibratedZeroShotClassifier`); None for bundles saved without one.
    """

    model: Any
    rule: Any
    attribute_names: list[str]
    input: dict
    metadata: dict
    calibration: dict | None = None

    @property
    def kind(self) -> str:
        return str(self.metadata.get("bundle", {}).get("kind", ""))

    @property
    def inputs(self) -> str:
        """What the model takes as input files."""
        return describe_inputs(self.input)

    def describe(self) -> str:
        """One line naming the model."""
        inner = getattr(self.model, "attribute_model_", self.model)
        fitted = self.calibration_report()
        calibrated = (f"calibrated (temperature {fitted['temperature']:.3g})" if fitted["calibrated"]
                      else "uncalibrated")
        stored = self.metadata.get("bundle", {}).get("payload_format")
        parts = (f"{self.model.name} + {self.rule.name} rule, as arrays" if isinstance(self.model, _ARRAY_MODELS)
                 else f"{type(inner).__name__} + {type(self.rule).__name__}")
        if stored == "skops" and isinstance(self.model, _ARRAY_MODELS):
            parts += " (read from skops: re-save the model with this tzsl to load it without scikit-learn)"
        return (f"{self.metadata.get('method', self.kind)} ({parts}), "
                f"{len(self.attribute_names)} attributes, {calibrated} posteriors; input: {self.inputs}")

    @property
    def temperature(self) -> float:
        """The calibrator's temperature (1.0 without one)."""
        return float(self.calibration["temperature"]) if self.calibration else 1.0

    def posteriors(self, class_scores: np.ndarray) -> np.ndarray:
        """Class posteriors ``softmax(class_scores / temperature)`` along the last axis (calibrated when the
        bundle is)."""
        return tempered_proba(np.atleast_2d(class_scores), self.temperature).reshape(np.shape(class_scores))

    def calibration_report(self) -> dict:
        """How the posteriors are calibrated: ``calibrated`` (bool), ``temperature`` and the calibrator's record."""
        if not self.calibration:
            return {"calibrated": False, "temperature": 1.0,
                    "reason": "uncalibrated: the bundle holds no calibrator (saved without one, or by an older tzsl)"}
        return {"calibrated": bool(self.calibration.get("fitted", False)), **self.calibration}

    def class_scores(self, scores: np.ndarray, K: np.ndarray) -> np.ndarray:
        """Class scores (n, c) of attribute scores ``scores`` (n, ...) against the classes ``K`` (c, m)."""
        return self.rule.decision_function(scores, K)


def _where(metadata: dict) -> str:
    return metadata.get("bundle", {}).get("path", "model bundle")


def _checked(payload: Any, metadata: dict) -> Predictor:
    where = _where(metadata)
    if not (isinstance(payload, dict) and {"model", "decision_rule"} <= set(payload) <= _PAYLOAD_KEYS):
        raise ModelBundleError(f"{where}: a zero-shot bundle holds {{'model', 'decision_rule'}} and optionally "
                               f"'calibration', found "
                               f"{sorted(payload) if isinstance(payload, dict) else type(payload).__name__}")
    model, rule, calibration = payload["model"], payload["decision_rule"], payload.get("calibration")
    if calibration is not None:
        t = calibration.get("temperature") if isinstance(calibration, dict) else None
        if not (isinstance(t, float | int) and np.isfinite(t) and t > 0):
            raise ModelBundleError(
                f"{where}: the calibration is not a dict with a positive temperature ({calibration!r})")
    if not callable(getattr(model, "attribute_scores", None)):
        raise ModelBundleError(f"{where}: the model ({type(model).__name__}) has no attribute_scores(X)")
    if not isinstance(rule, _ARRAY_RULES):
        from tzsl.models import DecisionRule  # noqa: PLC0415 - estimator payloads import scikit-learn anyway

        if not isinstance(rule, DecisionRule) or not hasattr(rule, "n_attributes_"):
            raise ModelBundleError(f"{where}: the decision rule is not a fitted DecisionRule ({type(rule).__name__})")
    missing = [k for k in ("attribute_names", "input") if k not in metadata]
    if missing:
        raise ModelBundleError(f"{where}: zero-shot bundle metadata lacks {missing}")
    names, schema = metadata["attribute_names"], metadata["input"]
    if not isinstance(names, list) or len(names) != rule.n_attributes_:
        raise ModelBundleError(f"{where}: metadata attribute_names do not match the rule's "
                               f"{rule.n_attributes_} attributes")
    if not isinstance(schema, dict) or schema.get("format") not in INPUT_FORMATS:
        raise ModelBundleError(f"{where}: metadata input is not a feature schema of format {list(INPUT_FORMATS)}")
    if schema["format"] == "features":
        ok = all(isinstance(schema.get(k), list) for k in ("sensors", "feature_names")) and schema.get("ndim") in (2, 3)
        if not ok:
            raise ModelBundleError(f"{where}: the feature schema needs sensors, feature_names and ndim 2 or 3")
    if schema["format"] == "hand-grasps" and not isinstance(schema.get("feature_params"), dict):
        raise ModelBundleError(f"{where}: the hand-grasps schema needs feature_params")
    return Predictor(model, rule, [str(a) for a in names], schema, metadata, calibration)


def _read_arrays(tree: dict, metadata: dict, where: str) -> dict:
    """``{"model", "decision_rule"[, "calibration"]}`` of an array payload (linear or detectors)."""
    names = metadata.get("attribute_names")
    if not isinstance(names, list):
        raise ModelBundleError(f"{where}: zero-shot bundle metadata lacks ['attribute_names']")
    read = read_detector_payload if "detectors" in tree else read_linear_payload
    model, rule, calibration = read(tree, len(names), where)
    payload: dict[str, Any] = {"model": model, "decision_rule": rule}
    if calibration is not None:
        payload["calibration"] = calibration
    return payload


def load_predictor(path: str | Path, *, trust_pickle: bool = False) -> Predictor:
    """Load a bundle (see :func:`tzsl.inference.bundle.load_bundle`; no code is run) as a :class:`Predictor`.

    ``trust_pickle=True`` also loads old (format version 1) pickle bundles, which can run code:
    only for files whose author you trust.

    Raises
    ------
    ModelBundleError
        Unreadable / corrupt / foreign bundle, a kind ``tzsl predict`` does not read, or a
        payload that is not a model + decision rule.
    """
    kind = read_bundle_header(path).kind  # verified, nothing deserialised yet
    if kind == DEEP_KIND:
        from tzsl.inference.deep_bundles import load_deep_bundle  # noqa: PLC0415 - needs the deep extra
        from tzsl.models import NearestAttributeRule  # noqa: PLC0415

        model = load_deep_bundle(path, trust_pickle=trust_pickle)
        metadata = dict(read_bundle_header(path).metadata)
        metadata["bundle"] = {"kind": kind, "path": str(path)}
        names = metadata.get("attribute_names") or [f"attr_{j}" for j in range(int(model.n_attributes_))]
        rule = NearestAttributeRule().fit(np.asarray(model.class_attributes_, dtype=float))
        return _checked({"model": model, "decision_rule": rule},
                        {**metadata, "method": "cnn-lstm", "attribute_names": list(names),
                         "input": {"format": "frames"}})
    if kind not in PREDICT_KINDS:
        hint = " (a per-EP model: give --eps-done)" if kind == "per-ep" else ""
        raise ModelBundleError(f"{path}: no predictor for bundles of kind {kind!r}{hint} "
                               f"(known: {list(PREDICT_KINDS)}); re-save models of older tzsl versions with this one")
    payload, metadata = load_bundle(path, expected_kind=kind, trust_pickle=trust_pickle)
    if metadata["bundle"]["payload_format"] == "npz":  # arrays: numpy alone
        return _checked(_read_arrays(payload, metadata, str(path)), metadata)
    predictor = _checked(payload, metadata)
    # a skops bundle of a model array payloads hold (written before they did): rank each grasp with the arrays
    arrays = array_payload(predictor.model, predictor.rule, predictor.calibration)
    return predictor if arrays is None else _checked(_read_arrays(arrays, metadata, str(path)), metadata)
