"""DAP models stored as arrays: an attribute-detector bank and its DAP rule, read with numpy alone.

A ``"zero-shot"`` bundle (:mod:`tzsl.inference.zero_shot_bundles`) whose attribute model is an
:class:`~tzsl.models.AttributeClassifierBank` (one detector per (attribute, sensor): the
DAP paper's RBF-SVM, its approximate Nystroem solver, or the linear detectors
``detector="logistic"`` / ``"linear-svm"`` / ``"robust-logistic"``, and ``"logistic-c1"``, whose logistic
regression is stored as a linear score with Platt ``(1, 0)``) and whose rule is a
:class:`~tzsl.models.DAPRule` is saved as an ``.npz`` payload of plain arrays. Each detector is

1. a standardisation ``z = (x - mean) / scale`` of its sensor's features,
2. optionally a PCA projection ``z = z @ components.T - pca_mean @ components.T`` (divided by
   ``whiten``; :class:`~tzsl.features.VariancePCA`),
3. a score: RBF, ``sum_i dual_coef_i exp(-gamma ||z - v_i||^2) + intercept`` over its support
   vectors (an SVM's) or landmarks (the Nystroem model's), or linear, ``z @ coef + intercept``,
4. Platt's sigmoid ``p(a_m = 1 | x_s) = expit(platt_a * score + platt_b)``.

The ``E = n_attributes * n_sensors`` detectors are stacked in the bank's order (attribute-major,
``e = m * n_sensors + s``), padded where their sizes differ, and evaluated together::

    detectors/family      str: "rbf" or "linear"
    detectors/shape       (3,) int: n_attributes, n_sensors, n_features
    detectors/mean, scale (E, n_features)
    detectors/components  (E, k, n_features)   # with a projection only (zero rows pad), with
    detectors/pca_mean    (E, n_features)      # pca_mean and whiten (E, k)
    detectors/vectors     (V, k), dual_coef (V,), n_vectors (E,), gamma (E,)   # "rbf"
    detectors/coef        (E, k)                                                # "linear"
    detectors/intercept   (E,), platt (E, 2)
    rule/name = "dap", rule/fusion, rule/prior ("uni", "train", "test" or "given"),
    rule/prior_values (n_attributes,) for "train" / "given", rule/eps
    calibration/...       0-d arrays: the calibrator's record (absent: none)

The posteriors equal the estimators' own (``predict_proba``) to rounding (tests check 1e-12; the
kernel sums are added in libsvm's order), and the rule ranks them with the DAP functions
:class:`~tzsl.models.DAPRule` calls
(:mod:`tzsl._scoring`). Reading a payload checks every array's shape and values (one line naming
the bundle and the array); like every bundle payload it runs no code (``allow_pickle=False``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from tzsl._scoring import (
    attribute_prior,
    check_attribute_posteriors,
    check_class_attributes,
    dap_log_scores,
    fuse_attribute_posteriors,
)
from tzsl.exceptions import ConfigError, ModelBundleError
from tzsl.inference.linear_bundles import read_calibration, stored_name
from tzsl.value_lists import FUSIONS, PRIORS

__all__ = ["DETECTOR_FAMILIES", "DAPArrayRule", "DetectorBank", "detector_payload", "read_detector_payload"]

#: Score families of a detector payload: RBF kernel expansions (SVM, Nystroem) and linear scores.
DETECTOR_FAMILIES: tuple[str, ...] = ("rbf", "linear")
#: Prior kinds of a stored DAP rule: the rule's own words, and "given" for an explicit prior.
_PRIOR_KINDS = (*PRIORS, "given")
#: Largest (detectors x trials x vectors) block of kernel values computed at once (floats).
_KERNEL_BLOCK = 4_000_000


def _expit(z: np.ndarray) -> np.ndarray:
    """The logistic sigmoid without overflow: ``1 / (1 + exp(-z))``."""
    e = np.exp(-np.abs(z))
    return np.where(z >= 0, 1.0 / (1.0 + e), e / (1.0 + e))


@dataclass(frozen=True)
class DetectorBank:
    """Per-(attribute, sensor) posteriors of a detector bank stored as arrays (module docstring).

    Attributes
    ----------
    family : {"rbf", "linear"}
    n_attributes, n_sensors, n_features : int
    mean, scale : ndarray of shape (E, n_features)
    components : ndarray of shape (E, k, n_features) or None
    pca_offset, whiten : ndarray of shape (E, k) or None
        ``pca_mean @ components.T`` of each detector, and the whitening divisors.
    vectors : ndarray of shape (E, n_max, k) or None
        RBF: each detector's vectors, zero-padded to the longest (their ``dual_coef`` is 0).
    vector_norms : ndarray of shape (E, n_max) or None
        Their squared norms.
    dual_coef : ndarray of shape (E, n_max) or None
    gamma : ndarray of shape (E,) or None
    coef : ndarray of shape (E, k) or None
        Linear scores.
    intercept : ndarray of shape (E,)
    platt : ndarray of shape (E, 2)
    name : str
        The estimator it was exported from (shown by ``tzsl predict``).
    """

    family: str
    n_attributes: int
    n_sensors: int
    n_features: int
    mean: np.ndarray
    scale: np.ndarray
    components: np.ndarray | None
    pca_offset: np.ndarray | None
    whiten: np.ndarray | None
    vectors: np.ndarray | None
    vector_norms: np.ndarray | None
    dual_coef: np.ndarray | None
    gamma: np.ndarray | None
    coef: np.ndarray | None
    intercept: np.ndarray
    platt: np.ndarray
    name: str = "AttributeClassifierBank"

    @property
    def n_features_in_(self) -> int:
        return self.n_features

    def _check(self, X) -> np.ndarray:
        X = np.asarray(X, dtype=np.float64)
        if X.ndim != 3:
            raise ConfigError(f"features must have shape (n_trials, n_sensors, n_features), got {X.shape}")
        if not np.isfinite(X).all():
            t, s, f = np.argwhere(~np.isfinite(X))[0]
            raise ConfigError(f"features hold a non-finite value at trial row {t}, sensor {s}, feature {f}")
        if X.shape[1:] != (self.n_sensors, self.n_features):
            raise ConfigError(f"X has {X.shape[1]} sensors x {X.shape[2]} features; the model was fitted on "
                              f"{self.n_sensors} x {self.n_features}")
        return X

    def _features(self, X: np.ndarray) -> np.ndarray:
        """Each detector's preprocessed features, shape (E, n_trials, k)."""
        sensor = np.tile(np.arange(self.n_sensors), self.n_attributes)
        Z = (X[:, sensor, :].transpose(1, 0, 2) - self.mean[:, None, :]) / self.scale[:, None, :]
        if self.components is None:
            return Z
        assert self.pca_offset is not None and self.whiten is not None  # stored with the components
        Z = Z @ self.components.transpose(0, 2, 1)
        Z -= self.pca_offset[:, None, :]
        return Z / self.whiten[:, None, :]

    def _rbf_scores(self, Z: np.ndarray) -> np.ndarray:
        """``sum_i dual_coef_i exp(-gamma ||z - v_i||^2)`` of (E, n, k) features, in blocks; shape (E, n)."""
        vectors, vector_norms, gamma, dual_coef = self.vectors, self.vector_norms, self.gamma, self.dual_coef
        # an RBF bank stores all four
        assert vectors is not None and vector_norms is not None and gamma is not None and dual_coef is not None
        E, n, _ = Z.shape
        rows = max(1, _KERNEL_BLOCK // max(1, E * vectors.shape[1]))
        norms = vector_norms[:, None, :]
        out = np.empty((E, n))
        for start in range(0, n, rows):
            block = Z[:, start : start + rows]
            D = block @ vectors.transpose(0, 2, 1)  # squared distances as scikit-learn's rbf_kernel
            D *= -2.0
            D += np.einsum("enk,enk->en", block, block)[:, :, None]
            D += norms
            np.maximum(D, 0.0, out=D)
            D *= -gamma[:, None, None]
            np.exp(D, out=D)
            D *= dual_coef[:, None, :]
            # summed vector by vector (cumsum adds in order, unlike sum), as libsvm sums: the SVM's scores
            out[:, start : start + rows] = np.cumsum(D, axis=2)[:, :, -1]
        return out

    def attribute_scores(self, X) -> np.ndarray:
        """Attribute posteriors per sensor, as the bank's ``predict_proba``.

        Parameters
        ----------
        X : array-like of shape (n_trials, n_sensors, n_features)
            Features in the units of training.

        Returns
        -------
        ndarray of shape (n_trials, n_sensors, n_attributes)
            ``p(a_m = 1 | x_s)``.
        """
        X = self._check(X)
        Z = self._features(X)
        if self.family == "linear":
            assert self.coef is not None  # a linear bank stores its coef
            score = np.einsum("enk,ek->en", Z, self.coef)
        else:
            score = self._rbf_scores(Z)
        score += self.intercept[:, None]
        P = _expit(self.platt[:, :1] * score + self.platt[:, 1:])  # (E, n)
        return P.reshape(self.n_attributes, self.n_sensors, -1).transpose(2, 1, 0)


@dataclass(frozen=True)
class DAPArrayRule:
    """:class:`~tzsl.models.DAPRule` as stored values: class scores with the same DAP functions.

    Attributes
    ----------
    fusion : {"avg", "max"}
    prior : {"uni", "train", "test", "given"}
    prior_values : ndarray of shape (n_attributes,) or None
        ``p(a_m = 1)`` for ``"train"`` (the training objects' mean row) and ``"given"``.
    eps : float
    n_attributes_ : int
    """

    fusion: str
    prior: str
    prior_values: np.ndarray | None
    eps: float
    n_attributes_: int

    @property
    def name(self) -> str:
        return f"DAP ({self.fusion} fusion, {self.prior} prior)"

    def decision_function(self, scores, class_attributes) -> np.ndarray:
        """Class log-scores of attribute posteriors against 0/1 class rows (as ``DAPRule.decision_function``).

        Parameters
        ----------
        scores : ndarray of shape (n_trials, n_sensors, n_attributes) or (n_trials, n_attributes)
        class_attributes : ndarray of shape (n_classes, n_attributes), 0/1

        Returns
        -------
        ndarray of shape (n_trials, n_classes)
        """
        K = check_class_attributes(class_attributes, self.n_attributes_)
        P = check_attribute_posteriors(scores)
        if P.shape[-1] != self.n_attributes_:
            raise ConfigError(f"DAPRule: posteriors have {P.shape[-1]} attributes; the rule was fitted on "
                              f"{self.n_attributes_}")
        present, absent = fuse_attribute_posteriors(P, self.fusion)
        prior = self.prior_values if self.prior in ("train", "given") else attribute_prior(self.prior,
                                                                                           class_attributes=K)
        return dap_log_scores(present, K, prior, P_absent=absent, eps=self.eps)


# ----------------------------------------------------------------------------- writing
def _preprocessor_arrays(pre: Any) -> dict | None:
    """``mean``, ``scale`` and (a PCA) ``components``, ``pca_mean``, ``whiten`` of a fitted preprocessor."""
    from sklearn.decomposition import PCA  # noqa: PLC0415 - only when saving
    from sklearn.preprocessing import StandardScaler  # noqa: PLC0415

    from tzsl.features import VariancePCA  # noqa: PLC0415

    scaler, pca = (pre.scaler_, pre.pca_) if type(pre) is VariancePCA else (pre, None)
    if type(scaler) is not StandardScaler or (pca is not None and type(pca) is not PCA):
        return None
    d = scaler.n_features_in_
    out = {"mean": scaler.mean_ if scaler.with_mean else np.zeros(d),
           "scale": scaler.scale_ if scaler.with_std else np.ones(d)}
    if pca is not None:
        whiten = np.ones(pca.components_.shape[0])
        if pca.whiten:
            whiten = np.sqrt(pca.explained_variance_)
            whiten[whiten < np.finfo(whiten.dtype).eps] = np.finfo(whiten.dtype).eps
        out.update(components=pca.components_, pca_mean=pca.mean_, whiten=whiten)
    return out


def _detector_arrays(est: Any) -> dict | None:
    """The arrays of one fitted detector (module docstring), or None when it is not one tzsl can store so."""
    from tzsl.models import (  # noqa: PLC0415
        AttributeSVM,
        LinearAttribute,
        LogisticAttribute,
        ScalableAttributeClassifier,
    )

    if type(est) is LogisticAttribute:  # z-score + logistic regression: its logit is the score, Platt (1, 0)
        scaler, logistic = est.pipeline_[0], est.pipeline_[-1]
        pre = _preprocessor_arrays(scaler) if len(est.pipeline_) == 2 else None
        if pre is None or [int(c) for c in est.classes_] != [0, 1]:
            return None
        return {**pre, "platt": np.array([1.0, 0.0]), "family": "linear", "coef": np.ravel(logistic.coef_),
                "intercept": float(logistic.intercept_[0])}
    pre = _preprocessor_arrays(getattr(est, "preprocessor_", None))
    if pre is None:
        return None
    out = {**pre, "platt": np.asarray(est.platt_, dtype=np.float64)}
    if type(est) is LinearAttribute:
        linear = est.estimator_
        return {**out, "family": "linear", "coef": np.ravel(linear.coef_), "intercept": float(linear.intercept_[0])}
    if type(est) is AttributeSVM:
        if any(svc.kernel != "precomputed" for svc in est.estimators_):
            return None
        vectors = [Z[svc.support_] for svc, Z in zip(est.estimators_, est.train_features_, strict=True)]
        coef = [w * svc.dual_coef_[0] for w, svc in zip(est.estimator_weights_, est.estimators_, strict=True)]
        intercept = sum(float(w * svc.intercept_[0])
                        for w, svc in zip(est.estimator_weights_, est.estimators_, strict=True))
        return {**out, "family": "rbf", "vectors": np.concatenate(vectors), "dual_coef": np.concatenate(coef),
                "gamma": float(est.gamma_), "intercept": intercept}
    if type(est) is ScalableAttributeClassifier and est.feature_map_.kernel == "rbf":
        fm = est.feature_map_
        return {**out, "family": "rbf", "vectors": fm.components_, "dual_coef": fm.normalization_.T @ est.coef_,
                "gamma": float(fm.gamma), "intercept": float(est.intercept_)}
    return None


def _pad(rows: list[np.ndarray], width: int, fill: float = 0.0) -> np.ndarray:
    """Rows of shape (k_e, ...) stacked into (E, width, ...), padded with ``fill``."""
    out = np.full((len(rows), width, *rows[0].shape[1:]), fill)
    for e, row in enumerate(rows):
        out[e, : row.shape[0]] = row
    return out


def _rule_arrays(rule: Any) -> dict:
    prior = rule.prior if isinstance(rule.prior, str) else "given"
    values = {"train": rule.train_prior_, "given": attribute_prior(rule.prior) if prior == "given" else None}
    out = {"name": np.asarray("dap"), "fusion": np.asarray(rule.fusion), "prior": np.asarray(prior),
           "eps": np.asarray(float(rule.eps))}
    if values.get(prior) is not None:
        out["prior_values"] = np.asarray(values[prior], dtype=np.float64)
    return out


def detector_payload(model: Any, decision_rule: Any, calibration: dict | None = None) -> dict | None:
    """The ``.npz`` payload of a fitted DAP model, or None when it cannot be stored as arrays.

    Parameters
    ----------
    model : fitted :class:`~tzsl.models.ZeroShotClassifier`
    decision_rule : fitted DecisionRule
    calibration : dict, optional
        The calibrator's record (scalars), stored beside the arrays.

    Returns
    -------
    dict or None
        The array tree of the module docstring; None unless the attribute model is an
        :class:`~tzsl.models.AttributeClassifierBank` of detectors of one family (with a
        ``StandardScaler`` or ``VariancePCA`` preprocessor) and the rule a :class:`~tzsl.models.DAPRule`.
    """
    from tzsl.models import AttributeClassifierBank, DAPRule  # noqa: PLC0415 - only when saving

    bank = getattr(model, "attribute_model_", None)
    if type(bank) is not AttributeClassifierBank or type(decision_rule) is not DAPRule:
        return None
    found = [_detector_arrays(est) for per_sensor in bank.estimators_ for est in per_sensor]
    rows = [r for r in found if r is not None]
    if len(rows) != len(found) or len({r["family"] for r in rows}) != 1:
        return None
    if len({"components" in r for r in rows}) != 1:
        return None
    family, projected = rows[0]["family"], "components" in rows[0]
    detectors: dict[str, np.ndarray] = {
        "family": np.asarray(family),
        "shape": np.asarray([bank.n_attributes_, bank.n_sensors_, bank.n_features_in_], dtype=np.int64),
        **{k: np.stack([np.asarray(r[k], dtype=np.float64) for r in rows]) for k in ("mean", "scale", "platt")},
        "intercept": np.asarray([r["intercept"] for r in rows], dtype=np.float64),
    }
    width = max(r["components"].shape[0] for r in rows) if projected else bank.n_features_in_
    if projected:
        detectors["components"] = _pad([r["components"] for r in rows], width)
        detectors["pca_mean"] = np.stack([r["pca_mean"] for r in rows])
        detectors["whiten"] = _pad([r["whiten"][:, None] for r in rows], width, 1.0)[:, :, 0]
    if family == "linear":
        detectors["coef"] = _pad([np.asarray(r["coef"])[:, None] for r in rows], width)[:, :, 0]
    else:
        detectors["vectors"] = np.concatenate([np.pad(np.asarray(r["vectors"], dtype=np.float64),
                                                      ((0, 0), (0, width - r["vectors"].shape[1]))) for r in rows])
        detectors["dual_coef"] = np.concatenate([np.asarray(r["dual_coef"], dtype=np.float64) for r in rows])
        detectors["n_vectors"] = np.asarray([r["vectors"].shape[0] for r in rows], dtype=np.int64)
        detectors["gamma"] = np.asarray([r["gamma"] for r in rows], dtype=np.float64)
    payload: dict = {"detectors": detectors, "rule": _rule_arrays(decision_rule),
                     "estimator": {"name": np.asarray(f"{type(bank).__name__} ({bank.detector_})")}}
    if calibration is not None:
        payload["calibration"] = {k: np.asarray(v) for k, v in calibration.items()}
    return payload


# ----------------------------------------------------------------------------- reading
def _text(tree: dict, key: str) -> str | None:
    value = tree.get(key)
    return None if value is None or np.asarray(value).dtype.kind != "U" or np.ndim(value) else str(np.asarray(value))


def _read_rule(tree: Any, n_attributes: int, fail) -> DAPArrayRule:
    if not isinstance(tree, dict) or _text(tree, "name") != "dap":
        raise fail("the payload needs rule/name = 'dap'")
    fusion, prior = _text(tree, "fusion"), _text(tree, "prior")
    if fusion not in FUSIONS or prior not in _PRIOR_KINDS:
        raise fail(f"rule fusion {fusion!r} or prior {prior!r} unknown; known: {list(FUSIONS)}, {list(_PRIOR_KINDS)}")
    eps = np.asarray(tree.get("eps", np.nan))
    if eps.shape != () or eps.dtype.kind != "f" or not 0.0 < float(eps) < 0.5:
        raise fail("rule eps must be one number in (0, 0.5)")
    values = None
    if prior in ("train", "given"):
        values = np.asarray(tree.get("prior_values", np.zeros(0)))
        if values.shape != (n_attributes,) or values.dtype.kind != "f" or not np.all((values >= 0) & (values <= 1)):
            raise fail(f"rule prior_values must be {n_attributes} probabilities")
    return DAPArrayRule(fusion, prior, values, float(eps), n_attributes)


def read_detector_payload(tree: dict, n_attributes: int, where: str) -> tuple[DetectorBank, DAPArrayRule,
                                                                             dict | None]:
    """The detector bank, DAP rule and calibration of a detector bundle's arrays, checked.

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
        A missing, misshapen or non-finite array, an unknown family, fusion or prior (one line
        naming the bundle and the array).
    """
    def fail(problem: str) -> ModelBundleError:
        return ModelBundleError(f"{where}: detector arrays: {problem}")

    det = tree.get("detectors")
    if not isinstance(det, dict):
        raise fail("the payload needs detectors/...")
    family = _text(det, "family")
    if family not in DETECTOR_FAMILIES:
        raise fail(f"family {family!r} is not one of {list(DETECTOR_FAMILIES)}")
    shape = np.asarray(det.get("shape", np.zeros(0)))
    if shape.shape != (3,) or shape.dtype.kind != "i" or shape.min() < 1 or shape[0] != n_attributes:
        raise fail(f"shape must be (n_attributes = {n_attributes}, n_sensors, n_features), got {shape.tolist()}")
    m, s, d = (int(v) for v in shape)
    E = m * s
    projected = "components" in det
    k = np.shape(det["components"])[1] if projected and np.ndim(det["components"]) == 3 else d
    width: dict[str | int, int] = {"E": E, "d": d, "k": k}  # a dimension's name -> its size (a number: itself)
    wanted = {"mean": ("E", "d"), "scale": ("E", "d"), "intercept": ("E",), "platt": ("E", 2)}
    if projected:
        wanted.update(components=("E", "k", "d"), pca_mean=("E", "d"), whiten=("E", "k"))
    if family == "linear":
        wanted["coef"] = ("E", "k")
    else:
        wanted.update(gamma=("E",), n_vectors=("E",))
    arrays = {}
    for key, dims in wanted.items():
        array = np.asarray(det.get(key, np.zeros(0)))
        expected = tuple(width.get(v, v) for v in dims)
        if array.shape != expected or array.dtype.kind not in ("i" if key == "n_vectors" else "f"):
            raise fail(f"{key} has shape {array.shape} ({array.dtype}); {E} detectors need {expected}")
        if not np.isfinite(array).all():
            raise fail(f"{key} holds NaN or infinite values")
        arrays[key] = array
    if not (np.all(arrays["scale"] > 0) and (not projected or np.all(arrays["whiten"] > 0))):
        raise fail("scale and whiten must be positive")
    vectors = dual_padded = gamma = None
    if family == "rbf":
        counts, gamma = arrays["n_vectors"], arrays["gamma"]
        stacked, dual = np.asarray(det.get("vectors", np.zeros(0))), np.asarray(det.get("dual_coef", np.zeros(0)))
        total = int(counts.sum()) if counts.min(initial=1) >= 1 else -1
        if total < 0 or stacked.shape != (total, k) or dual.shape != (total,) or stacked.dtype.kind != "f" \
                or dual.dtype.kind != "f" or not (np.isfinite(stacked).all() and np.isfinite(dual).all()):
            raise fail(f"vectors {stacked.shape} and dual_coef {dual.shape} must hold n_vectors (each >= 1, "
                       f"{total} in all) finite rows of {k} values")
        if not np.all(gamma > 0):
            raise fail("gamma must be positive")
        starts = np.concatenate([[0], np.cumsum(counts)])
        vectors = _pad([stacked[a:b] for a, b in zip(starts[:-1], starts[1:], strict=True)], int(counts.max()))
        dual_padded = _pad([dual[a:b, None] for a, b in zip(starts[:-1], starts[1:], strict=True)],
                           int(counts.max()))[:, :, 0]
    rule = _read_rule(tree.get("rule"), m, fail)
    name = stored_name(tree, "AttributeClassifierBank")
    calibration = read_calibration(tree, fail)
    offset = None
    if projected:
        offset = np.stack([arrays["pca_mean"][e].reshape(1, -1) @ arrays["components"][e].T for e in range(E)])[:, 0]
    bank = DetectorBank(family, m, s, d, arrays["mean"], arrays["scale"], arrays.get("components"), offset,
                        arrays.get("whiten"), vectors,
                        None if vectors is None else np.einsum("evk,evk->ev", vectors, vectors), dual_padded, gamma,
                        arrays.get("coef"), arrays["intercept"],
                        arrays["platt"], name)
    return bank, rule, calibration
