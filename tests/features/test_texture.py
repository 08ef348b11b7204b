"""Texture descriptors (LBP, GLCM, Gabor, intensity statistics) of grey / depth images."""

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
from tzsl.features import TextureDescriptor
from tzsl.features._texture import _GLCM_PROPS, _angles, _gabor_features, _normalise, _quantise, _uniform_lbp_histograms

SMALL = dict(lbp_radii=(1, 2), glcm_distances=(1, 2), gabor_frequencies=(0.1, 0.25))


def _images(n=6, size=40, seed=0):
    rng = np.random.default_rng(seed)
    return rng.integers(700, 1500, size=(n, size, size)).astype(np.uint16)


def _stripes(theta_deg, size=64, period=8.0):
    y, x = np.mgrid[:size, :size]
    t = np.radians(theta_deg)
    # stripes whose wave vector points along theta (what gabor_kernel(theta) responds to)
    return 0.5 + 0.5 * np.cos(2 * np.pi * (x * np.cos(t) + y * np.sin(t)) / period)


def test_shapes_and_feature_names():
    td = TextureDescriptor().fit(_images())
    F = td.transform(_images())
    names = td.get_feature_names_out()
    # 2 + 5 stats, 2 radii x 10 LBP bins, 4 props x 3 distances x 4 angles, 3 freq x 4 orient x 2
    assert td.n_features_per_image_ == 7 + 20 + 48 + 24 == F.shape[1] == len(names)
    assert F.shape == (6, 99) and np.isfinite(F).all()
    assert len(set(names)) == len(names)
    assert names[0] == "mean" and "lbp_r3_u9" in names and "glcm_correlation_d4_a135" in names
    assert names[-1] == "gabor_f0.4_o135_std"


def test_lbp_histograms_sum_to_one():
    td = TextureDescriptor(**SMALL).fit(_images())
    F = td.transform(_images())
    names = td.get_feature_names_out()
    for r in ("1", "2"):
        cols = [i for i, n in enumerate(names) if n.startswith(f"lbp_r{r}_")]
        np.testing.assert_allclose(F[:, cols].sum(axis=1), 1.0)


def test_key_frames_are_concatenated_in_time_order():
    rng = np.random.default_rng(1)
    videos = rng.integers(0, 255, size=(3, 5, 32, 32)).astype(np.uint8)
    td = TextureDescriptor(**SMALL).fit(videos)
    F = td.transform(videos)
    d = td.n_features_per_image_
    assert F.shape == (3, 5 * d)
    per_image = TextureDescriptor(**SMALL).fit(videos[0]).transform(videos.reshape(-1, 32, 32))
    np.testing.assert_allclose(F, per_image.reshape(3, 5 * d))
    names = td.get_feature_names_out()
    assert names[0] == "kf1_mean" and names[d] == "kf2_mean" and names[-1].startswith("kf5_gabor")
    with pytest.raises(DataFileError, match="fitted on"):
        td.transform(videos[0])


def test_gabor_by_fft_equals_skimage_gabor():
    from skimage.filters import gabor

    img = _normalise(_images(2, 48), {"normalization": "robust", "robust_percentiles": (1, 99)})
    params = {"gabor_downsample": 1, "gabor_frequencies": (0.07, 0.3), "gabor_n_orientations": 3}
    got = _gabor_features(img, params)
    ref = []
    for f in (0.07, 0.3):
        for t in np.arange(3) * np.pi / 3:
            real, imag = gabor(img[1], f, theta=t)
            mag = np.hypot(real, imag)
            ref += [mag.mean(), mag.std()]
    np.testing.assert_allclose(got[1], ref, rtol=1e-4)


