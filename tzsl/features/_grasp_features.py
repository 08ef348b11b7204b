"""Per-grasp features of a 5-BioTac hand: contact detection, material and shape features.

DAP paper sections 5.6 and 5.7.1:

* **Contact** - "The contact of a BioTac is detected when the difference in static pressure
  exceeds a given threshold." We compare each BioTac's PDC in the *hold window* (the last
  ``hold_fraction`` of the grasp's rows, default the last half) with the grasp's own *baseline*
  (mean of its first ``baseline_rows`` rows, taken before the fingers reach the object, see the
  grasp format in :mod:`tzsl.datasets`): a finger is in contact when
  ``mean(PDC[hold]) - mean(PDC[:baseline_rows]) > contact_threshold`` (ADC counts). Using the
  grasp's own baseline makes the test independent of each uncalibrated sensor's resting level.
* **Material features** - "a time average of the features ... we did not consider the vibrations
  signal PAC": the 22 values :data:`MATERIAL_FEATURES` (PDC, TAC, TDC, E1..E19) of every BioTac,
  each the mean over the hold window of the signal minus its baseline (ADC counts). The
  normalisation ("22 normalized means") and the PCA to 8 dimensions are fitted by the model on
  training grasps (:class:`tzsl.models.HandDAPClassifier`).
* **Shape features** - "Joints that did not contribute to the closing procedure (e.g. the wrist)
  were excluded, resulting in a feature vector xsh of 10 angular positions". The paper does not
  list the 10 joints. We take the flexion joints that close the hand, :data:`CLOSING_JOINTS`:
  the coupled distal+middle (``J0``) and proximal (``J3``) flexion of the first, middle, ring and
  little fingers and the two distal thumb flexions ``THJ1``, ``THJ2``; excluded are the four
  abduction joints (``J4``), the thumb's rotation/abduction joints ``THJ3..THJ5`` and the wrist.
  The feature is each joint's angle at the end of the grasp (mean of the last ``end_rows`` rows,
  radians).

Grasps may differ in length; they are NaN-padded to a common length and processed as one array.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from tzsl.datasets import FINGER_NAMES, JOINT_NAMES, Grasp
from tzsl.exceptions import ConfigError, DataFileError

__all__ = [
    "CLOSING_JOINTS",
    "MATERIAL_FEATURES",
    "GraspFeatures",
    "detect_contacts",
    "grasp_features",
    "pack_grasp_features",
    "unpack_grasp_features",
]

#: The 10 closing joints whose final angles are the shape features (our choice; see module doc).
CLOSING_JOINTS: tuple[str, ...] = (
    "FFJ0", "FFJ3", "MFJ0", "MFJ3", "RFJ0", "RFJ3", "LFJ0", "LFJ3", "THJ1", "THJ2",
)  # fmt: skip

#: The 22 time-averaged BioTac features per finger (no PAC), in feature order.
MATERIAL_FEATURES: tuple[str, ...] = ("pdc", "tac", "tdc") + tuple(f"e{i:02d}" for i in range(1, 20))


@dataclass
class GraspFeatures:
    """Features of ``n`` grasps of a hand with ``F`` BioTacs.

    Attributes
    ----------
    material : ndarray of shape (n, F, 22)
        Baseline-removed hold-window means of :data:`MATERIAL_FEATURES`, ADC counts.
    contact : ndarray of bool, shape (n, F)
        Whether each BioTac touched the object.
    shape : ndarray of shape (n, n_joints)
        Final angles of the closing joints, radians.
    grasp_ids : ndarray of str, shape (n,)
    objects : ndarray of str, shape (n,)
        Object of each grasp ("" when unknown).
    joint_names : tuple of str
        Names of the ``shape`` columns.
    """

    material: np.ndarray
    contact: np.ndarray
    shape: np.ndarray
    grasp_ids: np.ndarray
    objects: np.ndarray
    joint_names: tuple[str, ...] = CLOSING_JOINTS

    def __len__(self) -> int:
        return int(self.contact.shape[0])

    @property
    def n_contacts(self) -> np.ndarray:
        """Number of touching BioTacs per grasp, shape (n,)."""
        return self.contact.sum(axis=1)

    def subset(self, mask: np.ndarray) -> GraspFeatures:
        """The grasps selected by a boolean mask or an index array."""
        return GraspFeatures(
            material=self.material[mask],
            contact=self.contact[mask],
            shape=self.shape[mask],
            grasp_ids=self.grasp_ids[mask],
            objects=self.objects[mask],
            joint_names=self.joint_names,
        )

    def to_array(self) -> np.ndarray:
        """The packed array layout of :func:`pack_grasp_features`, shape (n, F*22 + F + n_joints)."""
        return pack_grasp_features(self.material, self.contact, self.shape)


def pack_grasp_features(material: np.ndarray, contact: np.ndarray, shape: np.ndarray) -> np.ndarray:
    """Pack per-grasp features into one float array (the input of the hand models).

    Parameters
    ----------
    material : ndarray of shape (n, F, d_mat)
    contact : ndarray of shape (n, F), bool or 0/1
    shape : ndarray of shape (n, d_shape)

    Returns
    -------
    ndarray of shape (n, F * d_mat + F + d_shape)
        Columns: finger 0's ``d_mat`` material features, ..., finger ``F-1``'s, then the ``F``
        contact flags (0.0/1.0), then the ``d_shape`` shape features.
    """
    material = np.asarray(material, dtype=float)
    n = material.shape[0]
    return np.hstack([material.reshape(n, -1), np.asarray(contact, dtype=float), np.asarray(shape, dtype=float)])


def unpack_grasp_features(
    X: np.ndarray, n_fingers: int = 5, n_material_features: int = 22
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Inverse of :func:`pack_grasp_features`.

    Returns
    -------
    material : ndarray of shape (n, n_fingers, n_material_features)
    contact : ndarray of bool, shape (n, n_fingers)
    shape : ndarray of shape (n, d_shape)
    """
    X = np.asarray(X, dtype=float)
    n_mat = n_fingers * n_material_features
    if X.ndim != 2 or X.shape[1] <= n_mat + n_fingers:
        raise ValueError(
            f"packed grasp features need shape (n, {n_fingers}*{n_material_features} + {n_fingers} + d_shape) "
            f"with d_shape >= 1; got {X.shape}"
        )
    material = X[:, :n_mat].reshape(-1, n_fingers, n_material_features)
    flags = X[:, n_mat : n_mat + n_fingers]
    if not np.isin(flags, (0.0, 1.0)).all():
        raise ValueError(f"contact columns {n_mat}..{n_mat + n_fingers - 1} must hold 0 or 1")
    return material, flags.astype(bool), X[:, n_mat + n_fingers :]


