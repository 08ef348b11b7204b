"""Simulated Shadow-hand grasps generated from a class-attribute matrix K.

No public Shadow-hand grasp data exist (the DAP paper's own recordings, section 5.5, are not
released). This simulator exists only to exercise and demonstrate the hand methods (contact
detection, MAXDAP / AVGDAP / LDAP, DF-MDAP, SC-MDAP) end to end. Its numbers say nothing
about real robots; results obtained on it must be reported as simulated.

The generative model, per grasp of object ``o`` (rows at a nominal 100 Hz, ``n_rows`` rows):

Contacts
    The number of touching fingers ``B`` is uniform on 1..5 and the touching fingers are a
    uniformly random subset (grasps without contact are dropped in the paper, so none are made).
    A touching finger's contact starts at a random row in [20%, 40%] of the recording (after the
    first 20% of rows, which stay free of contact and serve as the grasp's baseline).
Materials (BioTac signals)
    Every material attribute ``a`` has a fixed 22-d signature (mean changes of PDC, TAC, TDC and
    the 19 electrodes, ADC counts) derived from its name, so "glass" always feels the same. Each
    object gets its own version of each of its materials, perturbed by ``difficulty`` (e.g. two
    objects made of different plastics, the failure the paper reports for "plastic" in section
    5.8.1). Each touching finger touches one of the object's materials chosen uniformly at random:
    an object with several material attributes (thermal mug, jar, salter; section 5.7 item 1)
    therefore shows different materials to different fingers. The finger's signals rise from its
    baseline to ``baseline + signature`` (PDC and electrodes scaled by a random contact force),
    TAC shows a decaying transient; fingers that touch nothing stay at baseline. Every BioTac has
    its own baseline offsets and electrode gains (sensors are not calibrated), and white noise
    scaled by ``noise`` is added. PAC is baseline noise only (the hand methods do not use it).
Shape (joint angles)
    The 10 closing joints (see ``tzsl.features.CLOSING_JOINTS``) end at a posture that is a base
    posture plus one fixed 10-d pattern (radians) per shape attribute felt in the grasp, plus an
    object-specific offset scaled by ``difficulty`` (object size) and a per-grasp pose error
    scaled by ``noise``. Local shape attributes (default ``concave``, ``has_handle``,
    ``has_narrow_part``) are each missed by a grasp with probability ``shape_miss_rate`` (the
    grasp does not reach the bottle's neck or the mug's handle; section 5.7 item 2); a missed
    attribute adds no pattern. A finger that touches nothing closes further, to near its joint
    limit. The other 9 joints (abduction, thumb rotation, wrist) take random postures. Joint angles
    move from the spread-out start posture to the final posture with an exponential time course.

Every draw comes from ``random_state`` (the attribute signatures from their names), so the same
arguments give identical grasps; the whole data set is generated with array operations.
"""

from __future__ import annotations

import zlib
from collections.abc import Sequence
from dataclasses import dataclass, field
from numbers import Integral, Real
from pathlib import Path

import numpy as np
import pandas as pd

from tzsl.datasets._grasps import (
    FINGER_NAMES,
    JOINT_NAMES,
    Grasp,
    load_hand_table4,
    write_grasps,
)
from tzsl.datasets._types import BiotacSignals
from tzsl.exceptions import ConfigError

__all__ = ["LOCAL_SHAPE_ATTRIBUTES", "SimulatedGrasps", "simulate_grasps"]

#: Shape attributes that a single grasp may miss (local object parts), our reading of sections
#: 5.7.2 and 5.8 of the DAP paper (the bottle's narrow neck, the measuring cup's handle and rim).
LOCAL_SHAPE_ATTRIBUTES: tuple[str, ...] = ("concave", "has_handle", "has_narrow_part")

# Closing joints (same order as tzsl.features.CLOSING_JOINTS) and the finger each belongs to.
_CLOSING = ("FFJ0", "FFJ3", "MFJ0", "MFJ3", "RFJ0", "RFJ3", "LFJ0", "LFJ3", "THJ1", "THJ2")
_CLOSING_FINGER = np.array([1, 1, 2, 2, 3, 3, 4, 4, 0, 0])
_CLOSING_IDX = np.array([JOINT_NAMES.index(j) for j in _CLOSING])
_OTHER_IDX = np.array([i for i in range(len(JOINT_NAMES)) if JOINT_NAMES[i] not in _CLOSING])
_N_MAT = 22  # pdc, tac, tdc, e01..e19
_BASELINE = np.array([2000.0, 2000.0, 2600.0])  # pdc, tac, tdc resting levels (ADC counts)


