"""Checks every raw trial must pass, EP row masks, and BioTac baseline removal (DAP §4.3).

The DAP paper removes "the baseline activity from the BioTac readings by subtracting the
mean of the first 100 readings". A reading is one 100 Hz row of the recording (the whole
trial, not one exploratory procedure): in the full PHAC-2 release the first rows are
recorded before contact; in the HOLD-only MATLAB files the recording *is* the hold EP, so
the baseline is the first second of the hold.

Per signal the baseline is

* ``pdc``, ``tac``, ``tdc``: the mean of rows ``0..baseline_rows-1``, a scalar;
* ``pac``: one scalar, the mean over rows ``0..baseline_rows-1`` and all 22 sub-samples
  (PAC is one 2200 Hz signal stored 22 samples per row);
* ``electrodes``: one value per electrode, shape (19,).

The gripper aperture and the tool height are left untouched (they are kinesthetic
quantities in metres, not drifting ADC counts; Penn's ``gripper_min`` / ``gripper_mean``
are the raw joint position).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np
from sklearn.base import BaseEstimator, TransformerMixin

from tzsl.datasets import PHAC2_EPS, BiotacSignals, RawTrial
from tzsl.exceptions import ConfigError, DataFileError

#: BioTac signal name -> trailing shape of one row.
BIOTAC_SIGNAL_SHAPES: dict[str, tuple[int, ...]] = {
    "pdc": (),
    "pac": (22,),
    "tac": (),
    "tdc": (),
    "electrodes": (19,),
}


def trial_error(trial: RawTrial, problem: str) -> DataFileError:
    """The error for a bad trial: ``problem`` with the trial's source file and id."""
    return DataFileError(getattr(trial, "source", None), problem, trial=getattr(trial, "trial_id", None))


def check_raw_trial(trial: RawTrial, n_fingers: int | None = None) -> None:
    """Validate the arrays of one raw trial.

    Checks that ``trial`` is a :class:`~tzsl.datasets.RawTrial` with at least one finger,
    that every BioTac signal, the gripper aperture, the phase and (if present) the tool
    height have ``n`` rows and the expected trailing shape, are real numbers and hold no
    NaN/inf.

    Parameters
    ----------
    trial : RawTrial
        The trial to check.
    n_fingers : int, optional
        Required number of BioTacs (fingers); ``None`` accepts any positive number.

    Raises
    ------
    DataFileError
        Naming ``trial.source`` and ``trial.trial_id`` and the offending signal.
    """
    if not isinstance(trial, RawTrial):
        raise DataFileError(None, f"expected a RawTrial, got {type(trial).__name__}")
    n = np.shape(trial.gripper_aperture)[0] if np.ndim(trial.gripper_aperture) == 1 else None
    if n is None:
        raise trial_error(trial, f"gripper_aperture has shape {np.shape(trial.gripper_aperture)}; expected (n,)")
    if not trial.fingers:
        raise trial_error(trial, "trial has no BioTac (fingers is empty)")
    if n_fingers is not None and len(trial.fingers) != n_fingers:
        raise trial_error(trial, f"trial has {len(trial.fingers)} BioTacs; expected {n_fingers}")
    arrays: list[tuple[str, object, tuple[int, ...]]] = [("gripper_aperture", trial.gripper_aperture, ())]
    if trial.tool_z is not None:
        arrays.append(("tool_z", trial.tool_z, ()))
    for f, finger in enumerate(trial.fingers):
        if not isinstance(finger, BiotacSignals):
            raise trial_error(trial, f"finger_{f} is a {type(finger).__name__}, not BiotacSignals")
        for name, tail in BIOTAC_SIGNAL_SHAPES.items():
            arrays.append((f"finger_{f}/{name}", getattr(finger, name), tail))
    for name, value, tail in arrays:
        arr = np.asarray(value)
        if arr.shape != (n, *tail):
            raise trial_error(trial, f"{name} has shape {arr.shape}; expected {(n, *tail)}")
        if arr.dtype.kind not in "iuf":
            raise trial_error(trial, f"{name} is not real numeric (dtype {arr.dtype})")
        if arr.dtype.kind == "f":
            bad = ~np.isfinite(arr)
            if bad.any():
                row = int(np.argwhere(bad)[0][0])
                raise trial_error(trial, f"{name} holds NaN/inf (first at row {row})")
    if np.shape(trial.phase) != (n,):
        raise trial_error(trial, f"phase has shape {np.shape(trial.phase)}; expected ({n},)")


#: The four PHAC-2 exploratory procedures in the paper's order.
PHAC2_EP_NAMES: tuple[str, ...] = tuple(PHAC2_EPS)


def check_eps(eps: object) -> tuple[str, ...]:
    """Validate an ``eps`` parameter: a non-empty sequence of distinct EP names.

    Names are keys of :data:`~tzsl.datasets.PHAC2_EPS` (``"hold"``) or raw
    ``controller_detail_state`` strings. Raises ConfigError otherwise.
    """
    if isinstance(eps, str) or not isinstance(eps, Sequence) or len(eps) == 0:
        raise ConfigError(f"eps must be a non-empty sequence of EP names, got {eps!r}")
    names = tuple(eps)
    if not all(isinstance(e, str) and e for e in names):
        raise ConfigError(f"eps must hold non-empty strings, got {eps!r}")
    if len(set(names)) != len(names):
        raise ConfigError(f"eps lists an EP twice: {eps!r}")
    return names


