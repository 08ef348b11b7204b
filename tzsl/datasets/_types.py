"""The tidy structures every loader returns and every later layer consumes.

Two shapes of data flow through tzsl:

* :class:`RawTrial` - one trial's raw time series (variable length), as read from the
  PHAC-2 HDF5 release or the HOLD-phase MATLAB files.
* :class:`FeatureSet` - fixed-length per-trial, per-sensor feature vectors plus a trial
  table and the class-attribute table. This is what splits, models and experiments use.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

#: PHAC-2 exploratory procedures, in the paper's order, with their controller_detail_state.
PHAC2_EPS: dict[str, str] = {
    "squeeze": "SQUEEZE_SET_PRESSURE_SLOW",
    "hold": "HOLD_FOR_10_SECONDS",
    "slow_slide": "SLIDE_5CM",
    "fast_slide": "MOVE_DOWN_5CM",
}

#: Columns of the trial table every loader returns.
TRIAL_COLUMNS: tuple[str, ...] = ("trial_id", "object_id", "object_name", "trial_index")


@dataclass(frozen=True)
class BiotacSignals:
    """Raw signals of one BioTac over one recording of ``n`` rows at 100 Hz.

    Attributes
    ----------
    pdc : ndarray of shape (n,)
        Static (DC) fluid pressure, raw ADC counts.
    pac : ndarray of shape (n, 22)
        Dynamic (AC) pressure, 22 sub-samples per row (2200 Hz), raw ADC counts.
    tac : ndarray of shape (n,)
        Dynamic (AC) temperature, raw ADC counts.
    tdc : ndarray of shape (n,)
        Static (DC) temperature, raw ADC counts.
    electrodes : ndarray of shape (n, 19)
        Impedance of the 19 electrodes, raw ADC counts.
    """

    pdc: np.ndarray
    pac: np.ndarray
    tac: np.ndarray
    tdc: np.ndarray
    electrodes: np.ndarray

    @property
    def n_rows(self) -> int:
        """Number of 100 Hz rows."""
        return int(self.pdc.shape[0])


@dataclass(frozen=True)
class RawTrial:
    """One trial of a PR2-gripper exploration with two BioTacs.

    Attributes
    ----------
    trial_id : str
        ``<object>_<id3>_<trial2>``, e.g. ``car_sponge_101_01``.
    object_id : int
        Numeric object id (the 3-digit code in the trial id).
    object_name : str
        ``<object>_<id3>``, e.g. ``car_sponge_101``.
    trial_index : int
        1-based index of the trial for its object.
    source : str
        File the trial was read from (used in error messages).
    fingers : tuple of BiotacSignals
        One entry per BioTac (``finger_0``, ``finger_1``), each with ``n`` rows.
    gripper_aperture : ndarray of shape (n,)
        Gripper joint position in metres.
    phase : ndarray of shape (n,) of str
        ``controller_detail_state`` per row (see :data:`PHAC2_EPS`); rows outside any
        exploratory procedure carry other state names.
    tool_z : ndarray of shape (n,) or None
        Height of the tool frame in metres (from ``transforms/translation``), if recorded.
    adjectives : tuple of str or None
        Adjective labels stored with the trial, if any.
    """

    trial_id: str
    object_id: int
    object_name: str
    trial_index: int
    source: str
    fingers: tuple[BiotacSignals, ...]
    gripper_aperture: np.ndarray
    phase: np.ndarray
    tool_z: np.ndarray | None = None
    adjectives: tuple[str, ...] | None = None

    @property
    def n_rows(self) -> int:
        """Number of 100 Hz rows in the recording."""
        return int(self.gripper_aperture.shape[0])

    def ep_mask(self, ep: str) -> np.ndarray:
        """Boolean mask of shape (n,) selecting the rows of exploratory procedure ``ep``.

        ``ep`` is a key of :data:`PHAC2_EPS` (``"hold"``) or a raw state string.
        """
        state = PHAC2_EPS.get(ep, ep)
        return self.phase == state


@dataclass
class FeatureSet:
    """Per-trial, per-sensor feature vectors with their metadata.

    Attributes
    ----------
    X : ndarray of shape (n_trials, n_sensors, n_features)
        Feature vectors; one sensor per BioTac (or per finger / per camera).
    trials : DataFrame with n_trials rows
        At least the columns :data:`TRIAL_COLUMNS`; row ``i`` describes ``X[i]``.
    sensors : tuple of str, length n_sensors
        Sensor names, e.g. ``("finger_0", "finger_1")``.
    feature_names : tuple of str, length n_features
        Name of every feature column.
    attributes : DataFrame of shape (n_objects, n_attributes)
        0/1 class-attribute table indexed by ``object_name``; one row per object in
        ``trials``. Columns are attribute (adjective) names.
    dataset : str
        Dataset name, e.g. ``"phac2-penn"``.
    info : dict
        Free-form provenance (source files, checksums, dropped adjectives, ...).
    """

    X: np.ndarray
    trials: pd.DataFrame
    sensors: tuple[str, ...]
    feature_names: tuple[str, ...]
    attributes: pd.DataFrame
    dataset: str = ""
    info: dict = field(default_factory=dict)

    @property
    def n_trials(self) -> int:
        return int(self.X.shape[0])

    @property
    def n_objects(self) -> int:
        return int(self.trials["object_name"].nunique())

    @property
    def objects(self) -> np.ndarray:
        """Object name of every trial, shape (n_trials,)."""
        return self.trials["object_name"].to_numpy()

    def trial_attributes(self) -> np.ndarray:
        """Attribute row of every trial's object, shape (n_trials, n_attributes), int 0/1."""
        return self.attributes.loc[self.objects].to_numpy(dtype=int)

    def subset(self, mask: np.ndarray) -> "FeatureSet":
        """The trials selected by boolean ``mask`` of shape (n_trials,)."""
        trials = self.trials.loc[np.asarray(mask)].reset_index(drop=True)
        objects = trials["object_name"].unique()
        return FeatureSet(
            X=self.X[np.asarray(mask)],
            trials=trials,
            sensors=self.sensors,
            feature_names=self.feature_names,
            attributes=self.attributes.loc[objects],
            dataset=self.dataset,
            info=dict(self.info),
        )