def _windows(lengths: np.ndarray, n_max: int, baseline_rows: int, hold_fraction: float):
    """Boolean masks (n, n_max) of the baseline rows and the hold window of every recording."""
    rows = np.arange(n_max)[None, :]
    hold_start = np.floor(lengths * (1.0 - hold_fraction)).astype(int)
    hold_start = np.maximum(hold_start, baseline_rows)
    baseline = rows < baseline_rows
    hold = (rows >= hold_start[:, None]) & (rows < lengths[:, None])
    return baseline, hold


def _masked_mean(x: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Mean of ``x`` (n, F, R, ...) over rows where ``mask`` (n, F, R) holds."""
    m = mask.reshape(mask.shape + (1,) * (x.ndim - mask.ndim)).astype(float)
    return (np.where(m > 0, x, 0.0) * m).sum(axis=2) / m.sum(axis=2)


def detect_contacts(
    pdc: np.ndarray,
    lengths: np.ndarray | None = None,
    *,
    contact_threshold: float = 20.0,
    baseline_rows: int = 10,
    hold_fraction: float = 0.5,
) -> np.ndarray:
    """Which BioTacs touched the object: PDC rise over the grasp's own baseline above a threshold.

    Parameters
    ----------
    pdc : ndarray of shape (n, F, R)
        Static pressure of every BioTac, raw ADC counts; rows beyond a recording's length are
        ignored (may hold NaN).
    lengths : ndarray of int, shape (n, F), optional
        Valid rows of every recording; default: all ``R``.
    contact_threshold : float, default=20.0
        Minimum rise (ADC counts) of the hold-window mean over the baseline mean.
    baseline_rows : int, default=10
        Rows at the start of each recording averaged as its baseline (0.1 s at 100 Hz).
    hold_fraction : float, default=0.5
        Fraction of each recording, at its end, forming the hold window.

    Returns
    -------
    ndarray of bool, shape (n, F)
    """
    pdc = np.asarray(pdc, dtype=float)
    if pdc.ndim != 3:
        raise ValueError(f"pdc must have shape (n_grasps, n_fingers, n_rows); got {pdc.shape}")
    n, F, R = pdc.shape
    lengths = np.full((n, F), R) if lengths is None else np.asarray(lengths, dtype=int)
    _check_windows(baseline_rows, hold_fraction, contact_threshold)
    if lengths.shape != (n, F) or (lengths <= baseline_rows).any() or (lengths > R).any():
        raise ValueError(
            f"lengths must have shape ({n}, {F}) with baseline_rows={baseline_rows} < length <= {R}"
        )
    baseline, hold = _windows(lengths.reshape(-1), R, baseline_rows, hold_fraction)
    base = _masked_mean(pdc, np.broadcast_to(baseline, (n * F, R)).reshape(n, F, R))
    level = _masked_mean(pdc, hold.reshape(n, F, R))
    return (level - base) > contact_threshold


def _check_windows(baseline_rows: int, hold_fraction: float, contact_threshold: float) -> None:
    if not isinstance(baseline_rows, int | np.integer) or baseline_rows < 1:
        raise ConfigError(f"baseline_rows must be a positive integer, got {baseline_rows!r}")
    if not 0.0 < float(hold_fraction) <= 1.0:
        raise ConfigError(f"hold_fraction must be in (0, 1], got {hold_fraction!r}")
    if not np.isfinite(contact_threshold):
        raise ConfigError(f"contact_threshold must be finite, got {contact_threshold!r}")


def _pad(arrays: Sequence[np.ndarray], n_max: int) -> np.ndarray:
    out = np.full((len(arrays), n_max) + arrays[0].shape[1:], np.nan)
    for i, a in enumerate(arrays):
        out[i, : a.shape[0]] = a
    return out


def grasp_features(
    grasps: Sequence[Grasp],
    *,
    contact_threshold: float = 20.0,
    baseline_rows: int = 10,
    hold_fraction: float = 0.5,
    closing_joints: Sequence[str] = CLOSING_JOINTS,
    end_rows: int = 5,
) -> GraspFeatures:
    """Contacts, material and shape features of ``grasps`` (see the module docstring).

    Parameters
    ----------
    grasps : sequence of Grasp
        E.g. from :func:`tzsl.datasets.read_grasps` or :func:`tzsl.datasets.simulate_grasps`.
    contact_threshold, baseline_rows, hold_fraction
        As in :func:`detect_contacts`; the same windows give the material features.
    closing_joints : sequence of str
        Joint names (from :data:`tzsl.datasets.JOINT_NAMES`) used as shape features.
    end_rows : int, default=5
        Final rows of ``joints`` averaged for the end-of-grasp angles.

    Returns
    -------
    GraspFeatures

    Raises
    ------
    DataFileError
        A grasp with too few rows for its baseline and hold windows (naming file and grasp).
    ConfigError
        Unknown joint names or invalid window settings.
    """
    grasps = list(grasps)
    if not grasps:
        raise ConfigError("no grasps given")
    _check_windows(baseline_rows, hold_fraction, contact_threshold)
    unknown = [j for j in closing_joints if j not in JOINT_NAMES]
    if unknown:
        raise ConfigError(f"unknown joint name(s) {unknown}; known: {list(JOINT_NAMES)}")
    if not isinstance(end_rows, int | np.integer) or end_rows < 1:
        raise ConfigError(f"end_rows must be a positive integer, got {end_rows!r}")
    F = len(FINGER_NAMES)
    for g in grasps:
        if g.n_fingers != F:
            raise DataFileError(g.source or None, f"grasp has {g.n_fingers} fingers, expected {F}", trial=g.grasp_id)
        short = min(f.n_rows for f in g.fingers)
        if short - int(np.floor(short * (1.0 - hold_fraction))) < 1 or short <= baseline_rows:
            raise DataFileError(
                g.source or None,
                f"a BioTac recording has {short} rows; needs more than baseline_rows={baseline_rows} "
                f"and a non-empty hold window",
                trial=g.grasp_id,
            )
    lengths = np.array([[f.n_rows for f in g.fingers] for g in grasps])  # (n, F)
    R = int(lengths.max())
    # (n*F, R, 22) channels pdc, tac, tdc, e01..e19
    channels = _pad(
        [
            np.column_stack([f.pdc, f.tac, f.tdc, f.electrodes])
            for g in grasps
            for f in g.fingers
        ],
        R,
    ).reshape(len(grasps), F, R, len(MATERIAL_FEATURES))
    baseline, hold = _windows(lengths.reshape(-1), R, baseline_rows, hold_fraction)
    base = _masked_mean(channels, np.broadcast_to(baseline, (len(grasps) * F, R)).reshape(len(grasps), F, R))
    level = _masked_mean(channels, hold.reshape(len(grasps), F, R))
    material = level - base
    contact = material[..., 0] > contact_threshold  # PDC rise, same rule as detect_contacts

    cols = [JOINT_NAMES.index(j) for j in closing_joints]
    shape = np.stack([g.joints[-end_rows:, cols].mean(axis=0) for g in grasps])
    return GraspFeatures(
        material=material,
        contact=contact,
        shape=shape,
        grasp_ids=np.array([g.grasp_id for g in grasps], dtype=object),
        objects=np.array([g.object_name for g in grasps], dtype=object),
        joint_names=tuple(closing_joints),
    )