@dataclass
class SimulatedGrasps:
    """Output of :func:`simulate_grasps`.

    Attributes
    ----------
    grasps : list of Grasp
        The grasps, ``n_objects * n_grasps_per_object`` of them, object by object.
    truth : DataFrame
        One row per grasp: ``grasp_id``, ``object``, ``n_contacts``, ``f{i}_contact`` (bool),
        ``f{i}_material`` (material touched by finger ``i``, "" when no contact) and
        ``missed_shape`` (``;``-separated local shape attributes of the object this grasp missed).
    params : dict
        The arguments used (for provenance).
    """

    grasps: list[Grasp]
    truth: pd.DataFrame
    params: dict = field(default_factory=dict)


def _name_rng(name: str, salt: str) -> np.random.Generator:
    return np.random.default_rng(zlib.crc32(f"{salt}:{name}".encode()))


def _material_signature(name: str) -> np.ndarray:
    """Fixed 22-d signature of material ``name``: mean change of pdc, tac, tdc, e01..e19 (counts)."""
    rng = _name_rng(name, "material")
    pdc = rng.uniform(80.0, 260.0)  # contact pressure rise (stiffness)
    tac = rng.uniform(-60.0, -10.0)  # heat-flow transient (negative: heat leaves the finger)
    tdc = -rng.uniform(5.0, 70.0)  # temperature drop (thermal conductivity)
    electrodes = -rng.uniform(10.0, 120.0, 19)  # impedance drop under deformation
    return np.concatenate([[pdc, tac, tdc], electrodes])


def _shape_pattern(name: str) -> np.ndarray:
    """Fixed 10-d closing-joint pattern of shape attribute ``name`` (radians)."""
    return _name_rng(name, "shape").uniform(-0.35, 0.35, len(_CLOSING))


def _check_params(K, n_grasps_per_object, noise, difficulty, shape_miss_rate, n_rows) -> pd.DataFrame:
    if not isinstance(K, pd.DataFrame) or K.empty:
        raise ConfigError("K must be a non-empty DataFrame of 0/1 attributes indexed by object name")
    if not K.isin([0, 1]).all().all():
        raise ConfigError("K must hold only 0/1 entries")
    if K.index.duplicated().any():
        raise ConfigError(f"K has duplicate object rows {sorted(set(K.index[K.index.duplicated()]))}")
    if not isinstance(n_grasps_per_object, Integral) or n_grasps_per_object < 1:
        raise ConfigError(f"n_grasps_per_object must be a positive integer, got {n_grasps_per_object!r}")
    for name, value in (("noise", noise), ("difficulty", difficulty)):
        if (not isinstance(value, Real)
                or not np.isfinite(value)  # type: ignore[call-overload]  # numpy's stub omits numbers.Real
                or value < 0):
            raise ConfigError(f"{name} must be a finite number >= 0, got {value!r}")
    if (not isinstance(shape_miss_rate, Real)
            or not 0 <= shape_miss_rate <= 1):  # type: ignore[operator]  # typeshed's numbers.Real lacks __ge__
        raise ConfigError(f"shape_miss_rate must be in [0, 1], got {shape_miss_rate!r}")
    if not isinstance(n_rows, Integral) or n_rows < 20:
        raise ConfigError(f"n_rows must be an integer >= 20, got {n_rows!r}")
    return K.astype(int)


