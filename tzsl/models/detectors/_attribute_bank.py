"""Independent attribute classifiers, one per (attribute, sensor): the attribute layer of DAP.

:class:`AttributeClassifierBank` fits a clone of an attribute classifier (by default
:class:`~tzsl.models.AttributeSVM`, or above ``max_exact_trials`` training trials the
:class:`~tzsl.models.ScalableAttributeClassifier`) for every attribute and sensor, in parallel
(joblib, locally or on Dask) and cached, and gives ``predict_proba(X) -> (n, s, m)``. The
classifier's family (``detector``: RBF-SVM, linear, or chosen on the training objects) is
:mod:`tzsl.models.detectors._families`.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Iterable
from numbers import Integral

import numpy as np
from joblib import Parallel, delayed
from sklearn.base import BaseEstimator, clone
from sklearn.utils._param_validation import HasMethods, Interval, Options, StrOptions
from sklearn.utils.validation import check_is_fitted
from tqdm.auto import tqdm

from tzsl._fit_store import (
    array_digest,
    count_fits,
    fit_clone,
    fit_recorded,
    parallel_context,
    resolve_store,
    spawn_seeds,
    stored_fit,
)
from tzsl._profile import timed
from tzsl._progress import progress_bar
from tzsl.exceptions import ConfigError
from tzsl.models._validation import ValidatedParamsMixin
from tzsl.models._zsl_input import GridEdgeWarning
from tzsl.models.detectors._attribute_training import (
    AUTO_MAX_EXACT_TRIALS,
    SOLVERS,
    AttributeTrainingError,
    check_label_objects,
)
from tzsl.models.detectors._families import AUTO_CANDIDATES, DETECTORS, choose_detector, detector_template
from tzsl.models.detectors._scalable_attribute import ScalableAttributeClassifier
from tzsl.value_lists import JOBLIB_BACKENDS

__all__ = ["AttributeClassifierBank"]

#: Test trials from which :meth:`AttributeClassifierBank.predict_proba` runs the (attribute, sensor)
#: models in parallel on the bank's backend (below it, one after another in this process).
PARALLEL_PREDICT_TRIALS = 20_000


def _positive_posterior(estimator, X: np.ndarray) -> np.ndarray:
    """``estimator.predict_proba(X)[:, 1]`` for X (n_trials, n_features): shape (n_trials,)."""
    return estimator.predict_proba(X)[:, 1]


def _check_attribute_matrix(A, n: int, names) -> np.ndarray:
    A = np.asarray(A)
    if A.ndim != 2 or A.shape[0] != n:
        raise ConfigError(f"attribute targets must have shape ({n}, n_attributes), got {A.shape}")
    Af = A.astype(float)
    bad = ~np.isin(Af, (0.0, 1.0))  # NaN is not in the set either
    if bad.any():
        r, c = np.argwhere(bad)[0]
        raise AttributeTrainingError(
            f"attribute {names[c]!r}: trial row {r} has value {A[r, c].item()!r}; attribute targets must be 0/1"
        )
    return Af.astype(np.int64)


class AttributeClassifierBank(ValidatedParamsMixin, BaseEstimator):
    """Independent attribute classifiers: one per (attribute, sensor), fitted in parallel and cached.

    This is the attribute layer of DAP (paper §3.3, §4.4): attributes are assumed independent,
    and each sensor (BioTac) gets its own classifier.

    Parameters
    ----------
    estimator : classifier or None, default=None
        Template of ``detector="rbf-svm"``, cloned for every (attribute, sensor); must accept
        ``fit(X, y, groups)`` and give ``predict_proba``. ``None``: :class:`AttributeSVM` with
        default parameters. Must be None with any other ``detector``.
    detector : {"rbf-svm", "logistic", "linear-svm", "robust-logistic", "logistic-c1", "auto"}, default="rbf-svm"
        Family of the per-(attribute, sensor) classifier (:mod:`tzsl.models.detectors._families`):
        ``"rbf-svm"``: ``estimator``; ``"logistic"`` / ``"linear-svm"``:
        :class:`~tzsl.models.LinearAttribute` (L2 logistic regression / linear SVM on z-scored
        features, ``C`` by object-grouped CV, Platt posteriors); ``"robust-logistic"``: the
        logistic detector trained group-robustly over training objects; ``"logistic-c1"``:
        :class:`~tzsl.models.LogisticAttribute` (z-scored class-balanced L2 logistic regression,
        ``C = 1``, nothing tuned); ``"auto"``: the family
        of ``detector_candidates`` with the best AVGDAP accuracy on pseudo-unseen training
        classes (class-grouped folds of the training objects only), recorded in
        ``detector_choice_``; it costs ``AUTO_FOLDS`` refits of every candidate.
    detector_candidates : sequence of str, default=("rbf-svm", "logistic")
        The families ``detector="auto"`` chooses between.
    attribute_names : sequence of str or None, default=None
        Names used in error messages (default ``"0"``, ``"1"``, ...).
    n_jobs : int or None, default=None
        Parallel fits (joblib convention; ``-1`` = all cores).
    backend : {"loky", "dask", "threading", "sequential"}, default="loky"
        joblib backend. ``"dask"`` runs the fits on the current ``dask.distributed`` Client.
        Results do not depend on the backend or ``n_jobs``.
    memory : None, False, str, Path or joblib.Memory, default=None
        Cache folder of the fit store (:func:`tzsl.fit_store.resolve_store`): each per-(attribute,
        sensor) fit is read from ``<folder>/fits`` when an equal fit (same estimator parameters,
        training arrays and code) was stored before, by this or any other model, table or
        study; only the others are fitted (in parallel) and stored. ``None``:
        ``$TZSL_CACHE_DIR`` if set, else no store; ``False``: no store.
    progress : bool, default=False
        Show a tqdm progress bar over the fits.
    random_state : int, RandomState or None, default=None
        Each (attribute, sensor) fit gets its own seed from ``np.random.SeedSequence``.
    solver : {"exact", "approximate", "auto"}, default="auto"
        ``"exact"``: ``estimator`` as given. ``"approximate"``: a
        :class:`tzsl.models.ScalableAttributeClassifier` (Nystroem RBF features + logistic
        regression, linear in trials) with ``estimator``'s preprocessor, under-sampling and Platt
        weighting. ``"auto"``: exact up to ``max_exact_trials`` training trials, approximate above
        (the exact model's time grows as trials^2). The choice and its reason are in
        ``solver_choice_`` and printed when ``progress`` is on. Only ``detector="rbf-svm"`` has an
        approximate solver: the linear detectors are fitted exactly (their time is linear in trials).
    max_exact_trials : int, default=AUTO_MAX_EXACT_TRIALS
        Largest training set fitted exactly by ``solver="auto"`` (the exact model's cost against
        trials is measured by ``make bench-scale``).
    estimator_params : list of list of dict or None, default=None
        ``estimator_params[m][s]``: parameters set on the clone of attribute ``m`` on sensor ``s``
        (after its seed and name). :meth:`selected_params` gives each fitted model's chosen
        hyper-parameters this way (:func:`chosen_settings`), so a refit on part of the trials
        (posterior calibration's folds) skips the hyper-parameter search. None: the template as is.

    Attributes
    ----------
    estimators_ : list of list of fitted classifiers
        ``estimators_[m][s]`` is attribute ``m`` on sensor ``s``.
    grid_edge_hits_ : list of dict
        One ``{"attribute", "sensor", "parameter", "value", "edge"}`` per tuned hyper-parameter
        chosen at an end of its grid (from each estimator's ``grid_edges_``); a
        :class:`GridEdgeWarning` summarises them once per :meth:`fit`.
    n_sensors_, n_attributes_, n_features_in_ : int
    solver_choice_ : dict
        ``{"solver": "exact" | "approximate", "reason": str, "n_trials": int}``.
    detector_ : str
        The family fitted (the choice of ``detector="auto"``, else ``detector``).
    detector_choice_ : dict
        ``{"detector": detector_, "criterion": str, ...}``; with ``"auto"`` also ``"n_folds"``,
        ``"n_held_out_trials"`` and ``"scores"`` (each candidate's pseudo-unseen ``accuracy`` and
        ``attribute_log_loss``), for a study to write beside its results.
    """

    #: Attribute-model protocol: ``predict_proba`` gives ``p(a_m = 1 | x_s)`` (read by DAPRule).
    score_kind = "probability"

    _parameter_constraints: dict = {
        "estimator": [None, HasMethods(["fit", "predict_proba"])],
        "detector": [StrOptions(set(DETECTORS))],
        "detector_candidates": ["array-like"],
        "attribute_names": [None, "array-like"],
        "n_jobs": [None, Integral],
        "backend": [StrOptions(set(JOBLIB_BACKENDS))],
        "memory": [None, Options(bool, {False}), str, os.PathLike, HasMethods(["cache"])],
        "progress": ["boolean"],
        "random_state": ["random_state"],
        "solver": [StrOptions(set(SOLVERS))],
        "max_exact_trials": [Interval(Integral, 1, None, closed="left")],
        "estimator_params": [None, list],
    }

    def __init__(
        self,
        *,
        estimator=None,
        detector="rbf-svm",
        detector_candidates=AUTO_CANDIDATES,
        attribute_names=None,
        n_jobs=None,
        backend="loky",
        memory=None,
        progress=False,
        random_state=None,
        solver="auto",
        max_exact_trials=AUTO_MAX_EXACT_TRIALS,
        estimator_params=None,
    ):
        self.estimator = estimator
        self.detector = detector
        self.detector_candidates = detector_candidates
        self.attribute_names = attribute_names
        self.n_jobs = n_jobs
        self.backend = backend
        self.memory = memory
        self.progress = progress
        self.random_state = random_state
        self.solver = solver
        self.max_exact_trials = max_exact_trials
        self.estimator_params = estimator_params

    def _names(self, m: int) -> list[str]:
        if self.attribute_names is None:
            return [str(i) for i in range(m)]
        names = [str(a) for a in self.attribute_names]
        if len(names) != m:
            raise ConfigError(f"attribute_names has {len(names)} names but the targets have {m} columns")
        return names

    def _template(self):
        """The per-(attribute, sensor) classifier template of ``detector_`` (``detector`` before a fit)."""
        family = getattr(self, "detector_", self.detector)
        auto_linear = self.detector == "auto" and family != "rbf-svm"  # estimator is the rbf-svm candidate's
        return detector_template(family, None if auto_linear else self.estimator)

    def _choose_detector(self, X: np.ndarray, A: np.ndarray, groups) -> None:
        """Set ``detector_`` and ``detector_choice_`` (with ``"auto"``: :func:`choose_detector`)."""
        if self.detector != "auto":
            self.detector_ = self.detector
            self.detector_choice_ = {"detector": self.detector, "criterion": "given"}
            return
        self.detector_choice_ = choose_detector(self, X, A, groups, tuple(self.detector_candidates),
                                                random_state=spawn_seeds(self.random_state, 1)[0])
        self.detector_ = self.detector_choice_["detector"]
        if self.progress:
            tqdm.write(f"attribute detector: {self.detector_} (detector='auto', {self.detector_choice_['scores']})")

    def _choose_template(self, n_trials: int):
        """The estimator template for ``n_trials`` training trials; sets ``solver_choice_``."""
        exact = self._template()
        if self.detector_ != "rbf-svm":
            self.solver_choice_ = {"solver": "exact", "n_trials": int(n_trials),
                                   "reason": f"detector={self.detector_!r} is linear in trials"}
            return exact
        if self.solver == "auto":
            approximate = n_trials > self.max_exact_trials
            relation = ">" if approximate else "<="
            reason = f"solver='auto': {n_trials} training trials {relation} max_exact_trials={self.max_exact_trials}"
        else:
            approximate = self.solver == "approximate"
            reason = f"solver={self.solver!r}"
        self.solver_choice_ = {"solver": "approximate" if approximate else "exact", "reason": reason,
                               "n_trials": int(n_trials)}
        if self.progress:
            tqdm.write(f"attribute models: {self.solver_choice_['solver']} ({reason})")
        if not approximate:
            return exact
        # one protocol for both solvers: the approximate model searches the exact model's grid with
        # its folds and draws (the splits this was chosen on: INHERITED_CHOICES, "approximate-solver")
        params = exact.get_params(deep=False)
        shared = {k: v for k, v in params.items()
                  if k in ("preprocessor", "platt_weighting", "name", "random_state", "C_range", "gamma_range",
                           "n_C", "n_gamma", "n_draws")}
        if isinstance(params.get("cv"), Integral) and params["cv"] >= 2:  # not leave-one-object-out or a splitter
            shared["cv"] = params["cv"]
        undersampling = params.get("undersampling", "select")
        shared["undersampling"] = "none" if undersampling == "none" else "select"
        return ScalableAttributeClassifier(**shared)

    def _check_fit_input(self, X, A) -> tuple[np.ndarray, np.ndarray, list[str]]:
        """``(X, A, names)``: X (n_trials, n_sensors, n_features) float64, A (n_trials, n_attributes) 0/1."""
        X = _check_3d(X)
        n = X.shape[0]
        if np.ndim(A) != 2:
            raise ConfigError(f"attribute targets must have shape ({n}, n_attributes), got {np.shape(A)}")
        names = self._names(np.shape(A)[1])
        return X, _check_attribute_matrix(A, n, names), names

    def _run_fits(self, tasks: list, desc: str, on_result=None) -> list:
        """Run joblib ``tasks`` on ``self.backend`` / ``self.n_jobs``; results in task order.

        ``on_result(i, result)`` is called as each result arrives (the fit store saves it then,
        so an interrupted run keeps the fits it finished).
        """
        if not tasks:
            return []
        with parallel_context(self.backend):
            backend = None if self.backend == "dask" else self.backend
            results = Parallel(n_jobs=self.n_jobs, backend=backend, return_as="generator")(tasks)
            out = []
            for i, result in enumerate(progress_bar(results, show=self.progress, total=len(tasks), desc=desc)):
                if on_result is not None:
                    on_result(i, result)
                out.append(result)
            return out

    def _fit_stored(self, templates: list, data: list[tuple], digests: list[tuple], desc: str) -> list:
        """Fit clones of ``templates[i]`` on ``data[i]``, reading and writing the fit store.

        ``digests[i]``: the :func:`array_digest` of each array of ``data[i]`` (computed once per
        array by the caller). Only the fits the store does not hold go to the workers; the
        fitted estimators come back in task order.
        """
        store = resolve_store(self.memory)
        if not store.enabled:
            count_fits("off", len(templates))
            return self._run_fits([delayed(fit_clone)(t, *d) for t, d in zip(templates, data, strict=True)], desc)
        keys = [store.key(t, *dg) for t, dg in zip(templates, digests, strict=True)]
        fitted = [stored_fit(store, k, t) for k, t in zip(keys, templates, strict=True)]
        todo = [i for i, f in enumerate(fitted) if f is None]

        def save(n: int, result) -> None:
            store.save(keys[todo[n]], *result)

        done = self._run_fits([delayed(fit_recorded)(templates[i], *data[i]) for i in todo], desc, save)
        for i, (est, _, _) in zip(todo, done, strict=True):
            fitted[i] = est
        return fitted

    def _check_predict_input(self, X) -> np.ndarray:
        """``X`` as float64 (n_trials, n_sensors_, n_features_in_), after the fitted check."""
        check_is_fitted(self)
        X = _check_3d(X)
        if X.shape[1:] != (self.n_sensors_, self.n_features_in_):
            raise ConfigError(
                f"X has {X.shape[1]} sensors x {X.shape[2]} features; the model was fitted on "
                f"{self.n_sensors_} x {self.n_features_in_}"
            )
        return X

    @timed("fit")
    def fit(self, X, A, groups=None):
        """Fit one classifier per (attribute, sensor).

        Parameters
        ----------
        X : array-like of shape (n_trials, n_sensors, n_features)
            Per-sensor trial features.
        A : array-like of shape (n_trials, n_attributes)
            0/1 attribute targets of each trial (the attribute row of its object).
        groups : array-like of shape (n_trials,), optional
            Object of each trial, for object-grouped cross-validation.

        Returns
        -------
        self
        """
        self._validate_params()
        X, A, names = self._check_fit_input(X, A)
        n, s, d = X.shape
        groups = None if groups is None else np.asarray(groups)
        if groups is not None and groups.shape != (n,):
            raise ConfigError(f"groups must have shape ({n},), got {groups.shape}")
        if groups is not None:  # object names -> codes in sorted order: the same folds and draws, but each
            groups = np.unique(groups, return_inverse=True)[1].reshape(n)  # grouping is integer work
        check_label_objects(A, np.arange(n) if groups is None else groups, names)  # fail fast, before parallel work
        per_model = self._per_model_params(A.shape[1], s)
        self._choose_detector(X, A, groups)
        template = self._choose_template(n)
        seeds = spawn_seeds(self.random_state, A.shape[1] * s)
        # one array per sensor, shared by every attribute's task: the Dask backend scatters each once
        per_sensor = [np.ascontiguousarray(X[:, k, :]) for k in range(s)]
        targets = [np.ascontiguousarray(A[:, j]) for j in range(A.shape[1])]
        digests = _digests(per_sensor, targets, groups) if resolve_store(self.memory).enabled else None
        templates, data, keys = [], [], []
        for j, nm in enumerate(names):
            for k in range(s):
                est = clone(template)
                params = est.get_params(deep=False)
                if "random_state" in params:
                    est.set_params(random_state=seeds[j * s + k])
                if "name" in params:
                    est.set_params(name=f"{nm} (sensor {k})")
                est.set_params(**per_model[j][k])
                templates.append(est)
                data.append((per_sensor[k], targets[j], groups))
                keys.append(None if digests is None else (digests[0][k], digests[1][j], digests[2]))
        fitted = self._fit_stored(templates, data, keys, "attribute fits")
        self.estimators_ = [fitted[j * s : (j + 1) * s] for j in range(A.shape[1])]
        self.n_sensors_, self.n_attributes_, self.n_features_in_ = s, A.shape[1], d
        self._record_grid_edges(names)
        return self

    def _per_model_params(self, m: int, s: int) -> list[list[dict]]:
        """``estimator_params`` checked against ``m`` attributes x ``s`` sensors (empty dicts when None)."""
        if self.estimator_params is None:
            return [[{}] * s for _ in range(m)]
        shape = [len(row) for row in self.estimator_params]
        if len(shape) != m or any(k != s for k in shape):
            raise ConfigError(f"estimator_params must hold {m} attributes x {s} sensors of parameters, "
                              f"got {len(shape)} attributes with {sorted(set(shape))} sensors")
        return self.estimator_params

    def selected_params(self) -> dict:
        """Parameters that refit this bank as it was fitted: the solver it chose (``{"solver": "exact" |
        "approximate"}``), with ``detector="auto"`` the family it chose, and ``estimator_params``: each
        (attribute, sensor) model's chosen hyper-parameters (:func:`chosen_settings`).

        A refit on part of the training trials (posterior calibration's pseudo-unseen folds, which
        may be subsampled: :class:`tzsl.models.CalibratedZeroShotClassifier`) then uses the same
        kind of attribute model as this fit, whatever its number of trials, and the same
        hyper-parameters, without searching them again.
        """
        check_is_fitted(self)
        choice = getattr(self, "solver_choice_", None)  # None: a subclass without a solver (the chain)
        pinned = {} if choice is None else {"solver": choice["solver"]}
        if self.detector == "auto":
            pinned["detector"] = self.detector_
            if self.detector_ != "rbf-svm":
                pinned["estimator"] = None
        if "estimator_params" in self.get_params(deep=False):
            pinned["estimator_params"] = [[chosen_settings(est) for est in row] for row in self.estimators_]
        return pinned

    def _record_grid_edges(self, names: list[str]) -> None:
        """Fill ``grid_edge_hits_`` from the fitted estimators; one :class:`GridEdgeWarning` for the batch."""
        self.grid_edge_hits_ = [
            {"attribute": names[j], "sensor": k, "parameter": p, "value": v, "edge": e}
            for j, per_sensor in enumerate(self.estimators_)
            for k, est in enumerate(per_sensor)
            for p, v, e in getattr(est, "grid_edges_", ())
        ]
        if self.grid_edge_hits_:
            counts: dict[str, int] = {}
            for hit in self.grid_edge_hits_:
                key = f"{hit['parameter']} = {hit['value']:g} ({hit['edge']} edge)"
                counts[key] = counts.get(key, 0) + 1
            n_fits = sum(len(per) for per in self.estimators_)
            detail = ", ".join(f"{key}: {c}" for key, c in sorted(counts.items()))
            warnings.warn(
                f"{len(self.grid_edge_hits_)} hyper-parameter choices of {n_fits} (attribute, sensor) fits sit on a "
                f"grid edge ({detail}); the optimum may lie outside the grid (see grid_edge_hits_)",
                GridEdgeWarning, stacklevel=4,  # 4: past fit and its profile wrapper
            )

    @timed("predict")
    def predict_proba(self, X) -> np.ndarray:
        """Attribute posteriors per sensor.

        Parameters
        ----------
        X : array-like of shape (n_trials, n_sensors, n_features)

        Returns
        -------
        ndarray of shape (n_trials, n_sensors, n_attributes)
            ``p(a_m = 1 | x_s)``.
        """
        X = self._check_predict_input(X)
        P = np.empty((X.shape[0], self.n_sensors_, self.n_attributes_))
        pairs = [(j, k) for j in range(self.n_attributes_) for k in range(self.n_sensors_)]
        if X.shape[0] >= PARALLEL_PREDICT_TRIALS and self.n_jobs not in (None, 1):
            per_sensor = [np.ascontiguousarray(X[:, k, :]) for k in range(self.n_sensors_)]  # each shipped once
            tasks = [delayed(_positive_posterior)(self.estimators_[j][k], per_sensor[k]) for j, k in pairs]
            columns: Iterable[np.ndarray] = self._run_fits(tasks, "attribute posteriors")
        else:
            columns = (_positive_posterior(self.estimators_[j][k], X[:, k, :]) for j, k in pairs)
        for (j, k), column in zip(pairs, columns, strict=True):
            P[:, k, j] = column
        return P


def chosen_settings(estimator) -> dict:
    """Parameters that refit a fitted attribute classifier with the hyper-parameters it chose, searching none.

    By the attribute classifiers' convention (:class:`~tzsl.models.AttributeSVM`,
    :class:`~tzsl.models.ScalableAttributeClassifier`, :class:`~tzsl.models.LinearAttribute`): a
    tuned ``C_`` / ``gamma_`` becomes a one-point grid (``C_range = (C_, C_)``, ``n_C = 1``; the
    same for ``gamma``), ``grid = "paper"`` (no added or widened ``gamma`` / ``C`` points),
    ``max_grid_extensions = 0`` and ``n_draws = 1`` (one balanced under-sampling draw: a draw is
    of the fitted trials' objects and cannot be reused on others). The refit still fits its Platt
    sigmoid on its own object-grouped out-of-fold scores. Parameters the classifier lacks are left out.

    Parameters
    ----------
    estimator : fitted classifier

    Returns
    -------
    dict
        ``set_params`` keywords (empty for a classifier without tuned ``C_`` / ``gamma_``).
    """
    params = estimator.get_params(deep=False)
    out: dict = {}
    for name in ("C", "gamma"):
        value = getattr(estimator, f"{name}_", None)
        if value is not None and f"{name}_range" in params and f"n_{name}" in params:
            out[f"{name}_range"], out[f"n_{name}"] = (float(value), float(value)), 1
    if out:
        fixed = {"grid": "paper", "max_grid_extensions": 0, "n_draws": 1}
        out.update({k: v for k, v in fixed.items() if k in params})
    return out


def _digests(per_sensor: list, targets: list, groups) -> tuple[list[str], list[str], str]:
    """:func:`array_digest` of each sensor's features, each attribute's targets and the groups (once each)."""
    return ([array_digest(x) for x in per_sensor], [array_digest(t) for t in targets],
            array_digest(np.zeros(0) if groups is None else groups))


def _check_3d(X) -> np.ndarray:
    X = np.asarray(X, dtype=np.float64)
    if X.ndim != 3:
        raise ConfigError(f"features must have shape (n_trials, n_sensors, n_features), got {X.shape}")
    if not np.isfinite(X).all():
        t, s, f = np.argwhere(~np.isfinite(X))[0]
        raise ConfigError(f"features hold a non-finite value at trial row {t}, sensor {s}, feature {f}")
    return X
