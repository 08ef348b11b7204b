"""Small hand-built raw trials for the feature-extraction tests.

Signals are simple closed forms of the row index ``r`` and sub-sample ``s`` so that
baselines and averages can be computed by hand in the tests:

* finger ``f``: ``pdc = r + 1000 f``, ``pac[r, s] = 10 r + s``, ``tac = 7``,
  ``tdc = 2 r``, ``electrodes[r, k] = 100 k + r + 1000 f`` (uint16, like the real files);
* ``gripper_aperture`` and ``tool_z`` given by the test or a default ramp (metres).
"""

from __future__ import annotations

import numpy as np
import pytest

from tzsl.datasets import BiotacSignals, RawTrial

PRE = "MOVE_ARM_START_POSITION"


def build_trial(
    phase: list[str] | np.ndarray,
    *,
    n_fingers: int = 2,
    aperture: np.ndarray | None = None,
    tool_z: np.ndarray | None | bool = True,
    trial_id: str = "car_sponge_101_01",
    object_name: str = "car_sponge_101",
    source: str = "/data/test.h5",
    dtype: type = np.uint16,
) -> RawTrial:
    phase = np.asarray(phase, dtype=object).astype(str)
    n = phase.shape[0]
    r = np.arange(n)
    fingers = []
    for f in range(n_fingers):
        fingers.append(
            BiotacSignals(
                pdc=(r + 1000 * f).astype(dtype),
                pac=(10 * r[:, None] + np.arange(22)[None, :]).astype(dtype),
                tac=np.full(n, 7, dtype=dtype),
                tdc=(2 * r).astype(dtype),
                electrodes=(100 * np.arange(19)[None, :] + r[:, None] + 1000 * f).astype(dtype),
            )
        )
    if aperture is None:
        aperture = 0.08 - 0.0001 * r
    if tool_z is True:
        tool_z = 1.0 - 0.001 * r
    elif tool_z is False:
        tool_z = None
    object_id = int(object_name.rsplit("_", 1)[1])
    return RawTrial(
        trial_id=trial_id,
        object_id=object_id,
        object_name=object_name,
        trial_index=int(trial_id.rsplit("_", 1)[1]),
        source=source,
        fingers=tuple(fingers),
        gripper_aperture=np.asarray(aperture, dtype=np.float64),
        phase=phase,
        tool_z=None if tool_z is None else np.asarray(tool_z, dtype=np.float64),
    )


def four_ep_phase(pre: int = 100, lengths: tuple[int, int, int, int] = (10, 20, 30, 40)) -> list[str]:
    """``pre`` rows of start position, then the 4 EPs with the given lengths, then 5 rows open."""
    states = ["SQUEEZE_SET_PRESSURE_SLOW", "HOLD_FOR_10_SECONDS", "SLIDE_5CM", "MOVE_DOWN_5CM"]
    phase = [PRE] * pre
    for state, length in zip(states, lengths, strict=True):
        phase += [state] * length
    return phase + ["OPEN_GRIPPER_BY_2CM_FAST"] * 5


@pytest.fixture
def make_trial():
    """Factory: ``make_trial(phase, **kwargs) -> RawTrial`` (see :func:`build_trial`)."""
    return build_trial


@pytest.fixture
def four_ep():
    """Factory for a 4-EP phase vector: ``four_ep(pre=100, lengths=(10, 20, 30, 40))``."""
    return four_ep_phase


@pytest.fixture(scope="session")
def hold_trials(data_dir):
    """The 60 real HOLD-phase trials (checksum-verified by the loader)."""
    from tzsl.datasets import load_phac2_hold_mat

    return load_phac2_hold_mat(data_dir)


@pytest.fixture(scope="session")
def penn_data(data_dir):
    """The real Penn static features (600 x 4 x 47) with labels."""
    from tzsl.datasets import load_phac2_penn

    return load_phac2_penn(data_dir)


@pytest.fixture(scope="session")
def phac2_labels(data_dir):
    """The real 60 x 24 PHAC-2 adjective matrix."""
    from tzsl.datasets import load_phac2_labels

    return load_phac2_labels(data_dir)
