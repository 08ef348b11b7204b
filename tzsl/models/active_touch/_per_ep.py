"""Active touch: per-EP attribute models, a sequential zero-shot posterior and a policy choosing the next EP.

A robot pays for every exploratory procedure (EP) in seconds. Here the four PHAC-2 EPs (squeeze,
hold, slow slide, fast slide) each get their own attribute classifiers, the class posterior over
the *unseen* classes is updated after each EP, and the next EP is the one with the largest
expected reduction of class entropy.

Model (all fitted on training objects only):

* **Per-EP attribute models.** One :class:`tzsl.models.AttributeClassifierBank` per EP on that
  EP's feature block (sensors x EP features). The default per-(attribute, sensor) classifier is
  :class:`LogisticAttribute` (z-score + L2 logistic regression, class-balanced): its posteriors
  come straight from a log-loss fit (no separate Platt cross-validation), it has no
  hyper-parameter grid, and a fit takes milliseconds, so the 5 extra cross-validation fits the
  confusion estimate needs stay within seconds per split on one core. The RBF
  :class:`tzsl.models.AttributeSVM` of the DAP study takes seconds per EP and split even with a
  1 x 1 grid, which times 6 fits x 4 EPs x 10 splits is too slow for this evaluation.
* **Sequential posterior (tempered naive Bayes across EPs).** ``log p(z | D) = tau_D sum_{e in D}
  s_e(z) + c`` with ``s_e`` the DAP log-scores (:func:`tzsl.models.dap.dap_log_scores`) of EP ``e``'s
  fused attribute posteriors (:func:`tzsl.models.dap.fuse_attribute_posteriors`) and ``D`` the set of
  EPs done. With ``tau_D = 1`` this is Bayes' rule under the assumption that the EPs'
  observations are conditionally independent given the class; they are not (the same object is
  felt by every EP) and DAP's product over attributes is itself over-confident, so the plain
  product claims far more certainty than it has. The exponents ``tau_D`` are fitted by maximum
  likelihood (:func:`fit_posterior_exponents`) on *pseudo-unseen* classes of the training
  objects: in each of the ``cv`` object-grouped folds the held-out objects are the candidate
  classes and their trials' out-of-fold per-EP scores the evidence (the same folds as the
  confusion model; no test object is involved). ``tempering`` shares them per set of EPs
  (``"subset"``), per number of EPs (``"count"``) or not at all (``"none"``: the plain product).
* **Confusion (predictive) model.** Grouped ``cv``-fold cross-validation over the *training*
  objects gives out-of-fold fused posteriors ``p(a_m = 1 | x_e)``; per EP, attribute and true
  value ``v`` they are binned into ``n_bins`` equal bins on [0, 1] with add-``smoothing``
  counts: ``confusion_[e, m, v, b] = p(bin b | a_m = v)``. Given class ``z`` an EP's outcome is
  the vector of bins, independent across attributes given ``a^z``.
* **Policy.** Expected information gain ``I(Z; O_e) = H(pi) - E_{z ~ pi, o ~ p(o|z)} H(pi')``
  with ``pi' ∝ pi(z') p(o | z')`` under the confusion model, estimated by Monte Carlo with
  ``n_samples`` outcomes per class (common random numbers across classes and EPs); an EP whose
  confusion does not depend on the attribute values gives exactly 0. Greedy: the EP with the
  largest gain (``criterion="gain"``) or gain per second (``"gain_per_second"``).
* **Stopping rule.** Stop when the top class posterior reaches ``threshold``, when ``max_eps``
  EPs are done, when the next EP would exceed ``max_seconds``, or when no EP is left.

EP durations (:data:`PHAC2_EP_SECONDS`, seconds): hold 10 (the controller state
``HOLD_FOR_10_SECONDS``; Penn's ``pdc_area / pdc_max`` of the hold is ~960 samples at 100 Hz),
slow slide 5 and fast slide 2 (Penn controller constants ``SlowSlideTime = 5``,
``FastSlideTime = 2`` for the 5 cm slides, consistent with ``pdc_area / pdc_max`` lower bounds of
~400 and ~146 samples), squeeze 6 (not fixed by the controller: it closes 2.5 mm/s until the
pressure set-point and reopens at the same speed; 6 is the median over the 600 trials of
``4 (gripper_mean - gripper_min) / 2.5 mm/s``, rounded).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from numbers import Integral, Real

import numpy as np
from sklearn.base import BaseEstimator, _fit_context
from sklearn.model_selection import GroupKFold
from sklearn.utils._param_validation import HasMethods, Interval, StrOptions
from sklearn.utils.validation import check_is_fitted

from tzsl.exceptions import ConfigError
from tzsl.models._dap import (
    attribute_prior,
    check_class_attributes,
    fuse_attribute_posteriors,
)
from tzsl.models.active_touch._policy import (
    TEMPERINGS,
    binned_confusion,
    done_subset_index,
    expected_information_gain,
    fit_posterior_exponents,
    outcome_log_likelihoods,
    run_policy,
    sequential_log_posterior,
    stop_reasons,
)
from tzsl.models.detectors import AttributeClassifierBank, LogisticAttribute
from tzsl.models.rules import DAPRule
from tzsl.value_lists import FUSIONS

__all__ = [
    "PHAC2_EP_SECONDS",
    "TEMPERINGS",
    "LogisticAttribute",
    "PerEPAttributeModel",
    "binned_confusion",
    "ep_column_blocks",
    "expected_information_gain",
    "outcome_log_likelihoods",
    "run_policy",
    "sequential_log_posterior",
    "stop_reasons",
]

#: Duration of each PHAC-2 EP in seconds (sources in the module docstring).
PHAC2_EP_SECONDS: dict[str, float] = {"squeeze": 6.0, "hold": 10.0, "slow_slide": 5.0, "fast_slide": 2.0}


def ep_column_blocks(feature_names: Sequence[str], eps: Sequence[str] | None = None) -> dict[str, np.ndarray]:
    """Feature columns of each EP, from names ``"<ep>:<feature>"`` (e.g. ``"hold:pdc_max"``).

    Parameters
    ----------
    feature_names : sequence of str, length n_features
    eps : sequence of str, optional
        EPs to return, in this order; default: every prefix in order of first appearance.

    Returns
    -------
    dict of str -> int ndarray
        Column indices of each EP's block.
    """
    unprefixed = [n for n in feature_names if ":" not in str(n)]
    if unprefixed:
        raise ConfigError(f"feature name {unprefixed[0]!r} has no '<ep>:' prefix; per-EP models need EP-prefixed "
                          "features")
    prefixes = [str(n).partition(":")[0] for n in feature_names]
    order = list(dict.fromkeys(prefixes)) if eps is None else list(eps)
    blocks = {ep: np.flatnonzero(np.array(prefixes) == ep) for ep in order}
    empty = [ep for ep, cols in blocks.items() if cols.size == 0]
    if empty:
        raise ConfigError(f"no feature columns for EP(s) {empty}; the features have EPs {sorted(set(prefixes))}")
    return blocks


def _trainable(A: np.ndarray, groups: np.ndarray) -> np.ndarray:
    """Attributes with >= 2 objects of each value among the given trials, shape (m,) bool."""
    _, inv = np.unique(groups, return_inverse=True)
    per_object = np.zeros((inv.max() + 1, A.shape[1]))
    np.maximum.at(per_object, inv, A)  # an object's trials share its attribute row
    pos = per_object.sum(axis=0)
    return (pos >= 2) & (per_object.shape[0] - pos >= 2)


class PerEPAttributeModel(BaseEstimator):
    """One attribute-classifier bank per EP, plus the EPs' confusion from grouped CV on training objects.

    Parameters
    ----------
    ep_columns : mapping of str -> sequence of int
        Feature columns of each EP (see :func:`ep_column_blocks`); required.
    estimator : classifier or None, default=None
        Per-(attribute, sensor) template for :class:`tzsl.models.AttributeClassifierBank`;
        ``None``: :class:`LogisticAttribute`.
    ep_seconds : mapping of str -> float or None, default=None
        Duration of each EP in seconds; ``None``: :data:`PHAC2_EP_SECONDS` (must cover every EP).
    cv : int, default=5
        Object-grouped folds (shuffled ``GroupKFold``) for the out-of-fold posteriors.
    n_bins : int, default=10
        Equal-width bins of ``p(a = 1 | x_e)`` in the confusion model.
    smoothing : float, default=1.0
        Pseudo-count added to every bin.
    fusion : {"avg", "max"}, default="avg"
        Fusion of the sensors' posteriors in the DAP update (the confusion model always bins the
        sensor average).
    prior : {"uni", "train"}, default="uni"
        DAP attribute prior. ``"uni"`` matches class-balanced classifiers (their posteriors
        assume a 50% prior).
    update : {"dap", "confusion"}, default="dap"
        Per-EP class log-scores ``s_e(z)``: ``"dap"``, the DAP log-scores of the EP's fused
        posteriors; ``"confusion"``, ``sum_m log confusion_[e, m, a^z_m, bin(p_em)]``, the
        log-likelihood of the observed (binned, sensor-averaged) posteriors under the same
        confusion model the policy plans with (calibrated on training objects, so less
        over-confident than DAP).
    tempering : {"subset", "count", "none"}, default="subset"
        Exponents of the sequential posterior, fitted on pseudo-unseen training objects (module
        docstring): one per set of EPs done, one per number of EPs done, or none (plain product).
    random_state : int, RandomState or None, default=None
        Seeds the fold shuffle and the banks.

    Attributes
    ----------
    eps_ : tuple of str
    banks_ : dict of str -> AttributeClassifierBank
        Fitted on all training trials, one per EP.
    oof_posteriors_ : ndarray of shape (n_eps, n_trials, n_attributes)
        Out-of-fold sensor-averaged ``p(a = 1 | x_e)`` of the training trials; NaN where a fold's
        training part has fewer than 2 objects of either value of the attribute.
    oof_groups_ : ndarray of shape (n_trials,)
        Training groups the out-of-fold posteriors belong to (the fit's ``groups``).
    oof_folds_ : int ndarray of shape (n_trials,)
        Fold in which each training trial was held out.
    exponents_ : ndarray of shape (2 ** n_eps,)
        ``tau_D`` of each set of EPs done, indexed by :func:`done_subset_index` (entry 0: nothing done).
    tempering_trials_ : int
        Held-out training trials the exponents were fitted on.
    confusion_ : ndarray of shape (n_eps, n_attributes, 2, n_bins)
        ``p(bin | a_m = v)`` per EP; sums to 1 over bins.
    train_prior_ : ndarray of shape (n_attributes,)
    ep_seconds_ : ndarray of shape (n_eps,)
    n_attributes_, n_sensors_ : int
    """

    _parameter_constraints: dict = {
        "ep_columns": [Mapping, None],
        "estimator": [HasMethods(["fit", "predict_proba"]), None],
        "ep_seconds": [Mapping, None],
        "cv": [Interval(Integral, 2, None, closed="left")],
        "n_bins": [Interval(Integral, 2, None, closed="left")],
        "smoothing": [Interval(Real, 0, None, closed="neither")],
        "fusion": [StrOptions(set(FUSIONS))],
        "prior": [StrOptions({"uni", "train"})],
        "update": [StrOptions({"dap", "confusion"})],
        "tempering": [StrOptions(set(TEMPERINGS))],
        "random_state": ["random_state"],
    }

    def __init__(self, *, ep_columns=None, estimator=None, ep_seconds=None, cv=5, n_bins=10, smoothing=1.0,
                 fusion="avg", prior="uni", update="dap", tempering="subset", random_state=None):
        self.ep_columns = ep_columns
        self.estimator = estimator
        self.ep_seconds = ep_seconds
        self.cv = cv
        self.n_bins = n_bins
        self.smoothing = smoothing
        self.fusion = fusion
        self.prior = prior
        self.update = update
        self.tempering = tempering
        self.random_state = random_state

    def _bank(self, seed: int) -> AttributeClassifierBank:
        template = LogisticAttribute() if self.estimator is None else self.estimator
        # the default logistic fits take about as long as reading one back from the fit store: the
        # store keeps this model's whole fit instead (tzsl.fit_store.fit_cached), not its many small ones
        memory = False if self.estimator is None else None
        return AttributeClassifierBank(estimator=template, n_jobs=1, backend="sequential", random_state=seed,
                                       memory=memory)

    @_fit_context(prefer_skip_nested_validation=False)
    def fit(self, X, A, groups=None):
        """Fit the per-EP banks and the confusion model on training trials.

        Parameters
        ----------
        X : array-like of shape (n_trials, n_sensors, n_features)
        A : array-like of shape (n_trials, n_attributes)
            0/1 attribute row of each trial's object.
        groups : array-like of shape (n_trials,), optional
            Object of each trial; ``None``: every trial its own object.

        Returns
        -------
        self
        """
        if not self.ep_columns:
            raise ConfigError("ep_columns is required: the feature columns of each EP (see ep_column_blocks)")
        X = np.asarray(X, dtype=np.float64)
        if X.ndim != 3:
            raise ConfigError(f"features must have shape (n_trials, n_sensors, n_features), got {X.shape}")
        A = check_class_attributes(A, what="training attribute rows").astype(int)
        n = X.shape[0]
        groups = np.arange(n) if groups is None else np.asarray(groups)
        if A.shape[0] != n or groups.shape != (n,):
            raise ConfigError(f"X has {n} trials but A has {A.shape[0]} rows and groups {groups.shape[0]} entries")
        self.eps_ = tuple(self.ep_columns)
        cols = {ep: np.asarray(self.ep_columns[ep], dtype=np.intp) for ep in self.eps_}
        for ep, c in cols.items():
            if c.size == 0 or c.min() < 0 or c.max() >= X.shape[2]:
                raise ConfigError(f"ep_columns[{ep!r}] must index the {X.shape[2]} feature columns")
        seconds = PHAC2_EP_SECONDS if self.ep_seconds is None else self.ep_seconds
        missing = [ep for ep in self.eps_ if ep not in seconds]
        if missing:
            raise ConfigError(f"ep_seconds has no duration for EP(s) {missing}")
        self.ep_seconds_ = np.array([float(seconds[ep]) for ep in self.eps_])
        seeds = np.random.SeedSequence(np.random.RandomState(self.random_state).randint(2**31)).generate_state(
            len(self.eps_) + 1)
        self.banks_ = {ep: self._bank(int(seeds[i])).fit(X[:, :, cols[ep]], A, groups)
                       for i, ep in enumerate(self.eps_)}

        m = A.shape[1]
        oof = np.full((len(self.eps_), n, m), np.nan)
        fold_of = np.full(n, -1)
        n_folds = min(self.cv, np.unique(groups).size)
        folds = GroupKFold(n_splits=n_folds, shuffle=True, random_state=int(seeds[-1]))
        for f, (train, held) in enumerate(folds.split(X, A, groups)):
            fold_of[held] = f
            ok = _trainable(A[train], groups[train])
            if not ok.any():
                continue
            for i, ep in enumerate(self.eps_):
                bank = self._bank(int(seeds[i])).fit(X[np.ix_(train, np.arange(X.shape[1]), cols[ep])],
                                                     A[np.ix_(train, ok)], groups[train])
                oof[i, held[:, None], np.flatnonzero(ok)[None, :]] = bank.predict_proba(
                    X[np.ix_(held, np.arange(X.shape[1]), cols[ep])]).mean(axis=1)
        self.oof_posteriors_, self.oof_groups_, self.oof_folds_ = oof, groups.copy(), fold_of
        self.confusion_ = binned_confusion(oof, A, n_bins=self.n_bins, smoothing=self.smoothing)
        self.train_prior_ = attribute_prior("train", train_attributes=A, groups=groups)
        self.n_attributes_, self.n_sensors_ = m, X.shape[1]
        self.n_features_in_ = X.shape[2]
        self.exponents_ = np.ones(2 ** len(self.eps_))  # the untempered scores of the pseudo-unseen trials
        S, y, valid = self.pseudo_unseen_scores(A)
        self.exponents_ = fit_posterior_exponents(S, y, valid=valid, tempering=self.tempering)
        self.tempering_trials_ = int(y.size)
        return self

    def pseudo_unseen_scores(self, A) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Per-EP class scores of the training trials with their fold's held-out objects as the candidate classes.

        Each fold of the grouped cross-validation plays a zero-shot split on the training objects:
        its held-out objects' distinct attribute rows are the candidate (pseudo-unseen) classes,
        and their trials' out-of-fold posteriors the evidence (NaN, an attribute not trainable
        in the fold, counts as 0.5: no evidence). Folds with fewer than two distinct rows are skipped.

        Parameters
        ----------
        A : array-like of shape (n_trials, n_attributes)
            The training attribute rows given to :meth:`fit`.

        Returns
        -------
        scores : ndarray of shape (n_kept, n_eps, max_classes)
            Per-EP log-scores, padded with 0 beyond each fold's classes.
        y : int ndarray of shape (n_kept,)
            True class (column) of each trial.
        valid : bool ndarray of shape (n_kept, max_classes)
            The fold's candidate classes.
        """
        check_is_fitted(self, "oof_folds_")
        A = np.asarray(A, dtype=int)
        parts = []
        for f in np.unique(self.oof_folds_[self.oof_folds_ >= 0]):
            held = np.flatnonzero(self.oof_folds_ == f)
            K, y = np.unique(A[held], axis=0, return_inverse=True)
            if K.shape[0] < 2:
                continue
            P = np.nan_to_num(self.oof_posteriors_[:, held], nan=0.5).transpose(1, 0, 2)[:, :, None, :]
            parts.append((self.ep_log_scores(P, K), y.ravel()))
        Z = max((p[0].shape[2] for p in parts), default=0)
        S = np.zeros((sum(p[1].size for p in parts), len(self.eps_), Z))
        valid = np.zeros((S.shape[0], Z), dtype=bool)
        start = 0
        for scores, y in parts:
            S[start:start + y.size, :, :scores.shape[2]] = scores
            valid[start:start + y.size, :scores.shape[2]] = True
            start += y.size
        y = np.concatenate([p[1] for p in parts]) if parts else np.zeros(0, dtype=int)
        return S, y, valid

    def log_posterior(self, ep_scores, done, *, tempered: bool = True) -> np.ndarray:
        """:func:`sequential_log_posterior` with this model's fitted exponents (or the plain product).

        Parameters
        ----------
        ep_scores : array-like of shape (n_trials, n_eps, n_classes)
            From :meth:`ep_log_scores`.
        done : array-like of shape (n_trials, n_eps) or (n_eps,), bool
        tempered : bool, default=True
            ``False``: the untempered product (every exponent 1), for comparison.

        Returns
        -------
        ndarray of shape (n_trials, n_classes)
        """
        check_is_fitted(self, "exponents_")
        return sequential_log_posterior(ep_scores, done, self.exponents_ if tempered else None)

    def exponent(self, done) -> float:
        """The fitted exponent ``tau_D`` of one set of EPs done (bool array of shape (n_eps,))."""
        check_is_fitted(self, "exponents_")
        return float(self.exponents_[int(done_subset_index(np.asarray(done, dtype=bool)))])

    def predict_ep_proba(self, ep: str, X_ep) -> np.ndarray:
        """Attribute posteriors from one EP's feature block.

        Parameters
        ----------
        ep : str
        X_ep : array-like of shape (n_trials, n_sensors, n_ep_features)
            The EP's columns only (``X[:, :, ep_columns[ep]]``).

        Returns
        -------
        ndarray of shape (n_trials, n_sensors, n_attributes)
        """
        check_is_fitted(self)
        if ep not in self.banks_:
            raise ConfigError(f"unknown EP {ep!r}; the model knows {list(self.eps_)}")
        return self.banks_[ep].predict_proba(X_ep)

    def predict_proba(self, X) -> np.ndarray:
        """Attribute posteriors of every EP, shape (n_trials, n_eps, n_sensors, n_attributes)."""
        check_is_fitted(self)
        X = np.asarray(X, dtype=np.float64)
        return np.stack([self.predict_ep_proba(ep, X[:, :, np.asarray(self.ep_columns[ep])]) for ep in self.eps_],
                        axis=1)

    def dap_prior(self) -> np.ndarray:
        """The DAP attribute prior ``p(a_m = 1)``, shape (n_attributes,)."""
        check_is_fitted(self)
        return self.train_prior_ if self.prior == "train" else np.full(self.n_attributes_, 0.5)

    def ep_log_scores(self, P, class_attributes) -> np.ndarray:
        """Class log-scores of every EP separately (DAP or confusion log-likelihood, see ``update``).

        Parameters
        ----------
        P : array-like of shape (n_trials, n_eps, n_sensors, n_attributes)
            From :meth:`predict_proba`.
        class_attributes : array-like of shape (n_classes, n_attributes)

        Returns
        -------
        ndarray of shape (n_trials, n_eps, n_classes)
            Natural-log scores ``s_e(z)``.
        """
        check_is_fitted(self)
        P = np.asarray(P, dtype=np.float64)
        K = check_class_attributes(class_attributes, self.n_attributes_)
        if P.ndim != 4 or P.shape[1] != len(self.eps_):
            raise ConfigError(f"posteriors must have shape (n_trials, {len(self.eps_)}, n_sensors, n_attributes), "
                              f"got {P.shape}")
        # DAP through its rule, with this model's fusion and prior (an explicit prior: fitting reads only the
        # attribute count)
        rule = DAPRule(fusion=self.fusion, prior=self.dap_prior()).fit(K) if self.update != "confusion" else None
        out = []
        for e in range(P.shape[1]):
            if rule is None:
                present, _ = fuse_attribute_posteriors(P[:, e], "avg")
                bins = np.minimum((present * self.n_bins).astype(int), self.n_bins - 1)  # (n, m)
                logC = np.log(self.confusion_[e])  # (m, 2, B)
                terms = logC[np.arange(K.shape[1])[None, :, None], np.arange(2)[None, None, :], bins[:, :, None]]
                out.append(terms[:, :, 0].sum(axis=1)[:, None] + (terms[:, :, 1] - terms[:, :, 0]) @ K.T)
            else:
                out.append(rule.decision_function(P[:, e], K))
        return np.stack(out, axis=1)

    def outcome_log_likelihoods(self, class_attributes, n_samples: int = 256, random_state=0) -> np.ndarray:
        """:func:`outcome_log_likelihoods` with this model's confusion."""
        check_is_fitted(self)
        return outcome_log_likelihoods(self.confusion_, class_attributes, n_samples, random_state)
