"""Single-grasp DAP for a 5-BioTac hand: MAXDAP, AVGDAP and LDAP over the touching fingers.

DAP paper sections 5.6-5.7.2. Per grasp ``x = (x_sh, x_1,mat, ..., x_B,mat)`` with ``B`` touching
BioTacs (1 <= B <= 5):

* material attribute ``m`` from BioTac ``b``: ``p(a_m = 1 | x_b,mat)`` from a linear SVM on the
  8-d PCA projection of the 22 z-scored time averages, sigmoid (Platt) posterior; one classifier
  per (attribute, BioTac) pair (``D^am_train,b``, section 5.5) unless ``per_finger=False``;
* shape attribute ``m``: ``p(a_m = 1 | x_sh)`` from an RBF-SVM on the 10 closing-joint angles,
  sigmoid posterior.

Fusion over the touching BioTacs (:func:`fuse_grasp_posteriors`):

* MAXDAP, eq. (7): ``p(a_m=1|x) = max_b p(a_m=1|x_b,mat)``; shape ``p(a_m=1|x_sh)``;
* AVGDAP, eq. (8): ``p(a_m=1|x) = 1/B sum_b p(a_m=1|x_b,mat)``; shape ``p(a_m=1|x_sh)``;
* LDAP, eqs. (9)-(10): shape ``max(0.5, p(a_m=1|x_sh))``; material
  ``1/B sum_b max(0.5, p(a_m=1|x_b,mat))``.

The fused posteriors go into DAP, eq. (3), through the decision rule :class:`tzsl.models.DAPRule`
(:meth:`HandDAPClassifier.dap_rule`: one sensor, the estimator's prior), with
``p(a_m = 0 | x) = 1 - p(a_m = 1 | x)``. Eq. (7) fuses ``p(a_m = 1 | .)`` only; this differs from
the PHAC-2 MAXDAP of eq. (5), which takes the maximum of the posterior of each class's required
value (``tzsl.models.dap.fuse_attribute_posteriors(..., "max")``).

Calibration: the sigmoid of every SVM is fitted by ``CalibratedClassifierCV(method="sigmoid")``
with a stratified k-fold over the training grasps (training objects only). The folds are not
grouped by object, because in the paper's Table 4 several attributes (porcelain, glass, cardboard,
steel, round) are carried by a single training object, so an object-grouped fold would leave
one class out.
"""

from __future__ import annotations

from collections.abc import Sequence
from numbers import Integral, Real

import numpy as np
import pandas as pd
from joblib import Parallel, delayed
from sklearn.base import BaseEstimator, ClassifierMixin, clone
from sklearn.calibration import CalibratedClassifierCV
from sklearn.decomposition import PCA
from sklearn.model_selection import StratifiedKFold
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler
from sklearn.svm import SVC, LinearSVC
from sklearn.utils import check_random_state
from sklearn.utils._param_validation import Interval, StrOptions
from sklearn.utils.validation import check_is_fitted

from tzsl._parallel import one_blas_thread, reissued, relayed
from tzsl.exceptions import ConfigError, SplitError, TzslError
from tzsl.features import unpack_grasp_features
from tzsl.models._validation import ParameterError, ValidatedParamsMixin
from tzsl.models.rules import DAPRule

__all__ = ["FUSIONS", "HandDAPClassifier", "NoContactError", "fuse_grasp_posteriors"]

#: Fusion methods over the touching BioTacs of one grasp.
FUSIONS: tuple[str, ...] = ("maxdap", "avgdap", "ldap")


class NoContactError(TzslError, ValueError):
    """A grasp has no touching BioTac, so its material attributes cannot be assessed.

    The paper drops such grasps (section 5.5); select grasps with ``contact.any(axis=1)`` first.
    """


