"""A zero-shot ensemble: several registry methods, their class scores z-scored per trial and averaged.

Different zero-shot methods err differently: DAP multiplies per-attribute posteriors of
independent RBF-SVMs, ESZSL scores a bilinear compatibility, SAE a cosine in attribute space.
:class:`ScoreEnsembleZSL` fits each member on the same training trials (each member tunes itself
on the training objects / classes only, as it does alone) and scores a candidate class ``c`` for
trial ``x`` by

``score(x, c) = sum_j w_j * (s_j(x, c) - mean_c' s_j(x, c')) / std_c' s_j(x, c')``

where ``s_j(x, .)`` are member ``j``'s class scores over the candidate classes (DAP: log
posteriors, ESZSL: compatibilities, SAE: cosines). The trial-wise z-score puts scores of
different kinds and scales on one footing without any fitted parameter, so no choice of the
ensemble sees a test object (each member tunes itself on training objects or classes only).

How it compares with AVGDAP and with its members on PHAC-2 (accuracy, intervals, paired
differences on the same trials) is measured by ``experiments/benchmarks/phac2_accuracy.py`` and
by the method comparison of ``tzsl run phac2-dap`` (``phac2_method_comparison.csv``); no number
is kept here, so none can describe code that is no longer shipped. The splits the default members
were chosen on, and the confirmation splits of ``experiments/benchmarks/phac2_best_method.py`` that
report the method, are recorded in :data:`tzsl.models.INHERITED_CHOICES` (``ensemble-members``).

One fit per configuration: a member is built from the registry as a study builds a compared method
(the method's defaults, the ensemble's own seed) and fitted through the fit store
(:func:`tzsl.fit_store.fit_cached`), and so are its refits in posterior calibration's folds, each with
the hyper-parameters its fit chose (``pin_members``), as a calibrated method on its own refits them.
Where a study also compares the member's method with the same parameters (the template compares
``dap-avg``, ``eszsl`` and ``sae``), the member is that method's fit on the same training rows,
read back instead of fitted again; a member configured otherwise is fitted on its own.
"""

from __future__ import annotations

from numbers import Real

import numpy as np
from sklearn.base import BaseEstimator
from sklearn.utils.validation import check_array, check_is_fitted

from tzsl._fit_store import fit_cached
from tzsl._scoring import class_posteriors
from tzsl.exceptions import ConfigError
from tzsl.models._attribute_model_base import attribute_table_tags
from tzsl.models._dap import break_ties
from tzsl.models._registry import get_method
from tzsl.models._validation import ValidatedParamsMixin
from tzsl.models._zero_shot import zscore_rows

__all__ = ["ScoreEnsembleZSL"]

#: Members of the shipped ensemble, registry names with the methods' defaults: AVGDAP with the uniform
#: prior and the registry's RBF-SVM detectors (balanced Platt posteriors pair with the uniform prior, see
#: AttributeSVM), ESZSL and SAE. The RBF-SVM DAP was chosen on selection splits against the DAP of the
#: generic study's detector in its place or beside it (issue 32); its detector is the registry's default
#: (before issue 43: AttributeSVM(cv=5, grid="paper")), so a study comparing dap-avg fits it once for both
#: (INHERITED_CHOICES, "ensemble-members"; experiments/benchmarks/ensemble_reuse.py).
DEFAULT_MEMBERS: tuple = ("dap-avg", "eszsl", "sae")


def _spec(entry) -> dict:
    """A member entry as ``{"name": ..., **parameters}``."""
    if isinstance(entry, str):
        return {"name": entry}
    if isinstance(entry, dict) and isinstance(entry.get("name"), str):
        return dict(entry)
    raise ConfigError(f"ensemble member must be a method name or {{'name': ..., **parameters}}, got {entry!r}")


