"""Stacked and sparse attribute detectors on PHAC-2 (issue 32, item 2): two hypotheses, one decision rule.

Hypotheses (stated before any run on selection splits)
------------------------------------------------------
H_stack, "leave-one-object-out stacking of detectors": DAP reads attribute ``a`` from ``a``'s
detector alone. Attributes co-occur across objects (hard and squishy, smooth and rough), so the
other attributes' detectors carry evidence about ``a``; and a second stage trained on *held-out*
detector logits (each training object scored by detectors that never saw it) sees the errors an
unseen object's logits have, not the in-sample ones. A second stage per attribute, predicting ``a``
from the vector of ALL attributes' held-out fused logits of the ``dap-avg-logistic-c1`` detectors,
then DAP over its posteriors (method ``stack``), beats ``dap-avg-logistic-c1``.

H_sparse: an L1 logistic detector (method ``sparse``) in place of the L2 ``logistic-c1`` one: a
detector that reads fewer features may encode less of the training objects' identity, so its
errors on an unseen object come less together, and DAP (AVG fusion, uniform prior) over it beats
``dap-avg-logistic-c1``.

Choices fixed before measuring
------------------------------
* Reference and first stage: the registered ``dap-avg-logistic-c1``
  (:func:`~tzsl.studies.zero_shot.methods.fit_predict_split`, bare, the study's seed
  ``study seed + split index``); its predictions are the reference. Its held-out and test fused
  logits, the error-structure measures and the fold construction are those of
  ``phac2_correlated_dap.py`` (imported, not copied): :func:`held_out_logits` (10 object-grouped
  folds of the training objects), :func:`fused_logits` (logit of the AVG-fused posterior, clipped
  to ``[1e-6, 1 - 1e-6]``), :func:`class_means`, :func:`residuals`, :func:`error_structure`; its
  per-split cache ``<split>.npz`` (``S_oof``) is read when present in ``--out``.
* ``stack``: for each attribute ``a`` of the split, ``LogisticRegression`` (L2, intercept,
  ``class_weight="balanced"`` so that its posterior is for a 50% attribute prior, as the detectors'
  and DAP's uniform prior are; lbfgs) of ``a`` on the raw held-out logits ``S_oof`` (n_train, m) of
  all ``m`` attributes, ``a``'s own included; a missing held-out logit (an attribute not fitted in
  a fold) is 0 (no evidence). Raw logits, not z-scored: they share one scale, and a confident
  detector's larger spread should cost less penalty. ``C`` is one value per split for all
  attributes from ``STACK_C_GRID = (0.01, 0.1, 1.0)``, the one with the lowest mean over attributes
  of the class-balanced log-loss of the stage's out-of-fold posteriors in 5 object-grouped folds of
  the training objects (:func:`tzsl.models.protocol.class_grouped_folds`; an attribute present or
  absent in fewer than 2 trials of a fold's training part is left out of that fold); ties go to
  the smaller ``C``. The stage is refitted on all training trials at that ``C`` and applied to
  the test trials' fused logits of the final detectors. DAP: ``sum_a log p(a = K[c, a] | x)``
  (uniform prior, :func:`tzsl.models.dap.dap_log_scores`), ties broken with the split's seed.
* ``stack-own`` (diagnostic, never adopted): the same stage with ``a``'s own logit as its only
  input, a per-attribute recalibration on held-out logits; ``stack`` minus ``stack-own`` is what
  the other attributes add.
* ``sparse``: :class:`SparseLogisticAttribute` per (attribute, sensor) in an
  :class:`~tzsl.models.AttributeClassifierBank` (``solver="exact"``, ``random_state`` = the split's
  seed): z-scored features, ``LogisticRegression(l1_ratio=1, solver="liblinear",
  class_weight="balanced")`` (L1), ``C`` from ``SPARSE_C_GRID = (0.01, 0.03, 0.1, 0.3, 1.0)`` by 5
  object-grouped stratified folds (``StratifiedGroupKFold``, at most the rarer class's number of
  objects) of the detector's training trials, lowest class-balanced log-loss of the out-of-fold
  posteriors, ties to the smaller ``C``; the posterior is the refitted model's own. DAP as above
  (AVG fusion, uniform prior). Its held-out logits (for the error structure only) come from the
  same 10 folds with each detector's ``C`` pinned at its full-training choice.

Decision rule (fixed before running on selection splits)
--------------------------------------------------------
As ``phac2_correlated_dap.py``'s: on the selection splits (20 random splits, ``--purpose select
--seed 0``, and the 5 challenging splits) the criterion of a method is the mean of its random-split
accuracy and its challenging-split accuracy (each the mean over splits,
:func:`tzsl.evaluation.bootstrap_accuracy`'s point). ``stack`` (H_stack) is adopted if its criterion
is higher than ``dap-avg-logistic-c1``'s; ``sparse`` (H_sparse) by the same rule; if both pass, the
higher criterion is adopted. Only an adopted method is run once on confirmation splits
(``--purpose confirm --seed 32 --n-random 50`` and every challenging split, ``--references``
adding ``dap-avg`` and ``eszsl``, paired intervals). Nothing is registered by this script.

Measurements
------------
(a) per method (``c1``: the reference's detectors, ``stack``, ``stack-own``, ``sparse``), the error
structure of its held-out training logits (``oof_``) and test logits (``test_``, residuals against
the class means of its held-out logits) as ``phac2_correlated_dap.py``'s ``error_structure.csv``
(``between_share``, ``obj_corr``, ``obj_abs_corr``, ``obj_err_corr``, ``within_corr``,
``error_dispersion``), and ``test_error_corr01`` (:func:`tzsl.evaluation.within_object_error_correlation`);
the chosen ``C`` values and the sparse detectors' mean number of nonzero coefficients.
(b) per-trial correctness of every method; ``summary.csv`` (accuracy [two-level bootstrap 95%
interval] per kind and method, paired difference to each reference), ``decision.csv``.
"""
