"""Multi-label attribute classifier: attributes modelled jointly by a classifier chain (F8).

The DAP paper (§4.4) compares its independent per-attribute SVMs with a multi-label SVM from
scikit-multilearn that drops the independence assumption (the paper's two accuracies are
``DAP_INDEPENDENT_ACCURACY`` and ``DAP_MULTILABEL_ACCURACY`` of :mod:`tzsl.studies.papers.numbers`). scikit-
multilearn is unmaintained, so the joint model here is a **classifier chain** (Read et al., 2011;
the same idea as :class:`sklearn.multioutput.ClassifierChain`) per sensor:

* attributes are put in an order (random, seeded, or given);
* the classifier of the ``t``-th attribute sees the sensor features *and* the previous attributes
  ``a_{order[0]}, ..., a_{order[t-1]}`` (true 0/1 values when training);
* at prediction the previous attributes' *posteriors* are fed in, so ``p(a_t | x, a_<t)`` depends
  on the other attributes.

Each link is the same detector as the independent model (``detector``; by default the
:class:`AttributeSVM`: under-sampling, grouped tuning, Platt), whose preprocessor (z-score and PCA
for the SVM, z-score for a linear detector) transforms the sensor features and passes the chained
attribute columns through unchanged. Training links are independent (true labels are inputs), so
they run in parallel and are cached exactly like :class:`AttributeClassifierBank`; only prediction
walks the chain. Output has the same (n_trials, n_sensors, n_attributes) layout, so DAP uses it
unchanged.
"""

from __future__ import annotations

import numpy as np
from sklearn.base import clone
from sklearn.compose import ColumnTransformer
from sklearn.utils import check_random_state
from sklearn.utils._param_validation import StrOptions

from tzsl._fit_store import array_digest, resolve_store, spawn_seeds
from tzsl._profile import timed
from tzsl.exceptions import ConfigError
from tzsl.models.detectors._attribute_bank import AttributeClassifierBank
from tzsl.models.detectors._families import AUTO_CANDIDATES, detector_preprocessor

__all__ = ["MultiLabelAttributeClassifier"]


def _chain_preprocessor(base, n_features: int) -> ColumnTransformer:
    """Preprocess the sensor columns with ``base``; pass chained attribute columns through."""
    return ColumnTransformer(
        [("features", base, slice(0, n_features))], remainder="passthrough", sparse_threshold=0.0
    )


class MultiLabelAttributeClassifier(AttributeClassifierBank):
    """Classifier chain over per-attribute RBF-SVMs, one chain per sensor.

    Parameters
    ----------
    estimator : AttributeSVM-like or None, default=None
        Link template of ``detector="rbf-svm"`` (``fit(X, y, groups)``, ``predict_proba``, a
        ``preprocessor`` parameter). ``None``: :class:`AttributeSVM` defaults. Its preprocessor is
        applied to the sensor columns only.
    detector, detector_candidates
        The links' family, as in :class:`AttributeClassifierBank` (``"auto"`` scores the chain
        itself on pseudo-unseen training classes).
    order : None, "random" or sequence of int, default=None
        Chain order. ``None`` or ``"random"``: a random permutation from ``random_state``.
    attribute_names, n_jobs, backend, memory, progress, random_state
        As in :class:`AttributeClassifierBank`.

    Attributes
    ----------
    order_ : ndarray of shape (n_attributes,)
    estimators_ : list of list
        ``estimators_[t][s]``: link ``t`` of the chain (attribute ``order_[t]``) on sensor ``s``.
    """

    _parameter_constraints: dict = {  # the chain always fits its template exactly: no solver choice
        **{k: v for k, v in AttributeClassifierBank._parameter_constraints.items()
           if k not in ("solver", "max_exact_trials", "estimator_params")},
        "order": [None, StrOptions({"random"}), "array-like"],
    }

    def __init__(
        self,
        *,
        estimator=None,
        detector="rbf-svm",
        detector_candidates=AUTO_CANDIDATES,
        order=None,
        attribute_names=None,
        n_jobs=None,
        backend="loky",
        memory=None,
        progress=False,
        random_state=None,
    ):
        super().__init__(
            estimator=estimator,
            detector=detector,
            detector_candidates=detector_candidates,
            attribute_names=attribute_names,
            n_jobs=n_jobs,
            backend=backend,
            memory=memory,
            progress=progress,
            random_state=random_state,
        )
        self.order = order

    @timed("fit")
    def fit(self, X, A, groups=None):
        """Fit every link of every sensor's chain.

        Parameters
        ----------
        X : array-like of shape (n_trials, n_sensors, n_features)
        A : array-like of shape (n_trials, n_attributes)
            0/1 attribute targets.
        groups : array-like of shape (n_trials,), optional
            Object of each trial.

        Returns
        -------
        self
        """
        self._validate_params()
        X, A, names = self._check_fit_input(X, A)
        n, s, d = X.shape
        m = A.shape[1]
        seeds = spawn_seeds(self.random_state, m * s + 1)
        if self.order is None or (isinstance(self.order, str) and self.order == "random"):
            order = check_random_state(seeds[-1]).permutation(m)
        else:
            order = np.asarray(self.order, dtype=int)
            if sorted(order.tolist()) != list(range(m)):
                raise ConfigError(f"order must be a permutation of 0..{m - 1}, got {self.order!r}")
        self._choose_detector(X, A, groups)
        template = self._template()
        base_pre = detector_preprocessor(template)
        storing = resolve_store(self.memory).enabled
        groups_digest = array_digest(np.zeros(0) if groups is None else groups) if storing else None
        targets = [np.ascontiguousarray(A[:, j]) for j in range(m)]
        templates, data, digests = [], [], []
        for t, j in enumerate(order):
            prev = A[:, order[:t]].astype(float)
            for k in range(s):
                link = {"preprocessor": _chain_preprocessor(clone(base_pre), d), "random_state": seeds[t * s + k],
                        "name": f"{names[j]} (sensor {k}, chain position {t})"}
                # an untuned family (logistic-c1) has no preprocessor, seed or name: it z-scores every input itself
                est = clone(template).set_params(**{key: v for key, v in link.items() if key in template.get_params()})
                inputs = np.hstack([X[:, k, :], prev])
                templates.append(est)
                data.append((inputs, targets[j], groups))
                digests.append((array_digest(inputs), array_digest(targets[j]), groups_digest) if storing else None)
        fitted = self._fit_stored(templates, data, digests, "chain fits")
        self.estimators_ = [fitted[t * s : (t + 1) * s] for t in range(m)]
        self.order_ = order
        self.n_sensors_, self.n_attributes_, self.n_features_in_ = s, m, d
        return self

    @timed("predict")
    def predict_proba(self, X) -> np.ndarray:
        """Attribute posteriors, walking each sensor's chain.

        Parameters
        ----------
        X : array-like of shape (n_trials, n_sensors, n_features)

        Returns
        -------
        ndarray of shape (n_trials, n_sensors, n_attributes)
            ``p(a_m = 1 | x_s)`` with earlier attributes' posteriors as chain inputs.
        """
        X = self._check_predict_input(X)
        P = np.empty((X.shape[0], self.n_sensors_, self.n_attributes_))
        for k in range(self.n_sensors_):
            for t, j in enumerate(self.order_):
                prev = P[:, k, self.order_[:t]]
                P[:, k, j] = self.estimators_[t][k].predict_proba(np.hstack([X[:, k, :], prev]))[:, 1]
        return P