class ScoreEnsembleZSL(ValidatedParamsMixin, BaseEstimator):
    """Mean of trial-wise z-scored class scores of several zero-shot methods.

    Parameters
    ----------
    methods : sequence of str or dict, default=DEFAULT_MEMBERS
        Registry methods (``tzsl methods``), each a name or ``{"name": ..., **parameters}``.
        Default: ``dap-avg`` (the registry's RBF-SVM detectors, ``prior="uni"``), ``eszsl``, ``sae``,
        each with its defaults.
        Per-sensor methods (``input_ndim = 3``, e.g. DAP) get ``(n, n_sensors, n_features)``,
        the others the sensors side by side.
    weights : sequence of float or None, default=None
        Non-negative weight of each member; ``None``: equal weights.
    pin_members : bool, default=True
        How posterior calibration's pseudo-unseen folds (``calibration_refit="pinned"``, see
        :class:`tzsl.models.CalibratedZeroShotClassifier`) refit the members: True, each with the
        hyper-parameters its fit chose (the DAP bank's solver and ``C`` / ``gamma`` per classifier,
        ESZSL's ridges, SAE's ``lam``), as a calibrated method on its own refits them, so a member's
        fold refits are that method's; False, every member searches again (several times the CPU).
        True since issue 43 (the inherited choice ``ensemble-calibration-refit``; its numbers: the
        ``ensemble-reuse-benchmark`` block of ``experiments/benchmarks/README.md``).
    random_state : int, RandomState instance or None, default=None
        The seed of every member that takes one (the DAP SVM draws, each member's tie-breaking) and of
        the breaking of exact ties: the seed a study gives every compared method, so a member
        configured as a compared method is the same fit; a member entry's own ``random_state`` wins.

    Attributes
    ----------
    estimators_ : list of fitted estimators
        One per member, in ``methods`` order.
    member_input_ndims_ : list of int
        Input dimensionality of each member (3: per sensor; 2: sensors concatenated), read from
        the registry at fit time so prediction does not depend on it.
    weights_ : ndarray of shape (n_members,)
        Weights normalised to sum to 1.
    class_attributes_ : ndarray of shape (n_train_classes, n_attributes)
        Distinct training attribute rows (the default candidate classes).
    n_features_in_ : int
        Features per sensor.
    n_sensors_ : int
        1 for 2-D input.
    """

    _parameter_constraints: dict = {
        "methods": [list, tuple],
        "weights": [None, "array-like"],
        "pin_members": ["boolean"],
        "random_state": [None, "random_state"],
    }

    def __init__(self, *, methods=DEFAULT_MEMBERS, weights=None, pin_members=True, random_state=None):
        self.methods = methods
        self.weights = weights
        self.pin_members = pin_members
        self.random_state = random_state

    def __sklearn_tags__(self):
        return attribute_table_tags(super().__sklearn_tags__())

    def _check_param_values(self) -> None:
        if len(self.methods) == 0:
            raise ConfigError("ScoreEnsembleZSL: methods is empty")
        if self.weights is not None:
            w = np.asarray(self.weights, dtype=object).ravel()
            if (w.size != len(self.methods)
                    or not all(isinstance(v, Real)
                               and v >= 0  # type: ignore[operator]  # typeshed's numbers.Real lacks __ge__
                               for v in w)
                    or not sum(w) > 0):
                raise ConfigError(f"ScoreEnsembleZSL: weights must be {len(self.methods)} non-negative numbers "
                                  f"with a positive sum, got {self.weights!r}")

    @staticmethod
    def _member_input(input_ndim: int, X: np.ndarray) -> np.ndarray:
        return X if input_ndim == 3 else X.reshape(X.shape[0], -1)

    def _as_3d(self, X) -> np.ndarray:
        """``X`` as finite float64 (n_trials, n_sensors, n_features); 2-D input is one sensor."""
        X = check_array(X, allow_nd=True, dtype=np.float64, input_name="X")
        if X.ndim == 2:
            X = X[:, None, :]
        if X.ndim != 3:
            raise ValueError(f"X must be (n_trials, n_features) or (n_trials, n_sensors, n_features), got {X.shape}")
        return X

    def fit(self, X, Y, groups=None):
        """Fit every member on the training trials.

        Parameters
        ----------
        X : array-like of shape (n_trials, n_features) or (n_trials, n_sensors, n_features)
        Y : array-like of shape (n_trials, n_attributes)
            Attribute row of each trial's training class (1-D: one attribute).
        groups : array-like of shape (n_trials,), optional
            Object of each trial (members' grouped tuning).

        Returns
        -------
        self
        """
        self._validate_params()
        if Y is None:
            raise ValueError(f"{type(self).__name__} requires y to be passed, but the target y is None")
        X = self._as_3d(X)
        A = check_array(Y, ensure_2d=False, dtype=np.float64, input_name="y")
        A = A.reshape(-1, 1) if A.ndim == 1 else A
        if A.shape[0] != X.shape[0]:
            raise ValueError(f"X has {X.shape[0]} trials but Y has {A.shape[0]} rows")
        self.estimators_, self.member_input_ndims_ = [], []
        for entry in self.methods:
            spec = _spec(entry)
            method = get_method(spec["name"])
            params = {k: v for k, v in spec.items() if k != "name"}
            if method.calibratable:  # the ensemble's posterior is calibrated as a whole, not per member
                params.setdefault("calibration", "none")
            if self.random_state is not None and "random_state" in method.parameters():
                params.setdefault("random_state", self.random_state)  # as a study seeds a compared method
            self.member_input_ndims_.append(method.input_ndim)
            est = method.build(**params)  # a new instance
            self.estimators_.append(fit_cached(est, self._member_input(method.input_ndim, X), A, groups))
        w = np.ones(len(self.methods)) if self.weights is None else np.asarray(self.weights, dtype=np.float64)
        self.weights_ = w / w.sum()
        self.class_attributes_ = np.unique(A, axis=0)
        self.n_sensors_, self.n_features_in_ = X.shape[1], X.shape[2]
        return self

    def pinned_methods(self, pick) -> list[dict]:
        """Member entries that refit each fitted member with its chosen hyper-parameters (``pin_members``).

        Posterior calibration refits the ensemble on pseudo-unseen folds
        (:class:`tzsl.models.CalibratedZeroShotClassifier`); with ``calibration_refit="pinned"`` it
        refits it from these entries, so with ``pin_members`` each member keeps the choice of this
        fit; without it the entries are the members' own, and every member searches again.

        Parameters
        ----------
        pick : callable
            ``pick(attribute_model) -> dict``: the parameters that pin a fitted member's attribute
            model (``None`` for a member without one), e.g. its ``selected_params()``.

        Returns
        -------
        list of dict
            ``{"name": ..., **parameters}`` per member, in ``methods`` order, with ``pick``'s added.
        """
        check_is_fitted(self)
        return [{**_spec(entry), **(pick(getattr(est, "attribute_model_", None)) if self.pin_members else {})}
                for entry, est in zip(self.methods, self.estimators_, strict=True)]

    def decision_function(self, X, class_attributes=None) -> np.ndarray:
        """Ensemble class scores.

        Parameters
        ----------
        X : array-like, as in :meth:`fit`
        class_attributes : array-like of shape (n_classes, n_attributes), optional
            Candidate (unseen) classes; default the training classes.

        Returns
        -------
        ndarray of shape (n_trials, n_classes)
            Weighted mean of the members' trial-wise z-scored class scores.
        """
        check_is_fitted(self)
        X = self._as_3d(X)
        if X.shape[2] != self.n_features_in_:
            raise ValueError(f"X has {X.shape[2]} features, but {type(self).__name__} is expecting "
                             f"{self.n_features_in_} features as input")
        if X.shape[1] != self.n_sensors_:
            raise ValueError(f"X has {X.shape[1]} sensors; {type(self).__name__} was fitted on {self.n_sensors_}")
        K = self.class_attributes_ if class_attributes is None else np.asarray(class_attributes, dtype=np.float64)
        total = 0.0
        for ndim, est, w in zip(self.member_input_ndims_, self.estimators_, self.weights_, strict=True):
            Xm = self._member_input(ndim, X)
            total = total + w * zscore_rows(est.decision_function(Xm, K))
        return np.asarray(total)

    def predict_proba(self, X, class_attributes=None) -> np.ndarray:
        """Softmax of :meth:`decision_function` over the candidate classes; (n_trials, n_classes)."""
        return class_posteriors(self.decision_function(X, class_attributes))

    def predict(self, X, class_attributes=None) -> np.ndarray:
        """Best candidate class per trial (row index into ``class_attributes``); ties broken by ``random_state``."""
        return break_ties(self.decision_function(X, class_attributes), self.random_state)
