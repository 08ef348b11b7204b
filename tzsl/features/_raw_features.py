"""Per-BioTac feature vectors from raw PHAC-2 trials (DAP paper section 4.3).

For every trial and every BioTac (finger) the vector is, in this order:

1. the 23 baseline-removed BioTac channel averages of each EP, EP-major
   (``"<ep>:pdc"``, ``"<ep>:pac"``, ``"<ep>:tac"``, ``"<ep>:tdc"``,
   ``"<ep>:e01"`` ... ``"<ep>:e19"``): 23 x n_eps values in ADC counts;
2. the 3 kinesthetic features of each EP, EP-major (``"<ep>:aperture_min"``,
   ``"<ep>:aperture_mean"``, ``"<ep>:tool_z_drop"`` or ``"<ep>:aperture_path"``):
   3 x n_eps values in metres, identical for both fingers (one gripper).

With the 4 PHAC-2 EPs: 92 + 12 = 104 features per BioTac, "concatenating features of the
4 EP [...] with the gripper's 12 features" as in the paper. Z-scoring and PCA come next
(:class:`~tzsl.features.VariancePCA`), fitted on training objects only.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.utils.validation import check_is_fitted

from tzsl.datasets import RawTrial
from tzsl.exceptions import DataFileError
from tzsl.features._baseline import (
    PHAC2_EP_NAMES,
    check_baseline_rows,
    check_eps,
    check_raw_trial,
    remove_baseline_unchecked,
    trial_error,
)
from tzsl.features._kinesthetic import kinesthetic_feature_names, kinesthetic_unchecked, resolve_travel
from tzsl.features._time_average import BIOTAC_CHANNELS, biotac_ep_means_unchecked, ep_feature_names


class RawTrialFeatures(TransformerMixin, BaseEstimator):
    """Raw trials -> one feature vector per trial and BioTac (104-d with 4 EPs).

    Pipeline per trial: checks (shapes, NaN/inf, every EP present) -> baseline removal
    (mean of the first ``baseline_rows`` rows of every BioTac signal) -> per-EP time
    averages of the 23 BioTac channels -> per-EP gripper features, appended to both
    fingers. Nothing is learned from the data except the number of fingers and the
    travelled-distance source (``travel="auto"``), so ``fit`` on training trials and
    ``transform`` on test trials is leak-free. Trials have different lengths: input is a
    list, and the work is vectorised within each trial over rows and channels.

    Parameters
    ----------
    eps : sequence of str, default ("squeeze", "hold", "slow_slide", "fast_slide")
        Exploratory procedures, in output order; ``("hold",)`` for the HOLD-only files.
    baseline_rows : int, default 100
        Leading 100 Hz rows of each recording averaged as the BioTac baseline.
    travel : {"auto", "tool_z", "aperture"}, default "auto"
        Source of the travelled distance; see :mod:`tzsl.features._kinesthetic`.

    Attributes
    ----------
    n_fingers_ : int
        BioTacs per trial (2 on the PR2); ``transform`` requires the same.
    travel_ : {"tool_z", "aperture"}
        Resolved travelled-distance source.
    feature_names_out_ : ndarray of str, shape (26 * n_eps,)
        Names of the output columns (module docstring).
    """

    def __init__(
        self,
        eps: Sequence[str] = PHAC2_EP_NAMES,
        baseline_rows: int = 100,
        travel: str = "auto",
    ) -> None:
        self.eps = eps
        self.baseline_rows = baseline_rows
        self.travel = travel

    def fit(self, X: Sequence[RawTrial], y: object = None) -> "RawTrialFeatures":
        """Check parameters, record the finger count and resolve ``travel``. Returns self.

        Parameters
        ----------
        X : sequence of RawTrial, length n_trials >= 1
        y : ignored
        """
        eps = check_eps(self.eps)
        check_baseline_rows(self.baseline_rows)
        if len(X) == 0:
            raise DataFileError(None, "no trials to extract features from")
        check_raw_trial(X[0])
        for trial in X:
            if not isinstance(trial, RawTrial):
                raise DataFileError(None, f"expected RawTrial objects, got {type(trial).__name__}")
        self.n_fingers_ = len(X[0].fingers)
        self.travel_ = resolve_travel(self.travel, X)
        self.feature_names_out_ = np.asarray(
            ep_feature_names(eps, BIOTAC_CHANNELS)
            + ep_feature_names(eps, kinesthetic_feature_names(self.travel_)),
            dtype=object,
        )
        return self

    def transform(self, X: Sequence[RawTrial]) -> np.ndarray:
        """Feature vectors of every trial and BioTac.

        Parameters
        ----------
        X : sequence of RawTrial, length n_trials

        Returns
        -------
        ndarray of float64, shape (n_trials, n_fingers, 26 * n_eps)
            Per finger: 23 * n_eps BioTac averages (ADC counts relative to the baseline)
            then 3 * n_eps gripper features (metres, same for every finger).

        Raises
        ------
        DataFileError
            Naming file and trial: fewer than ``baseline_rows`` rows, an EP absent, a
            missing finger or malformed signal, NaN/inf, a missing ``tool_z`` when
            ``travel_ == "tool_z"``.
        """
        check_is_fitted(self)
        eps = check_eps(self.eps)
        n_eps = len(eps)
        out = np.empty((len(X), self.n_fingers_, 26 * n_eps))
        for i, trial in enumerate(X):
            check_raw_trial(trial, self.n_fingers_)
            clean = remove_baseline_unchecked(trial, self.baseline_rows)
            out[i, :, : 23 * n_eps] = biotac_ep_means_unchecked(clean, eps).reshape(self.n_fingers_, -1)
            out[i, :, 23 * n_eps :] = kinesthetic_unchecked(trial, eps, self.travel_).ravel()[None, :]
            if not np.isfinite(out[i]).all():
                raise trial_error(trial, "features are not finite (overflow in the signals?)")
        return out

    def get_feature_names_out(self, input_features: object = None) -> np.ndarray:
        """Output feature names, shape (26 * n_eps,)."""
        check_is_fitted(self)
        return self.feature_names_out_.copy()
