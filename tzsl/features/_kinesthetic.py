"""Kinesthetic (gripper) features per exploratory procedure (DAP paper section 4.3).

"As in [1], we considered the minimum gripper aperture, mean aperture and travelled
distance for each exploration as features" - 3 features per EP, 12 for the 4 EPs.

Per EP, in this order:

``aperture_min``
    Minimum of the gripper joint position over the EP's rows (m). Penn's
    ``gripper_min`` (static column 20).
``aperture_mean``
    Mean of the gripper joint position over the EP's rows (m). Penn's ``gripper_mean``
    (column 21).
``tool_z_drop`` or ``aperture_path`` - the travelled distance (m), see below.

Travelled distance: what we chose and why
-----------------------------------------
Reference [1] of the DAP paper is the PHAC-2 / Penn work (Chu et al.), whose third
kinesthetic feature is ``transform_distance``: the drop of the *tool frame height*
during the EP, ``z[first row of the EP] - min(z over the EP)`` (Penn-haptics-bolt,
``upenn_features.transform_features``; PROVENANCE.md section 3, column 22). Section 4.1
of the paper also lists the gripper height ``Z_g`` among the kinesthetic inputs, and the
Penn values confirm the meaning: about 0 during squeeze and hold, 1.4-4.3 cm during the
two 5 cm slides. So the paper's "travelled distance" is the tool's travel, and with
``travel="tool_z"`` we compute exactly Penn's quantity from ``RawTrial.tool_z``, so raw
features line up with the Penn static features.

Recordings without the tool height (the HOLD-only MATLAB files have no transforms) cannot
give that quantity. For them ``travel="aperture"`` measures the distance travelled by the
gripper joint instead: the path length ``sum |a[i+1] - a[i]|`` over consecutive rows
that both belong to the EP (m). This is a different quantity and is named differently
(``aperture_path``), never silently substituted: ``travel="auto"`` (default) picks
``"tool_z"`` when every fitted trial has ``tool_z`` and ``"aperture"`` when none has it,
raises on a mix, and records the choice in ``travel_`` and in the feature names.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.utils.validation import check_is_fitted

from tzsl.datasets import RawTrial
from tzsl.exceptions import ConfigError, DataFileError
from tzsl.features._baseline import PHAC2_EP_NAMES, check_eps, check_raw_trial, ep_masks, trial_error
from tzsl.features._time_average import ep_feature_names

#: Feature name of the travelled distance for each ``travel`` source.
TRAVEL_FEATURE: dict[str, str] = {"tool_z": "tool_z_drop", "aperture": "aperture_path"}


def kinesthetic_feature_names(travel: str) -> tuple[str, str, str]:
    """The 3 per-EP kinesthetic feature names for a resolved ``travel`` source."""
    return ("aperture_min", "aperture_mean", TRAVEL_FEATURE[travel])


def resolve_travel(travel: str, trials: Sequence[RawTrial]) -> str:
    """Resolve ``travel="auto"`` against the trials: ``"tool_z"`` or ``"aperture"``.

    Raises
    ------
    ConfigError
        ``travel`` is not ``"auto"``, ``"tool_z"`` or ``"aperture"``.
    DataFileError
        ``"auto"`` on trials of which some have ``tool_z`` and some not (names the first
        trial without it).
    """
    if travel not in ("auto", "tool_z", "aperture"):
        raise ConfigError(f"travel must be 'auto', 'tool_z' or 'aperture', got {travel!r}")
    if travel != "auto":
        return travel
    has = [t.tool_z is not None for t in trials]
    if all(has):
        return "tool_z"
    if not any(has):
        return "aperture"
    missing = trials[has.index(False)]
    raise trial_error(
        missing,
        "trial has no tool_z while other trials have one; the travelled distance would "
        "mix two quantities (pass travel='aperture' to use the gripper path for all)",
    )


def kinesthetic_ep_features(
    trial: RawTrial, eps: Sequence[str] = PHAC2_EP_NAMES, travel: str = "tool_z"
) -> np.ndarray:
    """Minimum aperture, mean aperture and travelled distance per EP of one trial.

    Parameters
    ----------
    trial : RawTrial
        One trial (checked here).
    eps : sequence of str, length n_eps
        EP names (keys of :data:`~tzsl.datasets.PHAC2_EPS`) or raw state strings.
    travel : {"tool_z", "aperture"}
        Travelled distance: tool height drop ``z[first EP row] - min(z)`` (Penn's
        ``transform_distance``) or gripper path length ``sum |diff(aperture)|``. See the
        module docstring.

    Returns
    -------
    ndarray of float64, shape (n_eps, 3)
        ``[aperture_min, aperture_mean, travelled distance]`` per EP, in metres.

    Raises
    ------
    DataFileError
        Malformed trial, an EP without rows, or ``travel="tool_z"`` on a trial without
        ``tool_z``.
    """
    eps = check_eps(eps)
    if travel not in TRAVEL_FEATURE:
        raise ConfigError(f"travel must be 'tool_z' or 'aperture' here, got {travel!r}")
    check_raw_trial(trial)
    return kinesthetic_unchecked(trial, eps, travel)


def kinesthetic_unchecked(trial: RawTrial, eps: tuple[str, ...], travel: str) -> np.ndarray:
    """:func:`kinesthetic_ep_features` of an already checked trial: (n_eps, 3) minimum
    aperture, mean aperture and travelled distance per EP (units of the recording)."""
    masks = ep_masks(trial, eps)  # (n_eps, n)
    aperture = np.asarray(trial.gripper_aperture, dtype=np.float64)
    out = np.empty((len(eps), 3))
    out[:, 0] = np.where(masks, aperture[None, :], np.inf).min(axis=1)
    out[:, 1] = masks @ aperture / masks.sum(axis=1)
    if travel == "tool_z":
        if trial.tool_z is None:
            raise trial_error(trial, "trial has no tool_z; the tool travel (tool_z_drop) needs it")
        z = np.asarray(trial.tool_z, dtype=np.float64)
        first = z[np.argmax(masks, axis=1)]
        out[:, 2] = first - np.where(masks, z[None, :], np.inf).min(axis=1)
    else:
        both = masks[:, 1:] & masks[:, :-1]  # consecutive rows inside the EP
        out[:, 2] = both @ np.abs(np.diff(aperture))
    return out


class KinestheticFeatures(TransformerMixin, BaseEstimator):
    """Gripper features per EP: minimum aperture, mean aperture, travelled distance.

    A transformer on lists of :class:`~tzsl.datasets.RawTrial`. The gripper is shared
    by both BioTacs, so the output has one vector per trial. See the module docstring for
    the travelled distance.

    Parameters
    ----------
    eps : sequence of str, default ("squeeze", "hold", "slow_slide", "fast_slide")
        Exploratory procedures, in output order.
    travel : {"auto", "tool_z", "aperture"}, default "auto"
        Source of the travelled distance; ``"auto"`` is resolved in ``fit``.

    Attributes
    ----------
    travel_ : {"tool_z", "aperture"}
        The resolved source.
    feature_names_out_ : ndarray of str, shape (3 * n_eps,)
        ``"<ep>:aperture_min"``, ``"<ep>:aperture_mean"``, ``"<ep>:tool_z_drop"`` (or
        ``"<ep>:aperture_path"``), EP-major.
    """

    def __init__(self, eps: Sequence[str] = PHAC2_EP_NAMES, travel: str = "auto") -> None:
        self.eps = eps
        self.travel = travel

    def fit(self, X: Sequence[RawTrial], y: object = None) -> "KinestheticFeatures":
        """Resolve ``travel`` and the output names. Returns self."""
        eps = check_eps(self.eps)
        if len(X) == 0:
            raise DataFileError(None, "no trials to extract features from")
        for trial in X:
            if not isinstance(trial, RawTrial):
                raise DataFileError(None, f"expected RawTrial objects, got {type(trial).__name__}")
        self.travel_ = resolve_travel(self.travel, X)
        self.feature_names_out_ = np.asarray(
            ep_feature_names(eps, kinesthetic_feature_names(self.travel_)), dtype=object
        )
        return self

    def transform(self, X: Sequence[RawTrial]) -> np.ndarray:
        """Kinesthetic features of every trial.

        Parameters
        ----------
        X : sequence of RawTrial, length n_trials

        Returns
        -------
        ndarray of float64, shape (n_trials, 3 * n_eps)
            Metres, EP-major (see ``feature_names_out_``).
        """
        check_is_fitted(self)
        eps = check_eps(self.eps)
        out = np.empty((len(X), 3 * len(eps)))
        for i, trial in enumerate(X):
            check_raw_trial(trial)
            out[i] = kinesthetic_unchecked(trial, eps, self.travel_).ravel()
        return out

    def get_feature_names_out(self, input_features: object = None) -> np.ndarray:
        """Output feature names, shape (3 * n_eps,)."""
        check_is_fitted(self)
        return self.feature_names_out_.copy()
