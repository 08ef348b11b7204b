"""Baseline removal: mean of the first 100 rows of every BioTac signal (DAP §4.3)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from sklearn.base import clone

from tzsl.exceptions import ConfigError, DataFileError
from tzsl.features import BaselineRemover, check_raw_trial, ep_masks, remove_baseline


def test_subtracts_mean_of_first_100_rows(make_trial):
    trial = make_trial(["HOLD_FOR_10_SECONDS"] * 150)
    out = remove_baseline(trial)
    r = np.arange(150)
    f0, f1 = out.fingers
    # pdc = r (+1000 on finger 1): baseline is mean(0..99) = 49.5
    np.testing.assert_allclose(f0.pdc, r - 49.5)
    np.testing.assert_allclose(f1.pdc, r - 49.5)
    # pac[r, s] = 10 r + s: one scalar baseline over 100 rows x 22 sub-samples = 505.5
    np.testing.assert_allclose(f0.pac, 10 * r[:, None] + np.arange(22)[None, :] - 505.5)
    # tac constant -> zero; tdc = 2r -> 2r - 99 (negative at the start: no uint16 wrap-around)
    np.testing.assert_array_equal(f0.tac, np.zeros(150))
    np.testing.assert_allclose(f0.tdc, 2 * r - 99.0)
    assert f0.tdc[0] == -99.0
    # electrodes[r, k] = 100 k + r: one baseline per electrode (100 k + 49.5)
    np.testing.assert_allclose(f1.electrodes, np.broadcast_to((r - 49.5)[:, None], (150, 19)))
    assert f0.pdc.dtype == np.float64 and f0.pac.shape == (150, 22)


def test_baseline_rows_parameter_and_gripper_untouched(make_trial):
    trial = make_trial(["HOLD_FOR_10_SECONDS"] * 30)
    out = remove_baseline(trial, baseline_rows=10)
    np.testing.assert_allclose(out.fingers[0].pdc, np.arange(30) - 4.5)
    # gripper aperture, tool height, phase and metadata are not baseline-removed
    np.testing.assert_array_equal(out.gripper_aperture, trial.gripper_aperture)
    np.testing.assert_array_equal(out.tool_z, trial.tool_z)
    np.testing.assert_array_equal(out.phase, trial.phase)
    assert (out.trial_id, out.source) == (trial.trial_id, trial.source)
    # the input is not modified
    assert trial.fingers[0].pdc.dtype == np.uint16 and trial.fingers[0].pdc[0] == 0


def test_exactly_100_rows_is_enough_99_is_not(make_trial):
    remove_baseline(make_trial(["HOLD_FOR_10_SECONDS"] * 100))
    trial = make_trial(["HOLD_FOR_10_SECONDS"] * 99, source="/x/short.mat", trial_id="acrylic_211_03",
                       object_name="acrylic_211")
    with pytest.raises(DataFileError) as err:
        remove_baseline(trial)
    msg = str(err.value)
    assert "/x/short.mat" in msg and "acrylic_211_03" in msg and "99 rows" in msg and "100" in msg
    assert err.value.trial == "acrylic_211_03"


@pytest.mark.parametrize("bad", [0, -3, 2.5, True, "100"])
def test_bad_baseline_rows(make_trial, bad):
    with pytest.raises(ConfigError, match="baseline_rows"):
        remove_baseline(make_trial(["HOLD_FOR_10_SECONDS"] * 120), baseline_rows=bad)
    with pytest.raises(ConfigError):
        BaselineRemover(baseline_rows=bad).fit([])


def test_nan_and_inf_are_named(make_trial):
    trial = make_trial(["HOLD_FOR_10_SECONDS"] * 120, dtype=np.float64)
    pdc = trial.fingers[1].pdc.copy()
    pdc[42] = np.nan
    bad = dataclasses.replace(
        trial, fingers=(trial.fingers[0], dataclasses.replace(trial.fingers[1], pdc=pdc))
    )
    with pytest.raises(DataFileError, match=r"finger_1/pdc holds NaN/inf \(first at row 42\)") as err:
        remove_baseline(bad)
    assert "car_sponge_101_01" in str(err.value) and "/data/test.h5" in str(err.value)
    aperture = trial.gripper_aperture.copy()
    aperture[3] = np.inf
    with pytest.raises(DataFileError, match="gripper_aperture holds NaN/inf"):
        check_raw_trial(dataclasses.replace(trial, gripper_aperture=aperture))


def test_malformed_signals(make_trial):
    trial = make_trial(["HOLD_FOR_10_SECONDS"] * 120)
    short = dataclasses.replace(trial.fingers[0], electrodes=trial.fingers[0].electrodes[:, :18])
    with pytest.raises(DataFileError, match=r"finger_0/electrodes has shape \(120, 18\)"):
        check_raw_trial(dataclasses.replace(trial, fingers=(short, trial.fingers[1])))
    with pytest.raises(DataFileError, match="trial has 1 BioTacs; expected 2"):
        check_raw_trial(dataclasses.replace(trial, fingers=trial.fingers[:1]), n_fingers=2)
    with pytest.raises(DataFileError, match="no BioTac"):
        check_raw_trial(dataclasses.replace(trial, fingers=()))
    with pytest.raises(DataFileError, match="tool_z has shape"):
        check_raw_trial(dataclasses.replace(trial, tool_z=np.zeros(5)))
    with pytest.raises(DataFileError, match="expected a RawTrial"):
        check_raw_trial({"pdc": [1, 2]})


def test_ep_masks(make_trial):
    trial = make_trial(["A"] * 3 + ["HOLD_FOR_10_SECONDS"] * 2 + ["A", "HOLD_FOR_10_SECONDS"])
    masks = ep_masks(trial, ("hold", "A"))
    np.testing.assert_array_equal(masks[0], [0, 0, 0, 1, 1, 0, 1])
    np.testing.assert_array_equal(masks[1], [1, 1, 1, 0, 0, 1, 0])
    with pytest.raises(DataFileError,
                       match=r"'squeeze' \(controller_detail_state 'SQUEEZE_SET_PRESSURE_SLOW'\) is absent"):
        ep_masks(trial, ("hold", "squeeze"))


def test_transformer_lists(make_trial):
    trials = [make_trial(["HOLD_FOR_10_SECONDS"] * n) for n in (100, 130)]
    remover = BaselineRemover(baseline_rows=50)
    assert clone(remover).get_params() == {"baseline_rows": 50}
    out = remover.fit(trials).transform(trials)
    assert [t.n_rows for t in out] == [100, 130]
    np.testing.assert_allclose(out[1].fingers[0].pdc[:3], [-24.5, -23.5, -22.5])
    assert remover.set_params(baseline_rows=200) is remover
    with pytest.raises(DataFileError, match="needs at least 200"):
        remover.transform(trials)