def test_gabor_energy_peaks_at_the_stripe_orientation():
    td = TextureDescriptor(gabor_frequencies=(0.125,), gabor_downsample=1).fit(np.zeros((1, 64, 64)))
    names = list(td.get_feature_names_out())
    for theta in (0, 45, 90, 135):
        F = td.transform(_stripes(theta)[None] * 1000)[0]
        energies = {o: F[names.index(f"gabor_f0.125_o{o}_mean")] for o in (0, 45, 90, 135)}
        assert max(energies, key=energies.get) == theta


def test_robust_normalisation_is_invariant_to_offset_and_gain():
    imgs = _images()
    td = TextureDescriptor(**SMALL).fit(imgs)
    # gain 4 and offset 512 are exact in binary floating point, so even the quantisation
    # for LBP / GLCM is identical (an inexact gain can flip a pixel across a level boundary)
    np.testing.assert_allclose(td.transform(imgs), td.transform(imgs.astype(float) * 4.0 + 512.0), atol=1e-9)


def test_robust_range_ignores_dropout_pixels_minmax_does_not():
    img = _images(1, 40).astype(float)
    holed = img.copy()
    holed[0, :2, :2] = 0  # 4 of 1600 pixels are depth dropouts (0.25 %)
    stats = slice(0, 7)  # mean, std, p5 .. p95 of the normalised image
    robust = TextureDescriptor(**SMALL).fit(img)
    assert np.abs(robust.transform(img)[0, stats] - robust.transform(holed)[0, stats]).max() < 0.01
    minmax = TextureDescriptor(normalization="minmax", **SMALL).fit(img)
    assert list(minmax.get_feature_names_out()[stats]) == ["mean", "std", "p5", "p25", "p50", "p75", "p95"]
    # min-max: the dropouts set the range and shift every statistic (mean 0.51 -> 0.74)
    assert np.abs(minmax.transform(img)[0, stats] - minmax.transform(holed)[0, stats]).max() > 0.2


def test_fixed_range_keeps_absolute_intensity():
    td = TextureDescriptor(normalization="fixed", value_range=(0, 2000), **SMALL).fit(_images())
    low, high = _images(), _images() + 400
    names = list(td.get_feature_names_out())
    diff = td.transform(high)[:, names.index("mean")] - td.transform(low)[:, names.index("mean")]
    np.testing.assert_allclose(diff, 0.2, atol=1e-9)


def test_constant_image_gives_finite_descriptor():
    F = TextureDescriptor(**SMALL).fit_transform(np.full((2, 30, 30), 5.0))
    assert np.isfinite(F).all()


def test_parallel_equals_serial():
    from joblib import parallel_config

    imgs = _images(70, 32)  # two chunks of 64
    a = TextureDescriptor(**SMALL).fit_transform(imgs)
    with parallel_config(backend="threading"):  # chunking/order check without process start-up
        b = TextureDescriptor(n_jobs=2, **SMALL).fit_transform(imgs)
    np.testing.assert_array_equal(a, b)


def test_bad_input():
    td = TextureDescriptor(**SMALL)
    with pytest.raises(DataFileError, match="expected images of shape"):
        td.fit(np.zeros((10, 10)))
    nan = np.zeros((3, 10, 10))
    nan[2, 0, 0] = np.nan
    with pytest.raises(DataFileError, match="image 2 .*NaN"):
        td.fit(nan)


@pytest.mark.parametrize(
    "params, message",
    [
        ({"normalization": "fixed"}, "needs value_range"),
        ({"normalization": "zscore"}, "normalization must be one of"),
        ({"lbp_radii": ()}, "lbp_radii must be a non-empty"),
        ({"glcm_levels": 1000}, "glcm_levels must be <= 256"),
        ({"gabor_downsample": 0}, "gabor_downsample must be an integer >= 1"),
        ({"percentiles": (50, 120)}, "percentiles must lie in"),
        ({"robust_percentiles": (99, 1)}, "robust_percentiles must be"),
    ],
)
def test_invalid_parameters(params, message):
    with pytest.raises(ConfigError, match=message):
        TextureDescriptor(**params).fit(_images())


