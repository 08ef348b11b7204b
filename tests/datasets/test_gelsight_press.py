"""The 15 real GelSight press records (forces, widths, lazy video)."""

from __future__ import annotations

import os
import pickle

import numpy as np
import pytest

from tzsl.datasets import load_gelsight_press
from tzsl.datasets._gelsight_press import _series
from tzsl.exceptions import ChecksumError, DataFileError, DataMissingError

OBJECTS = ["foam_brick", "golf_ball", "green_ball_softer", "orange_ball_softest", "purple_ball_hardest"]


@pytest.mark.realdata
def test_records(data_dir):
    recs = load_gelsight_press(data_dir)
    assert [(r.object_name, r.press_index) for r in recs] == [(o, i) for o in OBJECTS for i in (1, 2, 3)]
    for r in recs:
        assert r.forces.shape == r.widths.shape == (r.n_frames,)
        assert r.forces.dtype == np.float64
        assert 55 <= r.n_frames <= 85
        assert 15 < r.forces.max() < 30  # newtons
        assert 0.02 < r.widths.min() < r.widths.max() < 0.07  # metres
        # the gripper closes while the force rises: width at the force peak < initial width
        assert r.widths[np.argmax(r.forces)] < r.widths[0]
    assert recs[0].name == "foam_brick_1" and recs[0].n_frames == 85


@pytest.mark.realdata
def test_lazy_video(data_dir):
    rec = load_gelsight_press(data_dir)[3]  # golf_ball_1
    video = rec.read_video()
    assert video.shape == (rec.n_frames, 480, 640, 3) and video.dtype == np.uint8


def _linked_home(data_dir, tmp_path, skip=()):
    home = tmp_path / "home"
    (home / "gelsight_press").mkdir(parents=True)
    for p in (data_dir / "gelsight_press").iterdir():
        if p.name not in skip:
            os.symlink(p, home / "gelsight_press" / p.name)
    return home


@pytest.mark.realdata
def test_missing_and_tampered_files(data_dir, tmp_path):
    home = _linked_home(data_dir, tmp_path, skip={"golf_ball_2_widths.pkl"})
    with pytest.raises(DataMissingError, match="golf_ball_2_widths.pkl"):
        load_gelsight_press(home)
    evil = home / "gelsight_press" / "golf_ball_2_widths.pkl"
    evil.write_bytes(pickle.dumps(np.zeros(78)))
    with pytest.raises(ChecksumError, match="golf_ball_2_widths.pkl"):
        load_gelsight_press(home)


def test_series_validation(tmp_path):
    p = tmp_path / "x_forces.pkl"
    p.write_bytes(pickle.dumps([1.0, 2.0]))
    with pytest.raises(DataFileError, match="expected a 1-D numeric numpy array of forces; got list"):
        _series(p, "forces")
    p.write_bytes(pickle.dumps(np.zeros((3, 2))))
    with pytest.raises(DataFileError, match=r"got ndarray \(3, 2\)"):
        _series(p, "forces")
    p.write_bytes(pickle.dumps(np.array([1.0, np.nan])))
    with pytest.raises(DataFileError, match="NaN"):
        _series(p, "forces")
    p.write_bytes(pickle.dumps(np.array([1, 2], dtype=np.int32)))
    assert _series(p, "forces").dtype == np.float64
