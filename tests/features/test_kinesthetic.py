"""Kinesthetic features: minimum / mean aperture and travelled distance per EP."""

from __future__ import annotations

import numpy as np
import pytest

from tzsl.exceptions import ConfigError, DataFileError
from tzsl.features import KinestheticFeatures, kinesthetic_ep_features

HOLD = "HOLD_FOR_10_SECONDS"
SLIDE = "SLIDE_5CM"


def _trial(make_trial, tool_z=True):
    phase = ["X", HOLD, HOLD, HOLD, HOLD, SLIDE, SLIDE, SLIDE, "X"]
    aperture = np.array([0.09, 0.05, 0.03, 0.04, 0.02, 0.02, 0.02, 0.025, 0.09])
    z = np.array([1.2, 1.00, 1.01, 0.97, 0.98, 0.98, 0.96, 0.95, 1.3]) if tool_z else None
    return make_trial(phase, aperture=aperture, tool_z=z)


def test_hand_computed_tool_travel(make_trial):
    feats = kinesthetic_ep_features(_trial(make_trial), ("hold", "slow_slide"), travel="tool_z")
    # hold: aperture 0.05 0.03 0.04 0.02; z 1.00 1.01 0.97 0.98 -> drop = 1.00 - 0.97
    np.testing.assert_allclose(feats[0], [0.02, 0.035, 0.03], atol=1e-15)
    # slow slide: aperture 0.02 0.02 0.025; z 0.98 0.96 0.95 -> drop 0.03
    np.testing.assert_allclose(feats[1], [0.02, 0.065 / 3, 0.03], atol=1e-15)


def test_hand_computed_aperture_path(make_trial):
    feats = kinesthetic_ep_features(_trial(make_trial, tool_z=False), ("hold", "slow_slide"),
                                    travel="aperture")
    # |0.03-0.05| + |0.04-0.03| + |0.02-0.04| = 0.05; slide: 0 + 0.005
    np.testing.assert_allclose(feats[:, 2], [0.05, 0.005], atol=1e-15)
    np.testing.assert_allclose(feats[:, 0], [0.02, 0.02])


def test_path_ignores_jumps_between_separate_ep_segments(make_trial):
    phase = [HOLD, HOLD, "X", HOLD, HOLD]
    trial = make_trial(phase, aperture=np.array([0.01, 0.02, 0.5, 0.05, 0.03]), tool_z=False)
    feats = kinesthetic_ep_features(trial, ("hold",), travel="aperture")
    np.testing.assert_allclose(feats[0, 2], 0.01 + 0.02)  # not the 0.02 -> 0.05 jump


def test_travel_resolution(make_trial):
    with_z, without_z = _trial(make_trial), _trial(make_trial, tool_z=False)
    assert KinestheticFeatures(eps=("hold",)).fit([with_z]).travel_ == "tool_z"
    est = KinestheticFeatures(eps=("hold",)).fit([without_z])
    assert est.travel_ == "aperture"
    assert list(est.get_feature_names_out()) == ["hold:aperture_min", "hold:aperture_mean",
                                                 "hold:aperture_path"]
    with pytest.raises(DataFileError, match="no tool_z while other trials have one"):
        KinestheticFeatures(eps=("hold",)).fit([with_z, without_z])
    forced = KinestheticFeatures(eps=("hold",), travel="tool_z").fit([without_z])
    with pytest.raises(DataFileError, match="no tool_z"):
        forced.transform([without_z])
    with pytest.raises(ConfigError, match="travel"):
        KinestheticFeatures(travel="euclid").fit([with_z])


def test_transformer_shape_and_order(make_trial, four_ep):
    trial = make_trial(four_ep())  # default aperture 0.08 - 1e-4 r, tool_z 1 - 1e-3 r
    est = KinestheticFeatures()
    out = est.fit_transform([trial, trial])
    assert out.shape == (2, 12)
    names = list(est.get_feature_names_out())
    assert names[:3] == ["squeeze:aperture_min", "squeeze:aperture_mean", "squeeze:tool_z_drop"]
    assert names[-1] == "fast_slide:tool_z_drop"
    # hold rows 110..129: min aperture at row 129, mean at 119.5, z drop 19 rows
    np.testing.assert_allclose(out[0, 3:6], [0.08 - 0.0129, 0.08 - 0.01195, 0.019], rtol=1e-12)


def test_absent_ep(make_trial):
    with pytest.raises(DataFileError, match="'fast_slide'.*absent"):
        KinestheticFeatures(eps=("hold", "slow_slide", "fast_slide")).fit_transform(
            [_trial(make_trial)]
        )
