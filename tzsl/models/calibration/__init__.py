"""Calibrated class posteriors: one temperature fitted on pseudo-unseen classes.

The room of a calibrator. :class:`CalibratedZeroShotClassifier` composes a zero-shot estimator with these:
the calibration choices (:data:`CALIBRATIONS`), how its folds refit the method (:data:`CALIBRATION_REFITS`),
the held-out scores of pseudo-unseen training classes (:func:`pseudo_unseen_scores`, dealt on at most about
:data:`MAX_CALIBRATION_TRIALS` training trials by default, :func:`calibration_subsample`), the temperature that
minimises their log-loss (:func:`fit_temperature`) and the tempered softmax (:func:`tempered_proba`); it warns
with :class:`CalibrationWarning` when too few training classes leave nothing to fit on. The two classes are also
at the top of :mod:`tzsl.models`. Ensembles of methods are :mod:`tzsl.models.ensemble`.
"""

from tzsl.models._pseudo_unseen import MAX_CALIBRATION_TRIALS, calibration_subsample, pseudo_unseen_scores
from tzsl.models.calibration._posterior_calibration import (
    CALIBRATION_REFITS,
    CALIBRATIONS,
    CalibratedZeroShotClassifier,
    CalibrationWarning,
    fit_temperature,
    selected_params,
    tempered_proba,
)

__all__ = ["CALIBRATION_REFITS", "CALIBRATIONS", "MAX_CALIBRATION_TRIALS", "CalibratedZeroShotClassifier",
           "CalibrationWarning", "calibration_subsample", "fit_temperature", "pseudo_unseen_scores", "selected_params",
           "tempered_proba"]
