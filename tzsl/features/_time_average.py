"""Per-EP time averages of the 23 BioTac signals of every finger (DAP paper section 4.3).

"Next, the average of each signal was computed over the exploration time." For each
finger and each exploratory procedure (EP) the 23 values are, in this order:

``pdc``, ``pac``, ``tac``, ``tdc``, ``e01`` ... ``e19``

``pac`` is averaged over the EP's rows *and* its 22 sub-samples per row (one 2200 Hz
signal); every other signal over the EP's rows. Values are in the units of the input:
raw ADC counts, or ADC counts relative to the baseline after
:func:`~tzsl.features.remove_baseline`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.utils.validation import check_is_fitted

from tzsl.datasets import RawTrial
from tzsl.exceptions import DataFileError
from tzsl.features._baseline import PHAC2_EP_NAMES, check_eps, check_raw_trial, ep_masks

#: The 23 per-finger BioTac channels, in feature order.
BIOTAC_CHANNELS: tuple[str, ...] = ("pdc", "pac", "tac", "tdc") + tuple(
    f"e{i:02d}" for i in range(1, 20)
)


def biotac_channel_matrix(trial: RawTrial) -> np.ndarray:
    """Stack every finger's signals into one array of 23 channels per row.

    Parameters
    ----------
    trial : RawTrial
        A checked trial (see :func:`~tzsl.features.check_raw_trial`).

    Returns
    -------
    ndarray of float64, shape (n_fingers, n, 23)
        Channels in :data:`BIOTAC_CHANNELS` order; the ``pac`` channel is the mean of
        the row's 22 sub-samples. Units as in the trial (ADC counts).
    """
    mats = []
    for finger in trial.fingers:
        mats.append(
            np.column_stack(
                [
                    np.asarray(finger.pdc, dtype=np.float64),
                    np.mean(finger.pac, axis=1, dtype=np.float64),
                    np.asarray(finger.tac, dtype=np.float64),
                    np.asarray(finger.tdc, dtype=np.float64),
                    np.asarray(finger.electrodes, dtype=np.float64),
                ]
            )
        )
    return np.stack(mats)


def biotac_ep_means(trial: RawTrial, eps: Sequence[str] = PHAC2_EP_NAMES) -> np.ndarray:
    """Time average of the 23 BioTac channels of every finger over every EP.

    Parameters
    ----------
    trial : RawTrial
        One trial (checked here).
    eps : sequence of str, length n_eps
        EP names (keys of :data:`~tzsl.datasets.PHAC2_EPS`) or raw state strings.

    Returns
    -------
    ndarray of float64, shape (n_fingers, n_eps, 23)
        ``out[f, e, c]`` = mean of channel ``BIOTAC_CHANNELS[c]`` of finger ``f`` over the
        rows of EP ``eps[e]`` (ADC counts). Because every row has 22 PAC sub-samples, the
        mean of the per-row PAC means equals the mean over all sub-samples.

    Raises
    ------
    DataFileError
        A malformed trial, or an EP without rows (names file, trial and EP).
    """
    eps = check_eps(eps)
    check_raw_trial(trial)
    return biotac_ep_means_unchecked(trial, eps)


def biotac_ep_means_unchecked(trial: RawTrial, eps: tuple[str, ...]) -> np.ndarray:
    """:func:`biotac_ep_means` of an already checked trial."""
    masks = ep_masks(trial, eps).astype(np.float64)  # (n_eps, n)
    channels = biotac_channel_matrix(trial)  # (n_fingers, n, 23)
    sums = np.einsum("en,fnc->fec", masks, channels)
    return sums / masks.sum(axis=1)[None, :, None]


def ep_feature_names(eps: Sequence[str], names: Sequence[str]) -> list[str]:
    """``"<ep>:<name>"`` for every EP (outer) and name (inner)."""
    return [f"{ep}:{name}" for ep in eps for name in names]


class BiotacTimeAverage(TransformerMixin, BaseEstimator):
    """Per-EP time averages of the 23 BioTac channels, one vector per finger.

    A stateless transformer on lists of :class:`~tzsl.datasets.RawTrial` (trials have
    different lengths). Apply :class:`~tzsl.features.BaselineRemover` first to follow
    the paper.

    Parameters
    ----------
    eps : sequence of str, default ("squeeze", "hold", "slow_slide", "fast_slide")
        Exploratory procedures, in output order.

    Attributes
    ----------
    n_fingers_ : int
        Number of BioTacs per trial seen in ``fit``; ``transform`` requires the same.
    feature_names_out_ : ndarray of str, shape (23 * n_eps,)
        ``"<ep>:<channel>"``, EP-major (the 23 channels of ``eps[0]`` first).
    """

    def __init__(self, eps: Sequence[str] = PHAC2_EP_NAMES) -> None:
        self.eps = eps

    def fit(self, X: Sequence[RawTrial], y: object = None) -> "BiotacTimeAverage":
        """Record the number of fingers and the output names. Returns self."""
        eps = check_eps(self.eps)
        if len(X) == 0:
            raise DataFileError(None, "no trials to extract features from")
        check_raw_trial(X[0])
        self.n_fingers_ = len(X[0].fingers)
        self.feature_names_out_ = np.asarray(ep_feature_names(eps, BIOTAC_CHANNELS), dtype=object)
        return self

    def transform(self, X: Sequence[RawTrial]) -> np.ndarray:
        """Time averages of every trial.

        Parameters
        ----------
        X : sequence of RawTrial, length n_trials

        Returns
        -------
        ndarray of float64, shape (n_trials, n_fingers, 23 * n_eps)
            Means in ADC counts, EP-major (see ``feature_names_out_``).
        """
        check_is_fitted(self)
        eps = check_eps(self.eps)
        out = np.empty((len(X), self.n_fingers_, 23 * len(eps)))
        for i, trial in enumerate(X):
            check_raw_trial(trial, self.n_fingers_)
            out[i] = biotac_ep_means_unchecked(trial, eps).reshape(self.n_fingers_, -1)
        return out

    def get_feature_names_out(self, input_features: object = None) -> np.ndarray:
        """Output feature names, shape (23 * n_eps,)."""
        check_is_fitted(self)
        return self.feature_names_out_.copy()
