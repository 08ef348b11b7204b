"""The cross-trial-comparable columns of the Penn static features, split per BioTac.

Penn's 47 static features per trial and EP (PROVENANCE.md section 3) are:

======  ==========================  ==================================================
column  name                        kept?
======  ==========================  ==================================================
0-1     pdc_rise_count  [f0, f1]    yes, per finger
2-3     pdc_area        [f0, f1]    yes, per finger
4-5     pdc_max         [f0, f1]    yes, per finger
6-7     pac_energy      [f0, f1]    yes, per finger
8-9     pac_sc (spectral centroid)  yes, per finger
10-11   pac_sv (spectral variance)  yes, per finger
12-13   pac_ss (spectral skewness)  yes, per finger
14-15   pac_sk (spectral kurtosis)  yes, per finger
16-17   tac_area        [f0, f1]    yes, per finger
18-19   tdc_exp_fit_tau [f0, f1]    yes, per finger
20      gripper_min                 yes, shared by both fingers
21      gripper_mean                yes, shared
22      transform_distance          yes, shared (tool-height drop over the EP)
23-46   electrode_polyfit           **dropped**
======  ==========================  ==================================================

Columns 23-46 are polynomial coefficients fitted to the first principal components of the
electrodes, with the PCA fitted *per trial and EP* - component 1 of one trial is not
component 1 of another (arbitrary sign and direction), so these numbers are not
comparable across trials and would feed noise to any classifier.

Per finger and EP this leaves 10 BioTac + 3 gripper = 13 features; with 4 EPs 52 per
finger. Output order is EP-major: the 13 features of ``eps[0]``, then ``eps[1]``, ...;
names ``"<ep>:<feature>"``, e.g. ``"hold:pdc_max"``.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.utils.validation import check_is_fitted

from tzsl.datasets import PHAC2_EPS
from tzsl.exceptions import DataFileError
from tzsl.features._baseline import PHAC2_EP_NAMES, check_eps

#: Number of Penn static features per trial and EP.
PENN_N_COLUMNS = 47

#: Per-finger Penn features and their (finger_0, finger_1) column pair.
PENN_FINGER_COLUMNS: dict[str, tuple[int, int]] = {
    "pdc_rise_count": (0, 1),
    "pdc_area": (2, 3),
    "pdc_max": (4, 5),
    "pac_energy": (6, 7),
    "pac_sc": (8, 9),
    "pac_sv": (10, 11),
    "pac_ss": (12, 13),
    "pac_sk": (14, 15),
    "tac_area": (16, 17),
    "tdc_exp_fit_tau": (18, 19),
}

#: Gripper / tool features shared by both fingers, and their column.
PENN_SHARED_COLUMNS: dict[str, int] = {
    "gripper_min": 20,
    "gripper_mean": 21,
    "transform_distance": 22,
}

#: Columns dropped: per-trial electrode-PCA polynomial coefficients (not comparable).
PENN_DROPPED_COLUMNS: tuple[int, ...] = tuple(range(23, 47))

#: Per-finger, per-EP feature names in output order (13).
PENN_FEATURES_PER_EP: tuple[str, ...] = tuple(PENN_FINGER_COLUMNS) + tuple(PENN_SHARED_COLUMNS)

_STATE_TO_EP = {state: ep for ep, state in PHAC2_EPS.items()}


def penn_column_index(n_fingers: int = 2) -> np.ndarray:
    """Source column of every output feature of one EP, per finger.

    Returns
    -------
    ndarray of int, shape (n_fingers, 13)
        ``index[f, j]`` is the Penn column of feature ``PENN_FEATURES_PER_EP[j]`` for
        finger ``f`` (the shared columns repeat for every finger).
    """
    shared = list(PENN_SHARED_COLUMNS.values())
    return np.array(
        [[pair[f] for pair in PENN_FINGER_COLUMNS.values()] + shared for f in range(n_fingers)]
    )


def short_ep_names(eps: Sequence[str]) -> tuple[str, ...]:
    """Map ``controller_detail_state`` strings to short EP names; keep other names."""
    return tuple(_STATE_TO_EP.get(str(ep), str(ep)) for ep in eps)


def select_penn_columns(
    X: np.ndarray, eps: Sequence[str] = PHAC2_EP_NAMES
) -> tuple[np.ndarray, list[str]]:
    """Keep the comparable Penn columns and split them per finger.

    Parameters
    ----------
    X : array-like of shape (n_trials, n_eps, 47)
        Penn static features [trial, EP, feature] (units as in Penn's files).
    eps : sequence of str, length n_eps
        Names of the EPs along axis 1 (short names such as ``"hold"`` or the
        ``controller_detail_state`` strings, which are mapped to short names).

    Returns
    -------
    features : ndarray of float64, shape (n_trials, 2, 13 * n_eps)
        ``features[:, f]`` holds finger ``f``'s 10 BioTac features and the 3 shared
        gripper features of every EP, EP-major.
    names : list of str, length 13 * n_eps
        ``"<ep>:<feature>"``.

    Raises
    ------
    DataFileError
        Wrong shape, or NaN/inf entries (names the first bad trial row).
    """
    eps = short_ep_names(check_eps(eps))
    X = np.asarray(X)
    if X.ndim != 3 or X.shape[1] != len(eps) or X.shape[2] != PENN_N_COLUMNS:
        raise DataFileError(
            None,
            f"Penn static features have shape {X.shape}; expected (n_trials, {len(eps)}, "
            f"{PENN_N_COLUMNS})",
        )
    if X.dtype.kind not in "iuf":
        raise DataFileError(None, f"Penn static features are not numeric (dtype {X.dtype})")
    X = X.astype(np.float64, copy=False)
    bad = ~np.isfinite(X)
    if bad.any():
        i, e, c = np.argwhere(bad)[0]
        raise DataFileError(
            None, f"Penn static feature column {c} of EP {eps[e]!r} is NaN/inf in trial row {i}"
        )
    index = penn_column_index(2)  # (2, 13)
    out = X[:, :, index]  # (n_trials, n_eps, 2, 13)
    out = out.transpose(0, 2, 1, 3).reshape(X.shape[0], 2, -1)
    names = [f"{ep}:{name}" for ep in eps for name in PENN_FEATURES_PER_EP]
    return np.ascontiguousarray(out), names


class PennColumnSelector(TransformerMixin, BaseEstimator):
    """Penn static features (n_trials, n_eps, 47) -> per-finger (n_trials, 2, 13 * n_eps).

    Stateless wrapper around :func:`select_penn_columns` (see the module docstring for
    the kept columns and why 23-46 are dropped). Input and output are 3-D, so
    scikit-learn's ``check_estimator`` (2-D arrays) does not apply; the selection itself
    is tested on hand-made tensors.

    Parameters
    ----------
    eps : sequence of str, default ("squeeze", "hold", "slow_slide", "fast_slide")
        EP names along axis 1 of the input.

    Attributes
    ----------
    feature_names_out_ : ndarray of str, shape (13 * n_eps,)
    """

    def __init__(self, eps: Sequence[str] = PHAC2_EP_NAMES) -> None:
        self.eps = eps

    def fit(self, X, y=None) -> "PennColumnSelector":
        """Check the input shape and record output names. Returns self."""
        _, names = select_penn_columns(X, self.eps)
        self.feature_names_out_ = np.asarray(names, dtype=object)
        return self

    def transform(self, X) -> np.ndarray:
        """Select and split; see :func:`select_penn_columns`.

        Returns
        -------
        ndarray of float64, shape (n_trials, 2, 13 * n_eps)
        """
        check_is_fitted(self)
        out, _ = select_penn_columns(X, self.eps)
        return out

    def get_feature_names_out(self, input_features: object = None) -> np.ndarray:
        """Output feature names, shape (13 * n_eps,)."""
        check_is_fitted(self)
        return self.feature_names_out_.copy()