def simulate_grasps(
    K: pd.DataFrame,
    n_grasps_per_object: int = 30,
    noise: float = 1.0,
    difficulty: float = 0.5,
    shape_miss_rate: float = 0.3,
    *,
    material_attributes: Sequence[str] | None = None,
    local_shape_attributes: Sequence[str] = LOCAL_SHAPE_ATTRIBUTES,
    n_rows: int = 100,
    random_state: int | np.random.RandomState | None = None,
    folder: str | Path | None = None,
) -> SimulatedGrasps:
    """Simulate Shadow-hand grasps (5 BioTacs, 19 joints) of the objects of ``K``.

    For exercising and demonstrating the hand methods only: the data are synthetic (no public
    Shadow-hand grasp data exist); the generative model is described in the module docstring.

    Parameters
    ----------
    K : DataFrame of shape (n_objects, n_attributes), 0/1
        Class-attribute matrix indexed by object name, e.g. ``load_hand_table4().K``.
    n_grasps_per_object : int, default=30
    noise : float, default=1.0
        Scale of sensor noise and per-grasp variation (0 = noiseless).
    difficulty : float, default=0.5
        Scale of object-to-object variation of a material's signature and of the object-specific
        posture offset (0 = every object made of "plastic" feels identical).
    shape_miss_rate : float, default=0.3
        Probability that a grasp misses each local shape attribute of the object.
    material_attributes : sequence of str, optional
        Columns of ``K`` that are materials (sensed by BioTacs); the rest are shape attributes.
        Default: the material attributes of the paper's Table 4 (:func:`load_hand_table4`).
    local_shape_attributes : sequence of str
        Shape attributes a grasp may miss (columns of ``K`` not present are ignored).
    n_rows : int, default=100
        Rows per grasp (nominal 100 Hz).
    random_state : int, RandomState or None
    folder : str or Path, optional
        When given, also write the grasps there with :func:`write_grasps` (ground truth columns
        of :attr:`SimulatedGrasps.truth` are added to ``grasps.csv``).

    Returns
    -------
    SimulatedGrasps
    """
    K = _check_params(K, n_grasps_per_object, noise, difficulty, shape_miss_rate, n_rows)
    if material_attributes is None:
        material_attributes = load_hand_table4().material_attributes
    material_attributes = list(material_attributes)
    unknown = [a for a in material_attributes if a not in K.columns]
    if unknown:
        raise ConfigError(f"material attribute(s) {unknown} are not columns of K ({list(K.columns)})")
    shape_attributes = [a for a in K.columns if a not in material_attributes]
    local = [a for a in shape_attributes if a in set(local_shape_attributes)]
    mat = K[material_attributes].to_numpy()
    no_material = list(K.index[mat.sum(axis=1) == 0])
    if no_material:
        raise ConfigError(f"object(s) {no_material} have no material attribute; a BioTac must touch something")

    from sklearn.utils import check_random_state  # noqa: PLC0415 - scikit-learn only when simulating (tzsl predict reads datasets)

    rng = check_random_state(random_state)
    n_obj, n_g, F, R = len(K), int(n_grasps_per_object), len(FINGER_NAMES), int(n_rows)
    G = n_obj * n_g
    obj = np.repeat(np.arange(n_obj), n_g)  # (G,)
    t = np.arange(R, dtype=float)

    # --- contacts: B ~ U{1..F}, random subset of fingers --------------------------------------
    n_contacts = rng.randint(1, F + 1, size=G)
    rank = np.argsort(rng.random_sample((G, F)), axis=1).argsort(axis=1)
    contact = rank < n_contacts[:, None]  # (G, F)

    # --- materials: per object versions of the signatures, one material per finger -----------
    n_m = len(material_attributes)
    sig = np.stack([_material_signature(a) for a in material_attributes])  # (n_m, 22)
    scale = np.abs(sig).mean(axis=0)  # typical size of every component
    obj_sig = sig[None] + difficulty * 0.35 * scale * rng.standard_normal((n_obj, n_m, _N_MAT))
    n_mat_obj = mat.sum(axis=1)  # (n_obj,)
    mat_lists = np.argsort(-mat, axis=1, kind="stable")  # the object's materials first
    pick = np.floor(rng.random_sample((G, F)) * n_mat_obj[obj][:, None]).astype(int)
    material = mat_lists[obj[:, None], pick]  # (G, F) index into material_attributes
    force = rng.uniform(0.6, 1.4, (G, F))
    delta = obj_sig[obj[:, None], material] * (1 + 0.15 * noise * rng.standard_normal((G, F, _N_MAT)))
    delta[..., [0] + list(range(3, _N_MAT))] *= force[..., None]
    delta *= contact[..., None]

    # per-sensor calibration (fixed hardware: from names, not from random_state)
    gains = np.stack([_name_rng(f, "gain").uniform(0.7, 1.3, _N_MAT) for f in FINGER_NAMES])  # (F, 22)
    offsets = np.stack([_name_rng(f, "offset").normal(0.0, 40.0, _N_MAT) for f in FINGER_NAMES])
    resting = np.concatenate([_BASELINE, np.full(19, 3000.0)])
    delta *= gains[None]
    base = resting + offsets[None] + rng.normal(0.0, 15.0, (G, F, _N_MAT))  # (G, F, 22) slow drift

    onset = rng.uniform(0.2 * R, 0.4 * R, (G, F))
    tau = rng.uniform(0.03 * R, 0.08 * R, (G, F))
    since = np.clip(t[None, None] - onset[..., None], 0.0, None)  # (G, F, R)
    touching = t[None, None] >= onset[..., None]
    rise = np.where(touching, -np.expm1(-since / tau[..., None]), 0.0)
    transient = np.where(touching, np.exp(-since / (2 * tau[..., None])), 0.0)
    level = np.where(np.arange(_N_MAT) == 1, 0.0, 1.0)  # TAC: transient, not a level
    sigma = noise * np.concatenate([[2.0, 3.0, 1.0], np.full(19, 4.0)])
    # signals (G, F, R, 22): base + delta * (rise * level + transient * (1 - level) * 3) + sigma * noise,
    # computed in place on two buffers (the same operations on the same operands, so the same numbers)
    sig_t = rise[..., None] * level
    buffer = transient[..., None] * (1 - level)
    buffer *= 3.0
    sig_t += buffer
    sig_t *= delta[:, :, None, :]
    sig_t += base[:, :, None, :]
    np.multiply(sigma, rng.standard_normal((G, F, R, _N_MAT)), out=buffer)
    sig_t += buffer
    sig_t = sig_t.astype(np.float32)
    np.multiply(noise * 5.0, rng.standard_normal((G, F, R, 22)), out=buffer)
    buffer += 2048.0
    pac = buffer.astype(np.float32)
    del buffer

    # --- shape: final posture of the 10 closing joints -------------------------------------
    felt = np.repeat(K[shape_attributes].to_numpy()[:, None, :], n_g, axis=1).reshape(G, len(shape_attributes))
    local_cols = np.array([shape_attributes.index(a) for a in local], dtype=int)
    missed = np.zeros_like(felt, dtype=bool)
    if local_cols.size:
        missed[:, local_cols] = (rng.random_sample((G, local_cols.size)) < shape_miss_rate) & (
            felt[:, local_cols] == 1
        )
    felt = felt * ~missed
    patterns = np.stack([_shape_pattern(a) for a in shape_attributes]) if shape_attributes else np.zeros((0, 10))
    base_posture = np.tile([0.9, 0.6], 5)
    obj_offset = difficulty * 0.08 * rng.standard_normal((n_obj, len(_CLOSING)))
    q_close = (
        base_posture
        + felt @ patterns
        + obj_offset[obj]
        + noise * 0.05 * rng.standard_normal((G, len(_CLOSING)))
    )
    free = ~contact[:, _CLOSING_FINGER]  # (G, 10): finger of the joint touches nothing
    limit = np.tile([1.57, 1.57], 5)
    q_close = np.where(free, limit - np.abs(noise * 0.03 * rng.standard_normal((G, len(_CLOSING)))), q_close)
    q_open = np.zeros(len(JOINT_NAMES))
    q_final = np.empty((G, len(JOINT_NAMES)))
    q_final[:, _CLOSING_IDX] = q_close
    q_final[:, _OTHER_IDX] = rng.uniform(-0.3, 0.3, (G, _OTHER_IDX.size))
    tau_j = rng.uniform(0.1 * R, 0.2 * R, G)
    progress = -np.expm1(-t[None, :] / tau_j[:, None])  # (G, R)
    joints = (
        q_open + (q_final - q_open)[:, None, :] * progress[..., None]
        + noise * 0.005 * rng.standard_normal((G, R, len(JOINT_NAMES)))
    ).astype(np.float32)

    # --- assemble -----------------------------------------------------------------------------
    names = [str(o) for o in K.index]
    ids = [f"{names[o].replace(' ', '_')}_{j:03d}" for o in range(n_obj) for j in range(n_g)]
    grasps = [
        Grasp(
            grasp_id=ids[g],
            object_name=names[obj[g]],
            source="",
            fingers=tuple(
                BiotacSignals(
                    pdc=sig_t[g, f, :, 0],
                    tac=sig_t[g, f, :, 1],
                    tdc=sig_t[g, f, :, 2],
                    electrodes=sig_t[g, f, :, 3:],
                    pac=pac[g, f],
                )
                for f in range(F)
            ),
            joints=joints[g],
        )
        for g in range(G)
    ]
    mat_names = np.asarray(material_attributes, dtype=object)
    truth = pd.DataFrame({"grasp_id": ids, "object": [names[o] for o in obj], "n_contacts": n_contacts})
    for f in range(F):
        truth[f"f{f}_contact"] = contact[:, f]
    for f in range(F):
        truth[f"f{f}_material"] = np.where(contact[:, f], mat_names[material[:, f]], "")
    shape_names = np.asarray(shape_attributes, dtype=object)
    truth["missed_shape"] = [";".join(shape_names[row]) for row in missed]
    params = {
        "n_grasps_per_object": n_g,
        "noise": float(noise),
        "difficulty": float(difficulty),
        "shape_miss_rate": float(shape_miss_rate),
        "material_attributes": list(material_attributes),
        "local_shape_attributes": local,
        "n_rows": R,
        "random_state": random_state if isinstance(random_state, Integral | None) else repr(random_state),
        "simulated": True,
    }
    out = SimulatedGrasps(grasps=grasps, truth=truth, params=params)
    if folder is not None:
        write_grasps(folder, grasps, extra=truth.drop(columns=["grasp_id", "object"]))
    return out