def test_sklearn_api():
    est = TextureDescriptor(lbp_radii=(1,), n_jobs=1)
    check_parameters_default_constructible("TextureDescriptor", est)
    check_no_attributes_set_in_init("TextureDescriptor", est)
    check_get_params_invariance("TextureDescriptor", est)
    check_set_params("TextureDescriptor", est)
    assert clone(est).get_params() == est.get_params()
    # check_estimator feeds 2-D (n_samples, n_features) arrays only; this transformer takes
    # images (tagged three_d_array), so the API checks above are the applicable ones.
    from sklearn.exceptions import NotFittedError

    with pytest.raises(NotFittedError):
        est.transform(_images())


@pytest.mark.realdata
def test_real_depth_images(data_dir):
    from tzsl.datasets import load_fabric

    with pytest.warns(UserWarning, match="share one attribute vector"):
        data = load_fabric(data_dir)
    rows = np.flatnonzero(data.images["capture_index"].to_numpy() == 0)[:40]  # 40 fabrics
    imgs = data.read_images(rows)
    F = TextureDescriptor().fit_transform(imgs)
    assert F.shape == (40, 99) and np.isfinite(F).all()
    assert (F.std(axis=0) > 0).sum() >= 90  # descriptors vary across fabrics
    # two captures of one fabric are closer than captures of different fabrics (on average)
    same = data.read_images(
        np.flatnonzero(data.images["fabric_id"].to_numpy() == data.images["fabric_id"][rows[0]])[:2])
    Fs = TextureDescriptor().fit_transform(same)
    z = (F - F.mean(0)) / np.where(F.std(0) > 0, F.std(0), 1)
    zs = (Fs - F.mean(0)) / np.where(F.std(0) > 0, F.std(0), 1)
    within = np.linalg.norm(zs[0] - zs[1])
    between = np.median(np.linalg.norm(z[:, None] - z[None], axis=-1)[np.triu_indices(40, 1)])
    assert within < between


@pytest.mark.parametrize(("points", "radius"), [(8, 1.0), (8, 3.0), (4, 2.0), (16, 2.5), (8, 1.5)])
def test_uniform_lbp_histograms_equal_scikit_image_bit_for_bit(points, radius):
    from skimage.feature import local_binary_pattern

    rng = np.random.default_rng(points)
    images = np.concatenate([rng.integers(0, 256, size=(3, 23, 31)),  # 8-bit levels, as the descriptor's
                             np.repeat(rng.integers(0, 4, size=(1, 23, 1)), 31, axis=2)])  # ties and flat rows
    hists = _uniform_lbp_histograms(images.astype(np.uint8), points, radius)
    for image, hist in zip(images, hists, strict=True):
        codes = local_binary_pattern(image.astype(np.uint8), points, radius, method="uniform")
        expected = np.bincount(codes.astype(np.int64).ravel(), minlength=points + 2) / codes.size
        np.testing.assert_array_equal(hist, expected)


def test_glcm_block_equals_scikit_image_per_image_bit_for_bit():
    from skimage.feature import graycomatrix, graycoprops

    images = np.concatenate([_images(n=5, seed=3), np.full((1, 40, 40), 900, dtype=np.uint16)])  # and a flat one
    desc = TextureDescriptor(**SMALL, glcm_n_angles=3).fit(images)
    params = desc._params()
    out = desc.transform(images)
    glcm = out[:, [i for i, name in enumerate(desc.feature_names_per_image_) if name.startswith("glcm_")]]
    levels = int(params["glcm_levels"])
    for q, row in zip(_quantise(_normalise(images, params), levels), glcm, strict=True):
        mat = graycomatrix(q, params["glcm_distances"], _angles(3), levels=levels, symmetric=True, normed=True)
        np.testing.assert_array_equal(row, np.concatenate([graycoprops(mat, p).ravel() for p in _GLCM_PROPS]))
