"""Per-EP time averages of the 23 BioTac channels."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.exceptions import NotFittedError

from tzsl.exceptions import ConfigError, DataFileError
from tzsl.features import BIOTAC_CHANNELS, BiotacTimeAverage, biotac_ep_means


def test_channel_order():
    assert len(BIOTAC_CHANNELS) == 23
    assert BIOTAC_CHANNELS[:4] == ("pdc", "pac", "tac", "tdc")
    assert BIOTAC_CHANNELS[4] == "e01" and BIOTAC_CHANNELS[-1] == "e19"


def test_hand_computed_means(make_trial, four_ep):
    trial = make_trial(four_ep())  # squeeze rows 100-109, hold 110-129, slides 130-159, 160-199
    means = biotac_ep_means(trial, ("squeeze", "hold", "slow_slide", "fast_slide"))
    assert means.shape == (2, 4, 23)
    mid = np.array([104.5, 119.5, 144.5, 179.5])  # mean row index of each EP
    for f in (0, 1):
        np.testing.assert_allclose(means[f, :, 0], mid + 1000 * f)  # pdc = r + 1000 f
        np.testing.assert_allclose(means[f, :, 1], 10 * mid + 10.5)  # pac over rows and 22 subs
        np.testing.assert_allclose(means[f, :, 2], 7.0)  # tac
        np.testing.assert_allclose(means[f, :, 3], 2 * mid)  # tdc
        for k in range(19):  # electrode k = 100 k + r + 1000 f
            np.testing.assert_allclose(means[f, :, 4 + k], 100 * k + mid + 1000 * f)


def test_non_contiguous_ep_rows(make_trial):
    phase = ["X"] * 4 + ["HOLD_FOR_10_SECONDS"] * 2 + ["X"] * 3 + ["HOLD_FOR_10_SECONDS"]
    means = biotac_ep_means(make_trial(phase), ("hold",))
    np.testing.assert_allclose(means[0, 0, 0], (4 + 5 + 9) / 3)


def test_absent_ep_names_file_trial_and_ep(make_trial):
    trial = make_trial(["HOLD_FOR_10_SECONDS"] * 120, source="/d/steel_vase_702_04_HOLD.mat",
                       trial_id="steel_vase_702_04", object_name="steel_vase_702")
    with pytest.raises(DataFileError) as err:
        biotac_ep_means(trial, ("hold", "slow_slide"))
    msg = str(err.value)
    assert "/d/steel_vase_702_04_HOLD.mat" in msg and "steel_vase_702_04" in msg
    assert "'slow_slide'" in msg and "SLIDE_5CM" in msg


@pytest.mark.parametrize("eps", [(), "hold", ("hold", "hold"), ("hold", 3)])
def test_bad_eps(make_trial, eps):
    with pytest.raises(ConfigError, match="eps"):
        biotac_ep_means(make_trial(["HOLD_FOR_10_SECONDS"] * 5), eps)


def test_transformer(make_trial, four_ep):
    trials = [make_trial(four_ep()), make_trial(four_ep(lengths=(5, 5, 5, 5)), trial_id="car_sponge_101_02")]
    avg = BiotacTimeAverage(eps=("hold", "squeeze"))
    with pytest.raises(NotFittedError):
        avg.transform(trials)
    out = avg.fit_transform(trials)
    assert out.shape == (2, 2, 46)
    names = avg.get_feature_names_out()
    assert names[0] == "hold:pdc" and names[23] == "squeeze:pdc" and names[-1] == "squeeze:e19"
    np.testing.assert_allclose(out[0, 1, 0], 119.5 + 1000)  # finger 1, hold, pdc
    np.testing.assert_allclose(out[1, 0, 23], 102.0)  # second trial: squeeze rows 100-104
    one_finger = make_trial(four_ep(), n_fingers=1)
    with pytest.raises(DataFileError, match="1 BioTacs; expected 2"):
        avg.transform([one_finger])
