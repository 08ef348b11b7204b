"""Selection of the cross-trial-comparable Penn static columns, split per finger."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.base import clone

from tzsl.exceptions import ConfigError, DataFileError
from tzsl.features import PENN_DROPPED_COLUMNS, PENN_FEATURES_PER_EP, PennColumnSelector, select_penn_columns

EPS = ("squeeze", "hold", "slow_slide", "fast_slide")


def _coded(n=3, n_eps=4):
    """X[i, e, c] = 1000 i + 100 e + c: every output value tells where it came from."""
    i, e, c = np.meshgrid(np.arange(n), np.arange(n_eps), np.arange(47), indexing="ij")
    return (1000 * i + 100 * e + c).astype(np.float64)


def test_selection_on_coded_tensor():
    out, names = select_penn_columns(_coded(), EPS)
    assert out.shape == (3, 2, 52) and len(names) == 52
    src_col = out % 100
    src_ep = (out % 1000) // 100
    np.testing.assert_array_equal(out // 1000, np.arange(3)[:, None, None] * np.ones((1, 2, 52)))
    assert src_col.max() < 23  # no electrode-polyfit column (23-46) survives
    # EP-major blocks of 13
    np.testing.assert_array_equal(src_ep[0, 0], np.repeat(np.arange(4), 13))
    # per-EP column order: finger 0 takes the even, finger 1 the odd member of each pair,
    # both take the shared gripper columns 20, 21, 22
    np.testing.assert_array_equal(src_col[0, 0, :13], [0, 2, 4, 6, 8, 10, 12, 14, 16, 18, 20, 21, 22])
    np.testing.assert_array_equal(src_col[0, 1, :13], [1, 3, 5, 7, 9, 11, 13, 15, 17, 19, 20, 21, 22])
    assert names[13 + 2] == "hold:pdc_max"
    assert out[2, 1, 13 + 2] == 2000 + 100 + 5  # trial 2, finger 1, hold, pdc_max -> column 5
    assert names[:13] == [f"squeeze:{n}" for n in PENN_FEATURES_PER_EP]
    assert names[-1] == "fast_slide:transform_distance"
    assert PENN_DROPPED_COLUMNS == tuple(range(23, 47))


def test_state_names_map_to_short_names():
    states = ("SQUEEZE_SET_PRESSURE_SLOW", "HOLD_FOR_10_SECONDS", "SLIDE_5CM", "MOVE_DOWN_5CM")
    _, names = select_penn_columns(_coded(), states)
    _, short = select_penn_columns(_coded(), EPS)
    assert names == short
    out, names = select_penn_columns(_coded(n_eps=1)[:, :1], ("hold",))
    assert out.shape == (3, 2, 13) and names[0] == "hold:pdc_rise_count"


def test_bad_input():
    with pytest.raises(DataFileError, match=r"shape \(3, 4, 46\)"):
        select_penn_columns(_coded()[:, :, :46], EPS)
    with pytest.raises(DataFileError, match="expected \\(n_trials, 3, 47\\)"):
        select_penn_columns(_coded(), EPS[:3])
    X = _coded()
    X[1, 2, 7] = np.nan
    with pytest.raises(DataFileError, match="column 7 of EP 'slow_slide' is NaN/inf in trial row 1"):
        select_penn_columns(X, EPS)
    with pytest.raises(ConfigError):
        select_penn_columns(_coded(), "hold")


def test_selector_transformer():
    sel = PennColumnSelector()
    assert clone(sel).get_params() == {"eps": EPS}
    out = sel.fit_transform(_coded())
    np.testing.assert_array_equal(out, select_penn_columns(_coded(), EPS)[0])
    assert sel.get_feature_names_out()[1] == "squeeze:pdc_area"


@pytest.mark.realdata
def test_real_penn_features(penn_data):
    out, names = select_penn_columns(penn_data.X, penn_data.eps)
    assert out.shape == (600, 2, 52)
    assert "hold:pdc_max" in names
    gi = [names.index(f"{ep}:gripper_min") for ep in EPS]
    np.testing.assert_array_equal(out[:, 0, gi], out[:, 1, gi])
    np.testing.assert_array_equal(out[:, 0, gi], penn_data.X[:, :, 20])
    pdc = names.index("hold:pdc_max")
    np.testing.assert_array_equal(out[:, 1, pdc], penn_data.X[:, 1, 5])
    assert not np.array_equal(out[:, 0, pdc], out[:, 1, pdc])  # the two BioTacs differ
