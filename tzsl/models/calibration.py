"""Calibrated class posteriors: one temperature fitted on pseudo-unseen classes.

:class:`tzsl.models.CalibratedZeroShotClassifier` composes a zero-shot estimator with these:
the calibration choices (:data:`CALIBRATIONS`), how its folds refit the method (:data:`CALIBRATION_REFITS`),
the held-out scores of pseudo-unseen training classes (:func:`pseudo_unseen_scores`, dealt on at most about
:data:`MAX_CALIBRATION_TRIALS` training trials by default, :func:`calibration_subsample`), the temperature that
minimises their log-loss (:func:`fit_temperature`) and the tempered softmax (:func:`tempered_proba`).
"""

from tzsl.models._posterior_calibration import (
    CALIBRATION_REFITS,
    CALIBRATIONS,
    MAX_CALIBRATION_TRIALS,
    calibration_subsample,
    fit_temperature,
    pseudo_unseen_scores,
    selected_params,
    tempered_proba,
)

__all__ = ["CALIBRATION_REFITS", "CALIBRATIONS", "MAX_CALIBRATION_TRIALS", "calibration_subsample", "fit_temperature",
           "pseudo_unseen_scores", "selected_params", "tempered_proba"]
