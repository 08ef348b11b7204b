"""Active touch on the simulated hand: grasp types, the written tables (labelled simulated), the stopping rule."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from tests.study_settings import study_settings
from tzsl.datasets import load_hand_table4
from tzsl.exceptions import ConfigError
from tzsl.studies.active_touch.hand import GRASP_TYPES, grasp_type_of, run_active_hand
from tzsl.studies.config import ActiveTouchStudy
from tzsl.studies.outputs.results_folder import ResultsDir


def test_grasp_type_by_touching_biotacs():
    contact = np.zeros((6, 5), dtype=bool)
    for i, n in enumerate([0, 1, 2, 3, 4, 5]):
        contact[i, :n] = True
    assert grasp_type_of(contact).tolist() == [-1, 0, 0, 1, 2, 2]
    assert list(GRASP_TYPES) == ["pinch", "tripod", "power"]


def test_simulated_hand_tables(tmp_path):
    config = study_settings(ActiveTouchStudy, seeds=(0,), n_sequences=4, max_grasps=3, **{"hand.cv": 2}, n_samples=16,
                            thresholds=(0.5, 0.99), n_boot=50)
    out = run_active_hand(load_hand_table4(), ResultsDir(tmp_path), config)
    assert {p.name for p in tmp_path.iterdir()} == {"active_touch_hand.csv", "active_touch_hand_stop.csv",
                                                    "active_touch_hand.png"}
    curves, stop = (pd.read_csv(tmp_path / f"{n}.csv") for n in ("active_touch_hand", "active_touch_hand_stop"))
    assert (curves["data"] == "simulated").all() and (stop["data"] == "simulated").all()
    assert set(curves["strategy"]) == {"active", "fixed:pinch", "fixed:tripod", "fixed:power", "random_type",
                                       "random_grasp"}
    assert (curves.groupby("strategy")["grasps"].apply(list) == [[1, 2, 3]] * 6).all()
    assert ((curves["ci95_low"] <= curves["accuracy"] + 1e-12)
            & (curves["accuracy"] <= curves["ci95_high"] + 1e-12)).all()
    active = curves[curves["strategy"] == "active"].set_index("grasps")["accuracy"]
    assert active[3] > 2 * curves["chance"].iloc[0]  # the simulated attributes are learnable
    assert ((stop["mean_grasps"] >= 1) & (stop["mean_grasps"] <= 3)).all()
    np.testing.assert_allclose(stop["grasps_saved"], 3 - stop["mean_grasps"])
    for _, g in stop.groupby("strategy"):
        assert g.sort_values("threshold")["mean_grasps"].is_monotonic_increasing
    assert sum(out["active_touch_hand"].attrs["type_share"].values()) == pytest.approx(1.0, abs=1e-2)
    with pytest.raises(ConfigError, match="already exists"):
        run_active_hand(load_hand_table4(), ResultsDir(tmp_path), config)