def fuse_grasp_posteriors(
    P_material: np.ndarray,
    contact: np.ndarray,
    P_shape: np.ndarray,
    method: str = "ldap",
) -> np.ndarray:
    """Fuse per-BioTac material posteriors and shape posteriors of grasps (eqs. 7-10).

    Parameters
    ----------
    P_material : ndarray of shape (..., F, m_mat)
        ``p(a_m = 1 | x_b,mat)`` of every BioTac ``b``; entries of non-touching BioTacs are
        ignored (may be NaN).
    contact : ndarray of bool, shape (..., F)
        Touching BioTacs; every grasp needs at least one.
    P_shape : ndarray of shape (..., m_sh)
        ``p(a_m = 1 | x_sh)``.
    method : {"maxdap", "avgdap", "ldap"}
        MAXDAP (eq. 7), AVGDAP (eq. 8) or LDAP (eqs. 9 and 10).

    Returns
    -------
    ndarray of shape (..., m_mat + m_sh)
        Fused ``p(a_m = 1 | x)``, material attributes first, then shape attributes.

    Raises
    ------
    NoContactError
        Some grasp has no touching BioTac (listing their positions).
    """
    if method not in FUSIONS:
        raise ConfigError(f"fusion must be one of {FUSIONS}, got {method!r}")
    P_material = np.asarray(P_material, dtype=float)
    contact = np.asarray(contact, dtype=bool)
    P_shape = np.asarray(P_shape, dtype=float)
    if P_material.shape[:-1] != contact.shape or P_shape.shape[:-1] != contact.shape[:-1]:
        raise ValueError(
            f"shapes do not match: P_material {P_material.shape}, contact {contact.shape}, P_shape {P_shape.shape}"
        )
    B = contact.sum(axis=-1)
    if (B == 0).any():
        where = [tuple(int(i) for i in idx) for idx in np.argwhere(B == 0)][:10]
        raise NoContactError(f"grasp(s) at {where} have no touching BioTac; drop them before classifying")
    c = contact[..., None]
    if method == "maxdap":
        mat = np.where(c, P_material, -np.inf).max(axis=-2)
        sh = P_shape
    elif method == "avgdap":
        mat = np.where(c, P_material, 0.0).sum(axis=-2) / B[..., None]
        sh = P_shape
    else:  # ldap
        mat = np.where(c, np.maximum(0.5, P_material), 0.0).sum(axis=-2) / B[..., None]
        sh = np.maximum(0.5, P_shape)
    return np.concatenate([mat, sh], axis=-1)


def _fit_one(estimator, X: np.ndarray, y: np.ndarray):
    # the problems are tiny (~100 x 8): multi-threaded BLAS only adds overhead
    with one_blas_thread():
        return clone(estimator).fit(X, y)


