"""Key-frame selection (F14): synthetic videos with known answers and the 15 real GelSight presses."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.base import clone
from sklearn.utils.estimator_checks import (
    check_get_params_invariance,
    check_no_attributes_set_in_init,
    check_parameters_default_constructible,
    check_set_params,
)

from tzsl.exceptions import ConfigError, DataFileError
from tzsl.features import KeyFrameSelector, frame_differences, key_frame_indices

AMP = 50.0


def press_video(T=40, t0=10, t_peak=25, h=8, w=8, channels=3, split=False):
    """Base 100; from t0 the intensity ramps up linearly to +AMP at t_peak, then back down.

    a(t) = round((t - t0 + 1) / (t_peak - t0 + 1) * AMP) on [t0, t_peak]. With ``split`` the left
    half brightens and the right half darkens by a(t) (the mean intensity stays 100).
    """
    t = np.arange(T, dtype=float)
    rise = np.clip((t - t0 + 1) / (t_peak - t0 + 1), 0, 1)
    fall = np.clip(1 - (t - t_peak) / (T - t_peak), 0, 1)
    a = np.round(AMP * np.where(t <= t_peak, rise, fall))  # whole grey levels: exact in uint8
    shape = (T, h, w) + ((channels,) if channels else ())
    video = np.full(shape, 100.0)
    if split:
        video[:, :, : w // 2] += a[:, None, None, None] if channels else a[:, None, None]
        video[:, :, w // 2 :] -= a[:, None, None, None] if channels else a[:, None, None]
    else:
        video += a.reshape((T,) + (1,) * (len(shape) - 1))
    return video.astype(np.uint8), a


# -- synthetic: exact answers ------------------------------------------------------------
def test_paper_measure_relative_threshold():
    video, a = press_video()
    np.testing.assert_allclose(frame_differences(video), a)
    kf = KeyFrameSelector().fit().select_one(video)
    # a(10) = 3 <= 10 % of 50, a(11) = 6 > 5 -> start 11; max at 25;
    # linspace(11, 25, 5) = 11, 14.5, 18, 21.5, 25 -> rounded half up
    np.testing.assert_array_equal(kf.indices, [11, 15, 18, 22, 25])
    assert (kf.start, kf.end) == (11, 25)
    np.testing.assert_array_equal(kf.frames, video[[11, 15, 18, 22, 25]])


def test_absolute_threshold_in_intensity_units():
    video, _ = press_video()
    sel = KeyFrameSelector(threshold=20, threshold_mode="absolute")
    # a(t) > 20 grey levels first at t0 + 6 = 16 (a(15) = 19, a(16) = 22); linspace(16, 25, 5)
    np.testing.assert_array_equal(sel.select_one(video).indices, [16, 18, 21, 23, 25])


def test_grey_video_and_n_between():
    video, _ = press_video(channels=0)
    assert video.ndim == 3
    out = KeyFrameSelector(n_between=1).fit_transform(video)
    np.testing.assert_array_equal(out, video[[11, 18, 25]])


def test_cancelling_contact_defeats_the_paper_measure_not_mean_abs():
    video, _ = press_video(split=True)
    with pytest.raises(DataFileError, match="shows no press"):
        KeyFrameSelector(measure="mean_intensity").transform(video)
    kf = KeyFrameSelector(measure="mean_abs").select_one(video)
    np.testing.assert_array_equal(kf.indices, [11, 15, 18, 22, 25])


def test_relative_threshold_is_invariant_to_gain_and_noise_floor():
    """Onset relative to the difference range: scaling the contact and adding a constant
    noise floor leaves the key frames unchanged."""
    _, a = press_video()
    base = key_frame_indices(a)
    np.testing.assert_array_equal(key_frame_indices(3 * a + np.r_[0, np.full(a.size - 1, 0.7)]), base)


def test_multiple_videos_and_as_gray():
    v1, _ = press_video()
    v2, _ = press_video(t0=5, t_peak=30)
    out = KeyFrameSelector(as_gray=True).fit_transform([v1, v2])
    assert out.shape == (2, 5, 8, 8) and out.dtype == np.float64
    assert 0.0 <= out.min() and out.max() <= 1.0
    with pytest.raises(DataFileError, match="different frame shapes"):
        KeyFrameSelector().transform([v1, press_video(h=16)[0]])


# -- errors --------------------------------------------------------------------------------
def test_too_short_video():
    video, _ = press_video(T=4, t0=1, t_peak=2)
    with pytest.raises(DataFileError, match="video has 4 frames; key-frame selection needs at least 5"):
        KeyFrameSelector().transform(video)


def test_nothing_exceeds_absolute_threshold():
    video, _ = press_video()
    with pytest.raises(DataFileError, match="by more than the threshold 60 .*maximum difference 50"):
        KeyFrameSelector(threshold=60, threshold_mode="absolute").transform(video)


def test_static_video_relative_mode():
    video = np.full((20, 4, 4), 7, np.uint8)
    with pytest.raises(DataFileError, match="no press"):
        KeyFrameSelector().transform(video)


def test_sudden_jump_cannot_give_distinct_frames():
    video = np.zeros((20, 4, 4), np.uint8)
    video[10:] = 200
    with pytest.raises(DataFileError, match=r"frame 10\) to its maximum \(frame 10\) in 0 frames"):
        KeyFrameSelector().transform(video)


def test_errors_name_the_video_file(tmp_path):
    import imageio.v3 as iio

    path = tmp_path / "still_press.avi"
    iio.imwrite(path, np.full((8, 32, 32, 3), 90, np.uint8), plugin="FFMPEG", fps=30, codec="mjpeg")
    with pytest.raises(DataFileError, match=r"still_press\.avi.*no press"):
        KeyFrameSelector().transform([path])
    unreadable = tmp_path / "broken.avi"
    unreadable.write_bytes(b"RIFF")
    with pytest.raises(DataFileError, match=r"broken\.avi"):
        KeyFrameSelector().transform([unreadable])


def test_bad_array_input():
    with pytest.raises(DataFileError, match=r"video 1: .*shape \(T, H, W\)"):
        KeyFrameSelector().transform([press_video()[0], np.zeros((5, 5))])
    nan_video = np.zeros((10, 4, 4))
    nan_video[3, 1, 1] = np.nan
    with pytest.raises(DataFileError, match="NaN"):
        KeyFrameSelector().transform(nan_video)


@pytest.mark.parametrize(
    "params, message",
    [
        ({"threshold": 1.5}, "relative threshold must lie in"),
        ({"threshold": -1, "threshold_mode": "absolute"}, "absolute threshold must be > 0"),
        ({"threshold_mode": "percent"}, "threshold_mode must be one of"),
        ({"measure": "ssim"}, "measure must be one of"),
        ({"n_between": 2.5}, "n_between must be an integer"),
    ],
)
def test_invalid_parameters(params, message):
    with pytest.raises(ConfigError, match=message):
        KeyFrameSelector(**params).fit()


def test_sklearn_api():
    est = KeyFrameSelector(threshold=0.2, measure="mean_abs")
    check_parameters_default_constructible("KeyFrameSelector", est)
    check_no_attributes_set_in_init("KeyFrameSelector", est)
    check_get_params_invariance("KeyFrameSelector", est)
    check_set_params("KeyFrameSelector", est)
    assert clone(est).get_params() == est.get_params()
    assert est.fit().n_key_frames_ == 5
    # check_estimator itself only feeds 2-D arrays; this estimator takes videos
    # (tagged three_d_array), so the API checks above are the applicable ones.


# -- the 15 real GelSight press videos ----------------------------------------------------
# Relation tested: the end key frame (maximum difference) lies on the force plateau of the
# press: the gripper force at that frame is >= FORCE_FRACTION of the press's peak force.
# (The gripper holds its force for up to ~25 frames, so the frame of the force maximum is
# an arbitrary point of the plateau; frame offsets to it are checked over all 15 videos:
# median |offset| <= MEDIAN_OFFSET and max <= MAX_OFFSET frames, 30 fps.) The start key
# frame comes after the first frames (>= 2) and before the force peak.
FORCE_FRACTION = 0.85
MEDIAN_OFFSET = 5
MAX_OFFSET = 20
# The paper's mean-intensity measure fails the relation on these three videos (measured:
# force at the end frame 41 %, 55 % and 0 % of the peak): on a GelSight Wedge the contact
# brightens some regions and darkens others, which cancel in the mean intensity.
PAPER_MEASURE_FAILS = {"green_ball_softer_1", "purple_ball_hardest_2", "purple_ball_hardest_3"}


@pytest.fixture(scope="module")
def real_key_frames(data_dir):
    from tzsl.datasets import load_gelsight_press

    out = {}
    sels = {m: KeyFrameSelector(measure=m).fit() for m in ("mean_intensity", "mean_abs")}
    lines = ["video                   measure         indices              force_peak offset F(end)/Fmax"]
    for rec in load_gelsight_press(data_dir):
        video = rec.read_video()  # decoded once, both measures, then dropped
        for m, sel in sels.items():
            kf = sel.select_one(video, source=rec.name)
            peak = int(np.argmax(rec.forces))
            ratio = float(rec.forces[kf.end] / rec.forces.max())
            out[rec.name, m] = (kf.indices, rec.forces, peak, ratio)
            lines.append(f"{rec.name:23s} {m:15s} {str(kf.indices):20s} {peak:10d} {kf.end - peak:+6d} {ratio:10.2f}")
    print("\n".join(lines))  # the measured offsets (pytest -s)
    return out


REAL = [
    f"{obj}_{i}"
    for obj in ("foam_brick", "golf_ball", "green_ball_softer", "orange_ball_softest", "purple_ball_hardest")
    for i in (1, 2, 3)
]


@pytest.mark.realdata
@pytest.mark.slow
def test_all_fifteen_real_videos_loaded(real_key_frames):
    assert sorted({name for name, _ in real_key_frames}) == sorted(REAL)


def _params():
    for name in REAL:
        yield pytest.param(name, "mean_abs", id=f"{name}-mean_abs")
        marks = (
            [pytest.mark.xfail(strict=True, reason="paper's mean-intensity measure: contact changes cancel")]
            if name in PAPER_MEASURE_FAILS
            else []
        )
        yield pytest.param(name, "mean_intensity", marks=marks, id=f"{name}-mean_intensity")


@pytest.mark.realdata
@pytest.mark.slow
@pytest.mark.parametrize("name, measure", list(_params()))
def test_end_key_frame_on_the_force_plateau(real_key_frames, name, measure):
    indices, forces, peak, ratio = real_key_frames[name, measure]
    assert ratio >= FORCE_FRACTION, f"force at end frame {indices[-1]} is {ratio:.0%} of the peak"


@pytest.mark.realdata
@pytest.mark.slow
def test_mean_abs_end_frame_offsets_to_force_peak(real_key_frames):
    offsets = np.array([abs(int(real_key_frames[n, "mean_abs"][0][-1]) - real_key_frames[n, "mean_abs"][2])
                        for n in REAL])
    assert np.median(offsets) <= MEDIAN_OFFSET, offsets
    assert offsets.max() <= MAX_OFFSET, offsets


@pytest.mark.realdata
@pytest.mark.slow
@pytest.mark.parametrize("measure", ["mean_abs", "mean_intensity"])
def test_contact_starts_after_the_first_frames(real_key_frames, measure):
    for name in REAL:
        indices, forces, peak, _ = real_key_frames[name, measure]
        assert indices[0] >= 2, name
        assert indices[0] < peak, name
        assert np.all(np.diff(indices) > 0), name


@pytest.mark.realdata
@pytest.mark.slow
def test_mean_abs_start_follows_force_onset(real_key_frames):
    """With the per-pixel measure the start frame is within 5 frames of the force onset
    (first frame with force > 10 % of the peak)."""
    for name in REAL:
        indices, forces, _, _ = real_key_frames[name, "mean_abs"]
        onset = int(np.argmax(forces > 0.1 * forces.max()))
        assert abs(int(indices[0]) - onset) <= 5, (name, int(indices[0]), onset)


def test_pipeline_video_files_to_texture_descriptors(tmp_path):
    """Paths of press videos -> 5 grey key frames -> per-frame texture descriptors."""
    import imageio.v3 as iio
    from sklearn.pipeline import make_pipeline

    from tzsl.features import TextureDescriptor

    paths = []
    for k, (t0, tp) in enumerate([(5, 20), (8, 24)]):
        video, _ = press_video(T=30, t0=t0, t_peak=tp, h=32, w=32)
        paths.append(tmp_path / f"press_{k}.avi")
        iio.imwrite(paths[-1], video, plugin="FFMPEG", fps=30, codec="mjpeg", quality=10)
    pipe = make_pipeline(
        KeyFrameSelector(as_gray=True, threshold=5, threshold_mode="absolute"),
        TextureDescriptor(lbp_radii=(1,), glcm_distances=(1,), gabor_frequencies=(0.2,)),
    )
    F = pipe.fit_transform(paths)
    d = pipe[-1].n_features_per_image_
    assert F.shape == (2, 5 * d) and np.isfinite(F).all()
    kf = pipe[0].select_one(paths[1])
    assert kf.end == 24 and 8 <= kf.start <= 10  # MJPG may shift grey levels slightly
