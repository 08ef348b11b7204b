"""Calibrated class posteriors: one temperature fitted on pseudo-unseen classes.

:class:`tzsl.models.CalibratedZeroShotClassifier` composes a zero-shot estimator with these:
the calibration choices (:data:`CALIBRATIONS`), the held-out scores of pseudo-unseen training
classes (:func:`pseudo_unseen_scores`), the temperature that minimises their log-loss
(:func:`fit_temperature`) and the tempered softmax (:func:`tempered_proba`).
"""

from tzsl.models._posterior_calibration import CALIBRATIONS, fit_temperature, pseudo_unseen_scores, tempered_proba

__all__ = ["CALIBRATIONS", "fit_temperature", "pseudo_unseen_scores", "tempered_proba"]
