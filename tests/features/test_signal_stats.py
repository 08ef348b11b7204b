"""SignalStatistics: per-channel summary statistics of generic time series."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.stats
from sklearn.base import clone
from sklearn.exceptions import NotFittedError
from sklearn.utils.estimator_checks import (
    check_get_params_invariance,
    check_no_attributes_set_in_init,
    check_parameters_default_constructible,
    check_set_params,
)

from tzsl.exceptions import ConfigError, DataFileError
from tzsl.features import SIGNAL_STATISTICS, SignalStatistics, subtract_baseline

ALL = tuple(SIGNAL_STATISTICS)


def test_hand_computed_values():
    # one trial, channel a = 1, 3, 2, 6 ; channel b = 0, 0, 0, 4
    sig = np.array([[1.0, 0.0], [3.0, 0.0], [2.0, 0.0], [6.0, 4.0]])
    est = SignalStatistics(statistics=ALL, channels=("a", "b")).fit([sig])
    got = dict(zip(est.get_feature_names_out(), est.transform([sig])[0], strict=True))
    # channel a: mean 3, deviations -2, 0, -1, 3 -> m2 = 14/4, m3 = (-8 + 0 - 1 + 27)/4 = 4.5,
    # m4 = (16 + 0 + 1 + 81)/4 = 24.5
    assert got["a_mean"] == 3.0
    assert got["a_std"] == pytest.approx(np.sqrt(3.5))
    assert (got["a_min"], got["a_max"], got["a_range"]) == (1.0, 6.0, 5.0)
    assert got["a_median"] == 2.5  # sorted 1 2 3 6
    assert got["a_iqr"] == pytest.approx(3.75 - 1.75)  # q25 at pos 0.75: 1.75; q75 at 2.25: 3.75
    assert got["a_skew"] == pytest.approx(4.5 / 3.5**1.5)
    assert got["a_kurtosis"] == pytest.approx(24.5 / 3.5**2 - 3)
    assert got["a_rms"] == pytest.approx(np.sqrt((1 + 9 + 4 + 36) / 4))
    assert got["a_energy"] == 50.0
    assert got["a_mean_abs_diff"] == pytest.approx((2 + 1 + 4) / 3)
    # slope: t = 0..3, t - 1.5 = -1.5 -0.5 0.5 1.5 ; sum (t-1.5)(x-3) = 3 + 0 - 0.5 + 4.5 = 7 ; Stt = 5
    assert got["a_slope"] == pytest.approx(7 / 5)
    assert got["b_mean"] == 1.0 and got["b_median"] == 0.0 and got["b_iqr"] == 1.0
    assert list(est.get_feature_names_out()[:3]) == ["a_mean", "a_std", "a_min"]  # channel-major


def test_matches_numpy_and_scipy_on_ragged_trials():
    rng = np.random.default_rng(0)
    sigs = [rng.standard_normal((n, 3)) * [1, 10, 100] + [0, 5, -50] for n in (2, 3, 17, 250)]
    F = SignalStatistics(statistics=ALL).fit_transform(sigs).reshape(len(sigs), 3, len(ALL))
    for i, x in enumerate(sigs):
        ref = {
            "mean": x.mean(0), "std": x.std(0), "min": x.min(0), "max": x.max(0), "range": np.ptp(x, 0),
            "median": np.median(x, 0), "iqr": np.subtract(*np.percentile(x, [75, 25], axis=0)),
            "skew": scipy.stats.skew(x, 0), "kurtosis": scipy.stats.kurtosis(x, 0),
            "rms": np.sqrt((x**2).mean(0)), "energy": (x**2).sum(0),
            "mean_abs_diff": np.abs(np.diff(x, axis=0)).mean(0), "slope": np.polyfit(np.arange(len(x)), x, 1)[0],
        }
        for k, name in enumerate(ALL):
            np.testing.assert_allclose(F[i, :, k], ref[name], rtol=1e-10, atol=1e-10, err_msg=name)


def test_baseline_removal_and_time_average():
    sig = np.array([[10.0, 1.0], [12.0, 1.0], [20.0, 7.0], [30.0, 9.0]])
    out = SignalStatistics(statistics=("mean", "max", "std"), baseline_rows=2).fit_transform([sig])[0]
    # baseline = mean of rows 0-1 = (11, 1); relative signal a: -1 1 9 19 ; b: 0 0 6 8
    np.testing.assert_allclose(out, [7.0, 19.0, np.std([-1, 1, 9, 19]), 3.5, 8.0, np.std([0, 0, 6, 8])])
    np.testing.assert_allclose(subtract_baseline(sig, 2), sig - [11.0, 1.0])
    # a 3-D array of equal-length trials is accepted too; mean only = a time average
    block = np.stack([sig, 2 * sig])
    np.testing.assert_allclose(SignalStatistics(statistics=("mean",)).fit_transform(block),
                               [sig.mean(0), 2 * sig.mean(0)])


def test_constant_channel_has_zero_skew_and_kurtosis():
    sig = np.column_stack([np.full(5, 0.1), np.arange(5.0)])
    out = SignalStatistics(statistics=("skew", "kurtosis", "std")).fit_transform([sig])[0]
    assert out[0] == 0.0 and out[1] == 0.0 and out[2] < 1e-15
    assert np.isfinite(out).all()


@pytest.mark.parametrize("params, message", [
    ({"statistics": "mean"}, "non-empty sequence"),
    ({"statistics": ()}, "non-empty sequence"),
    ({"statistics": ("mean", "mode")}, "unknown signal statistic"),
    ({"statistics": ("mean", "mean")}, "twice"),
    ({"baseline_rows": -1}, "baseline_rows"),
    ({"channels": ("a",)}, "channels names 1 channels"),
])
def test_invalid_parameters(params, message):
    with pytest.raises(ConfigError, match=message):
        SignalStatistics(**params).fit([np.zeros((4, 2))])


def test_bad_signals_name_the_trial():
    est = SignalStatistics(statistics=("mean", "slope"), baseline_rows=3).fit([np.zeros((5, 2))])
    with pytest.raises(DataFileError, match="signal 1 has 3 channels"):
        est.transform([np.zeros((5, 2)), np.zeros((5, 3))])
    with pytest.raises(DataFileError, match="signal 1 has 2 rows.*need at least 3"):
        est.transform([np.zeros((5, 2)), np.zeros((2, 2))])
    bad = np.zeros((6, 2))
    bad[4, 1] = np.nan
    with pytest.raises(DataFileError, match=r"signal 1 holds NaN/inf \(first at row 4\)"):
        est.transform([np.zeros((5, 2)), bad])
    with pytest.raises(DataFileError, match="expected \\(n_rows, n_channels\\)"):
        est.transform([np.zeros(5)])
    with pytest.raises(DataFileError, match="array of shape \\(4, 2\\)"):
        est.transform(np.zeros((4, 2)))  # a 2-D array is not a batch of signals
    with pytest.raises(DataFileError, match="1 rows.*need at least 2"):
        SignalStatistics(statistics=("slope",)).fit([np.zeros((2, 1))]).transform([np.zeros((1, 1))])


def test_sklearn_api():
    est = SignalStatistics(statistics=("mean", "iqr"), baseline_rows=2, channels=("x", "y"))
    check_parameters_default_constructible("SignalStatistics", est)
    check_no_attributes_set_in_init("SignalStatistics", est)
    check_get_params_invariance("SignalStatistics", est)
    check_set_params("SignalStatistics", est)
    assert clone(est).get_params() == est.get_params()
    # check_estimator feeds 2-D (n_samples, n_features) arrays only; this transformer takes a
    # batch of time series (tagged three_d_array), so the API checks above are the applicable ones.
    with pytest.raises(NotFittedError):
        est.transform([np.zeros((3, 2))])
    sigs = [np.arange(8.0).reshape(4, 2), np.ones((6, 2))]
    assert est.fit(sigs) is est
    assert est.n_channels_ == 2
    np.testing.assert_array_equal(est.transform(sigs), clone(est).fit_transform(sigs))
    assert est.transform(sigs).shape == (2, 4)