def ep_masks(trial: RawTrial, eps: Sequence[str]) -> np.ndarray:
    """Row masks of the exploratory procedures ``eps`` in one trial.

    Parameters
    ----------
    trial : RawTrial
        A trial whose ``phase`` holds one ``controller_detail_state`` per row.
    eps : sequence of str, length n_eps
        EP names (keys of :data:`~tzsl.datasets.PHAC2_EPS`) or raw state strings.

    Returns
    -------
    ndarray of bool, shape (n_eps, n)
        ``masks[e, i]`` is True when row ``i`` belongs to EP ``eps[e]``.

    Raises
    ------
    DataFileError
        An EP has no row in the trial (names the file, the trial and every absent EP).
    """
    phase = np.asarray(trial.phase).astype(str)
    states = np.array([PHAC2_EPS.get(ep, ep) for ep in eps])
    masks = phase[None, :] == states[:, None]
    counts = masks.sum(axis=1)
    if (counts == 0).any():
        absent = ", ".join(
            f"{eps[e]!r} (controller_detail_state {str(states[e])!r})"
            for e in np.flatnonzero(counts == 0).tolist()
        )
        raise trial_error(
            trial, f"exploratory procedure {absent} is absent: no row of the trial carries that state"
        )
    return masks


def check_baseline_rows(baseline_rows: object) -> int:
    """Validate the ``baseline_rows`` parameter (a positive int); raise ConfigError otherwise."""
    if isinstance(baseline_rows, bool) or not isinstance(baseline_rows, (int, np.integer)) or baseline_rows < 1:
        raise ConfigError(f"baseline_rows must be a positive integer, got {baseline_rows!r}")
    return int(baseline_rows)


def biotac_baseline(finger: BiotacSignals, baseline_rows: int = 100) -> dict[str, np.float64 | np.ndarray]:
    """Baseline of every signal of one BioTac: the mean of its first ``baseline_rows`` rows.

    Parameters
    ----------
    finger : BiotacSignals
        Signals with at least ``baseline_rows`` rows (not checked here).
    baseline_rows : int
        Number of leading 100 Hz rows averaged.

    Returns
    -------
    dict
        ``pdc``, ``pac``, ``tac``, ``tdc``: float64 scalars (ADC counts);
        ``electrodes``: float64 array of shape (19,) (ADC counts).
    """
    head = slice(0, baseline_rows)
    return {
        "pdc": np.mean(finger.pdc[head], dtype=np.float64),
        "pac": np.mean(finger.pac[head], dtype=np.float64),
        "tac": np.mean(finger.tac[head], dtype=np.float64),
        "tdc": np.mean(finger.tdc[head], dtype=np.float64),
        "electrodes": np.mean(finger.electrodes[head], axis=0, dtype=np.float64),
    }


def remove_baseline(trial: RawTrial, baseline_rows: int = 100) -> RawTrial:
    """Subtract from every BioTac signal the mean of its first ``baseline_rows`` rows.

    Parameters
    ----------
    trial : RawTrial
        A trial with ``n >= baseline_rows`` rows. Integer ADC counts (e.g. uint16) are
        converted to float64 before subtracting, so nothing wraps around.
    baseline_rows : int, default 100
        Number of leading 100 Hz rows of the recording that define the baseline.

    Returns
    -------
    RawTrial
        A copy whose BioTac signals are float64 ADC counts relative to the baseline
        (same shapes: ``pdc``/``tac``/``tdc`` (n,), ``pac`` (n, 22), ``electrodes``
        (n, 19)). Gripper aperture, tool height, phase and metadata are unchanged.

    Raises
    ------
    DataFileError
        Fewer than ``baseline_rows`` rows, or any malformed signal (see
        :func:`check_raw_trial`); the message names the file and the trial.
    """
    baseline_rows = check_baseline_rows(baseline_rows)
    check_raw_trial(trial)
    return remove_baseline_unchecked(trial, baseline_rows)


def remove_baseline_unchecked(trial: RawTrial, baseline_rows: int) -> RawTrial:
    """:func:`remove_baseline` of an already checked trial."""
    if trial.n_rows < baseline_rows:
        raise trial_error(
            trial,
            f"recording has {trial.n_rows} rows; baseline removal needs at least "
            f"{baseline_rows} (the mean of the first {baseline_rows} readings)",
        )
    fingers = []
    for finger in trial.fingers:
        base = biotac_baseline(finger, baseline_rows)
        fingers.append(
            BiotacSignals(
                **{
                    name: np.asarray(getattr(finger, name), dtype=np.float64) - base[name]
                    for name in BIOTAC_SIGNAL_SHAPES
                }
            )
        )
    return dataclasses.replace(trial, fingers=tuple(fingers))


class BaselineRemover(TransformerMixin, BaseEstimator):
    """Remove the BioTac baseline (mean of the first ``baseline_rows`` rows) of each trial.

    A stateless transformer on lists of :class:`~tzsl.datasets.RawTrial` (trials have
    different lengths, so this is not an array transformer). See :func:`remove_baseline`.

    Parameters
    ----------
    baseline_rows : int, default 100
        Number of leading 100 Hz rows of each recording that define the baseline
        (DAP paper section 4.3: "the mean of the first 100 readings").
    """

    def __init__(self, baseline_rows: int = 100) -> None:
        self.baseline_rows = baseline_rows

    def fit(self, X: Sequence[RawTrial], y: object = None) -> "BaselineRemover":
        """Check the parameter; nothing is learned. Returns self."""
        check_baseline_rows(self.baseline_rows)
        return self

    def transform(self, X: Sequence[RawTrial]) -> list[RawTrial]:
        """Baseline-removed copies of the trials.

        Parameters
        ----------
        X : sequence of RawTrial, length n_trials

        Returns
        -------
        list of RawTrial, length n_trials
            BioTac signals as float64 ADC counts relative to each trial's own baseline.
        """
        return [remove_baseline(trial, self.baseline_rows) for trial in X]

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.requires_fit = False
        return tags