class HandDAPClassifier(ValidatedParamsMixin, ClassifierMixin, BaseEstimator):
    """Zero-shot object recognition from one grasp of a 5-BioTac hand (DAP paper section 5).

    Parameters
    ----------
    material_attributes : sequence of str
        Columns of the class-attribute table sensed by the BioTacs; every other column is a
        shape attribute (sensed by the joint angles).
    fusion : {"maxdap", "avgdap", "ldap"}, default="ldap"
        Fusion over touching BioTacs (:func:`fuse_grasp_posteriors`).
    n_components : int, default=8
        PCA dimension of the z-scored 22 BioTac means (section 5.6).
    material_C : float, default=1.0
        ``C`` of the linear SVMs (material attributes).
    shape_C : float, default=1.0
        ``C`` of the RBF-SVMs (shape attributes).
    shape_gamma : float or "scale", default="scale"
        RBF ``gamma`` on z-scored joint angles.
    per_finger : bool, default=True
        One material classifier per (attribute, BioTac), trained on that BioTac's touching grasps
        (the paper's ``D^am_train,b``). ``False`` pools the touching BioTacs of all fingers.
    calibration_cv : int, default=3
        Stratified folds of the sigmoid calibration (over training grasps).
    prior : float, default=0.5
        Attribute prior ``p(a_m = 1)`` for DAP (0.5: the paper's uni-prior).
    n_fingers : int, default=5
    n_material_features : int, default=22
        Layout of the packed input (see :func:`tzsl.features.pack_grasp_features`).
    n_jobs : int or None, default=None
        Parallel fits (joblib).
    random_state : int, RandomState or None, default=None
        Seeds the calibration folds and the linear SVMs.

    Attributes
    ----------
    classes_ : ndarray of str
        Training objects (rows of the ``K`` given to :meth:`fit`).
    K_ : DataFrame
        Training class-attribute rows, columns ``material_attributes_ + shape_attributes_``.
    material_attributes_, shape_attributes_ : list of str
    material_models_ : list (per BioTac, or one) of list (per material attribute) of Pipeline
    shape_models_ : list of Pipeline
    left_out_attributes_ : dict of str to str
        Attributes the training grasps cannot teach (a label with fewer than 2 grasps on some BioTac,
        or on the joint angles), left out of the model, with the reason; empty when none.
    relaxations_ : list of str
        Calibrations given fewer folds than ``calibration_cv`` (a label with fewer grasps), one line each.
    n_features_in_ : int

    Notes
    -----
    Input ``X`` is the packed array of :func:`tzsl.features.pack_grasp_features`
    (``GraspFeatures.to_array()``): per-BioTac material features, contact flags, shape features.
    """

    _parameter_constraints: dict = {
        "material_attributes": ["array-like"],
        "fusion": [StrOptions(set(FUSIONS))],
        "n_components": [Interval(Integral, 1, None, closed="left")],
        "material_C": [Interval(Real, 0, None, closed="neither")],
        "shape_C": [Interval(Real, 0, None, closed="neither")],
        "shape_gamma": [Interval(Real, 0, None, closed="neither"), StrOptions({"scale", "auto"})],
        "per_finger": ["boolean"],
        "calibration_cv": [Interval(Integral, 2, None, closed="left")],
        "prior": [Interval(Real, 0, 1, closed="neither")],
        "n_fingers": [Interval(Integral, 1, None, closed="left")],
        "n_material_features": [Interval(Integral, 1, None, closed="left")],
        "n_jobs": [None, Integral],
        "random_state": ["random_state"],
    }

    def __init__(
        self,
        *,
        material_attributes: Sequence[str] = ("porcelain", "plastic", "cardboard", "glass", "steel"),
        fusion: str = "ldap",
        n_components: int = 8,
        material_C: float = 1.0,
        shape_C: float = 1.0,
        shape_gamma: float | str = "scale",
        per_finger: bool = True,
        calibration_cv: int = 3,
        prior: float = 0.5,
        n_fingers: int = 5,
        n_material_features: int = 22,
        n_jobs: int | None = None,
        random_state=None,
    ):
        self.material_attributes = material_attributes
        self.fusion = fusion
        self.n_components = n_components
        self.material_C = material_C
        self.shape_C = shape_C
        self.shape_gamma = shape_gamma
        self.per_finger = per_finger
        self.calibration_cv = calibration_cv
        self.prior = prior
        self.n_fingers = n_fingers
        self.n_material_features = n_material_features
        self.n_jobs = n_jobs
        self.random_state = random_state

    # ------------------------------------------------------------------ helpers
    def _check_param_values(self) -> None:
        if self.n_components > self.n_material_features:
            raise ParameterError(
                f"n_components={self.n_components} exceeds n_material_features={self.n_material_features}"
            )

    def _unpack(self, X):
        try:
            return unpack_grasp_features(X, self.n_fingers, self.n_material_features)
        except ValueError as exc:
            raise ConfigError(f"X is not a packed grasp-feature array: {exc}") from None

    def _calibrated(self, base, seed: int, folds: int) -> CalibratedClassifierCV:
        cv = StratifiedKFold(folds, shuffle=True, random_state=seed)
        return CalibratedClassifierCV(base, method="sigmoid", cv=cv)

    def _calibration_folds(self, y: np.ndarray, name: str, where: str) -> int:
        """Folds of one attribute's calibration: ``calibration_cv``, or fewer (>= 2) when a label has
        fewer grasps (recorded in ``relaxations_``); 0 when a label has fewer than 2 (not learnable)."""
        counts = np.bincount(y, minlength=2)
        fewest = int(counts.min())
        if fewest >= self.calibration_cv:
            return self.calibration_cv
        why = f"{int(counts[1])} positive and {int(counts[0])} negative training grasps ({where})"
        if fewest < 2:
            self.left_out_attributes_.setdefault(name, f"{why}; its calibration needs 2 of each")
            return 0
        self.relaxations_.append(f"attribute {name!r}: calibration folds {self.calibration_cv} -> {fewest} ({why})")
        return fewest

    def _pca_components(self, n_grasps: int, folds: int, where: str) -> int:
        """``n_components``, or fewer when a calibration fold's training grasps cannot carry it (recorded)."""
        fitted_on = n_grasps - -(-n_grasps // folds)  # grasps in the smallest calibration training fold
        if fitted_on >= self.n_components:
            return self.n_components
        if fitted_on < 1:
            raise SplitError(f"{where}: {n_grasps} touching training grasps cannot fit the material attributes")
        line = (f"PCA components {self.n_components} -> as many as a calibration fold's grasps allow ({where}: "
                f"{n_grasps} touching training grasps)")
        if line not in self.relaxations_:
            self.relaxations_.append(line)
        return fitted_on

    def _touching(self, contact: np.ndarray) -> list[tuple[np.ndarray, np.ndarray, str]]:
        """The material classifiers' training rows: per BioTac (or pooled), the grasp and finger index of
        every touching BioTac reading, shapes (n_rows,) each, and the group's name."""
        n, F = contact.shape
        if not self.per_finger:
            sel = contact.reshape(-1)
            return [(np.repeat(np.arange(n), F)[sel], np.tile(np.arange(F), n)[sel], "all BioTacs pooled")]
        return [(np.flatnonzero(contact[:, b]), np.full(int(contact[:, b].sum()), b), f"BioTac {b}")
                for b in range(F)]

    # ------------------------------------------------------------------ fit
    def fit(self, X, y, K: pd.DataFrame):
        """Learn the attribute classifiers from grasps of training objects.

        Parameters
        ----------
        X : ndarray of shape (n, F*22 + F + d_shape)
            Packed grasp features (:meth:`tzsl.features.GraspFeatures.to_array`).
        y : array-like of str, shape (n,)
            Object of every grasp.
        K : DataFrame of shape (n_objects, n_attributes), 0/1
            Class-attribute rows, indexed by object name; must contain every object of ``y``.
            Only the rows of ``y``'s objects are used.

        Returns
        -------
        self
        """
        self._validate_params()
        material, contact, shape = self._unpack(X)
        y = np.asarray(y)
        if y.shape != (material.shape[0],):
            raise ConfigError(f"y must have shape ({material.shape[0]},), got {y.shape}")
        if not isinstance(K, pd.DataFrame):
            raise ConfigError("K must be a DataFrame indexed by object name")
        missing_obj = sorted(set(y.tolist()) - set(K.index))
        if missing_obj:
            raise ConfigError(f"object(s) {missing_obj} of y have no row in K")
        mat_attrs = list(self.material_attributes)
        unknown = [a for a in mat_attrs if a not in K.columns]
        if unknown:
            raise ConfigError(f"material attribute(s) {unknown} are not columns of K")
        shape_attrs = [a for a in K.columns if a not in mat_attrs]
        self.classes_ = np.array(pd.unique(y), dtype=object)
        groups = self._touching(contact)
        # what the training grasps can teach: an attribute a label of which has < 2 grasps somewhere is left out
        self.left_out_attributes_: dict[str, str] = {}
        self.relaxations_: list[str] = []
        rows = K.loc[self.classes_, mat_attrs + shape_attrs].astype(int)
        A = rows.loc[y].to_numpy()
        folds = {name: [self._calibration_folds(A[grasp, j], name, where) for grasp, _, where in groups]
                 for j, name in enumerate(mat_attrs)}
        folds.update({name: [self._calibration_folds(A[:, len(mat_attrs) + j], name, "joint angles")]
                      for j, name in enumerate(shape_attrs)})
        mat_attrs = [a for a in mat_attrs if a not in self.left_out_attributes_]
        shape_attrs = [a for a in shape_attrs if a not in self.left_out_attributes_]
        if not mat_attrs + shape_attrs:
            raise SplitError("no attribute can be learned from these training grasps: "
                             + "; ".join(f"{a!r}: {why}" for a, why in self.left_out_attributes_.items()))
        self.material_attributes_ = mat_attrs
        self.shape_attributes_ = shape_attrs
        self.K_ = rows[mat_attrs + shape_attrs]
        A = self.K_.loc[y].to_numpy()  # (n, m) labels of every grasp
        rng = check_random_state(self.random_state)
        seeds = rng.randint(np.iinfo(np.int32).max, size=4)

        # material: one PCA + calibrated linear SVM per attribute, per finger (or pooled)
        jobs: list[tuple] = []
        self._material_keys: list[object] = []  # never filled nor read (fitted models carry it)
        for g, (grasp, finger, where) in enumerate(groups):
            Xb, Ab = material[grasp, finger], A[grasp, : len(mat_attrs)]
            for j, name in enumerate(mat_attrs):
                svm = LinearSVC(C=self.material_C, class_weight="balanced", random_state=int(seeds[0]))
                pipe = make_pipeline(
                    StandardScaler(),
                    PCA(n_components=self._pca_components(Xb.shape[0], folds[name][g], where),
                        random_state=int(seeds[1])),
                    self._calibrated(svm, int(seeds[2]), folds[name][g]),
                )
                jobs.append((pipe, Xb, Ab[:, j]))
        for j, name in enumerate(shape_attrs):
            labels = A[:, len(mat_attrs) + j]
            svm = SVC(kernel="rbf", C=self.shape_C, gamma=self.shape_gamma, class_weight="balanced")
            calibrated = self._calibrated(svm, int(seeds[3]), folds[name][0])
            jobs.append((make_pipeline(StandardScaler(), calibrated), shape, labels))
        fitted = [reissued(r) for r in Parallel(n_jobs=self.n_jobs)(delayed(relayed(_fit_one))(est, Xj, yj)
                                                                     for est, Xj, yj in jobs)]
        n_mat_models = len(groups) * len(mat_attrs)
        self.material_models_ = [
            fitted[i * len(mat_attrs) : (i + 1) * len(mat_attrs)] for i in range(len(groups))
        ]
        self.shape_models_ = fitted[n_mat_models:]
        self.n_features_in_ = np.asarray(X).shape[1]
        return self

    # ------------------------------------------------------------------ posteriors
    def attribute_posteriors(self, X) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Unfused posteriors of every grasp.

        Returns
        -------
        P_material : ndarray of shape (n, F, m_mat)
            ``p(a_m = 1 | x_b,mat)``; NaN for BioTacs not touching.
        contact : ndarray of bool, shape (n, F)
        P_shape : ndarray of shape (n, m_sh)
            ``p(a_m = 1 | x_sh)``.
        """
        check_is_fitted(self, "material_models_")
        X = np.asarray(X, dtype=float)
        if X.ndim != 2 or X.shape[1] != self.n_features_in_:
            raise ConfigError(f"X must have shape (n, {self.n_features_in_}), got {X.shape}")
        material, contact, shape = self._unpack(X)
        n, F, d = material.shape
        m_mat = len(self.material_attributes_)
        P_mat = np.full((n, F, m_mat), np.nan)
        for b in range(F):
            models = self.material_models_[b if self.per_finger else 0]
            sel = contact[:, b]
            if sel.any():
                Xb = material[sel, b]
                P_mat[sel, b] = np.column_stack([m.predict_proba(Xb)[:, 1] for m in models])
        P_sh = (
            np.column_stack([m.predict_proba(shape)[:, 1] for m in self.shape_models_])
            if self.shape_models_
            else np.empty((n, 0))
        )
        return P_mat, contact, P_sh

    def predict_attribute_proba(self, X, fusion: str | None = None) -> np.ndarray:
        """Fused ``p(a_m = 1 | x)`` per grasp, shape (n, m); columns as :attr:`K_`.

        ``fusion`` overrides the estimator's fusion method.
        """
        P_mat, contact, P_sh = self.attribute_posteriors(X)
        return fuse_grasp_posteriors(P_mat, contact, P_sh, self.fusion if fusion is None else fusion)

    def attribute_scores(self, X) -> np.ndarray:
        """The zero-shot protocol's attribute scores: :meth:`predict_attribute_proba` with the
        estimator's fusion, shape (n, m), read by a :class:`tzsl.models.DAPRule` (as in a saved bundle)."""
        return self.predict_attribute_proba(X)

    def _class_matrix(self, K: pd.DataFrame | None) -> pd.DataFrame:
        check_is_fitted(self, "material_models_")
        if K is None:
            return self.K_
        if not isinstance(K, pd.DataFrame):
            raise ConfigError("K must be a DataFrame indexed by object name")
        missing = [a for a in self.K_.columns if a not in K.columns]
        if missing:
            raise ConfigError(f"K lacks the attribute column(s) {missing} the model was trained on")
        return K[list(self.K_.columns)].astype(int)

    def predict_log_scores(self, X, K: pd.DataFrame | None = None, fusion: str | None = None) -> np.ndarray:
        """DAP log scores ``log p(z | x)`` up to a per-grasp constant, shape (n, k).

        Parameters
        ----------
        X : packed grasp features
        K : DataFrame, optional
            Candidate objects (e.g. the test objects' rows). Default: the training objects.
        fusion : str, optional
            Overrides the estimator's fusion method.
        """
        Kc = self._class_matrix(K)
        return self.dap_rule().decision_function(self.predict_attribute_proba(X, fusion), Kc.to_numpy(dtype=float))

    def dap_rule(self) -> DAPRule:
        """The DAP decision rule of the fused grasp posteriors: :class:`~tzsl.models.DAPRule` with the prior
        ``p(a_m = 1) = prior`` for every attribute, fitted on the training objects' rows :attr:`K_`.

        Its ``decision_function(P, K)`` and ``predict(P, K, random_state)`` take fused posteriors of shape
        (n, m) (:meth:`predict_attribute_proba`, or their DF-MDAP mean over grasps) and a 0/1 table (k, m),
        columns as :attr:`K_`; a 2-D posterior is one sensor, so the rule's fusion does not apply.
        """
        check_is_fitted(self, "material_models_")
        prior = np.full(self.K_.shape[1], float(self.prior))
        return DAPRule(prior=prior).fit(self.K_.to_numpy(dtype=float))

    def predict(self, X, K: pd.DataFrame | None = None, fusion: str | None = None) -> np.ndarray:
        """Most probable object of every grasp (eq. 4), shape (n,); names from ``K``'s index."""
        Kc = self._class_matrix(K)
        scores = self.predict_log_scores(X, Kc, fusion)
        return Kc.index.to_numpy()[np.argmax(scores, axis=1)]

    def score(self, X, y, K: pd.DataFrame | None = None) -> float:
        """Accuracy of :meth:`predict` against ``y``."""
        return float(np.mean(self.predict(X, K) == np.asarray(y)))
