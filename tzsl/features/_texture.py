"""Classical texture descriptors for tactile / depth images (scikit-image based).

One image ``(H, W)`` -> one fixed-length vector made of four blocks, in this order:

1. **Intensity statistics** of the normalised image: mean, standard deviation and the
   ``percentiles`` (default 5, 25, 50, 75, 95).
2. **Uniform LBP histograms** (``skimage.feature.local_binary_pattern``, method
   ``"uniform"``: rotation-invariant uniform patterns) with ``lbp_points`` neighbours at
   each radius in ``lbp_radii``; ``lbp_points + 2`` bins per radius, normalised to sum 1.
   Computed on the normalised image quantised to 256 levels.
3. **GLCM statistics** (``skimage.feature.graycomatrix`` / ``graycoprops``): contrast,
   homogeneity, energy and correlation of the symmetric, normalised co-occurrence matrix
   at every distance in ``glcm_distances`` (pixels) and ``glcm_n_angles`` angles evenly
   spaced in [0, 180) degrees, on the image quantised to ``glcm_levels`` grey levels.
   For a constant image scikit-image defines correlation as 1.
4. **Gabor energies**: mean and standard deviation of the magnitude of the complex
   response to ``skimage.filters.gabor_kernel(frequency, theta)`` (bandwidth 1) for each
   frequency in ``gabor_frequencies`` and ``gabor_n_orientations`` orientations evenly
   spaced in [0, 180) degrees. For speed the image is first averaged over
   ``gabor_downsample`` x ``gabor_downsample`` blocks, so **frequencies are in cycles
   per pixel of the downsampled image** (0.1 at downsample 2 = 0.05 cycles per original
   pixel). The filtering is the same as ``skimage.filters.gabor`` (convolution with
   ``mode="reflect"`` borders) but done by FFT over a whole batch of images.

Normalisation (``normalization``)
---------------------------------
Every image is mapped to [0, 1] first (descriptors 2-4 need a fixed grey range):

``"robust"`` (default)
    Per image, the ``robust_percentiles`` (1st and 99th) of its values map to 0 and 1,
    values outside are clipped. Depth images carry a set-up dependent offset (camera
    distance) and contain invalid zero pixels: every one of the 1300 fabric depth PNGs
    has minimum 0 (dropouts, ~0.4 % of pixels) while valid depths lie in ~750-1480, so a
    plain min-max would be set by the dropouts and squeeze the texture into a fraction of
    the range. The robust range ignores up to 1 % outliers at each end, removes the offset
    and gain, and keeps the surface texture. It also drops absolute depth, which depends
    on the set-up rather than the fabric.
``"minmax"``
    Per image min-max to [0, 1].
``"fixed"``
    ``value_range=(lo, hi)`` in input units maps to [0, 1], clipped; keeps absolute
    intensity (use when all images come from one calibrated sensor).

A constant image (no range) becomes all zeros.

Input shapes
------------
``(n_images, H, W)`` -> ``(n_images, d)``; ``(n_videos, n_frames, H, W)`` (e.g. the 5 key
frames of :class:`tzsl.features.KeyFrameSelector` with ``as_gray=True``) -> the descriptor
of every frame concatenated in time order, ``(n_videos, n_frames * d)``.
"""

from __future__ import annotations

import numpy as np
from joblib import Parallel, delayed
from scipy import fft as sfft
from skimage.feature import graycomatrix, graycoprops
from skimage.filters import gabor_kernel
from skimage.measure import block_reduce
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.utils.validation import check_is_fitted

from tzsl._parallel import reissued, relayed
from tzsl.exceptions import ConfigError, DataFileError

__all__ = ["DESCRIPTOR_CHUNK", "TextureDescriptor", "texture_feature_names"]

_GLCM_PROPS = ("contrast", "homogeneity", "energy", "correlation")
_NORMALIZATIONS = ("robust", "minmax", "fixed")
#: Images per joblib task / per batched FFT (bounds memory: 64 x 12 filters x ~200^2 complex).
DESCRIPTOR_CHUNK = 64


def _angles(n: int) -> np.ndarray:
    return np.arange(n) * (np.pi / n)


def _deg(theta: float) -> str:
    return f"{np.degrees(theta):g}"


def texture_feature_names(params: dict) -> list[str]:
    """Names of the descriptor of one image, in output order (see the module docstring)."""
    names = ["mean", "std"] + [f"p{q:g}" for q in params["percentiles"]]
    for r in params["lbp_radii"]:
        names += [f"lbp_r{r:g}_u{b}" for b in range(int(params["lbp_points"]) + 2)]
    for prop in _GLCM_PROPS:
        for d in params["glcm_distances"]:
            names += [f"glcm_{prop}_d{d:g}_a{_deg(a)}" for a in _angles(params["glcm_n_angles"])]
    for f in params["gabor_frequencies"]:
        for t in _angles(params["gabor_n_orientations"]):
            names += [f"gabor_f{f:g}_o{_deg(t)}_mean", f"gabor_f{f:g}_o{_deg(t)}_std"]
    return names


def _normalise(images: np.ndarray, params: dict) -> np.ndarray:
    """(n, H, W) any numeric -> (n, H, W) float64 in [0, 1] (vectorised over images)."""
    x = images.astype(np.float64, copy=False)
    how = params["normalization"]
    if how == "robust":
        lo, hi = np.percentile(x, params["robust_percentiles"], axis=(1, 2))
    elif how == "minmax":
        lo, hi = x.min(axis=(1, 2)), x.max(axis=(1, 2))
    else:
        lo = np.full(x.shape[0], float(params["value_range"][0]))
        hi = np.full(x.shape[0], float(params["value_range"][1]))
    span = hi - lo
    ok = span > 0
    scale = np.where(ok, 1.0 / np.where(ok, span, 1.0), 0.0)
    out = (x - lo[:, None, None]) * scale[:, None, None]
    return np.clip(out, 0.0, 1.0)


def _quantise(x: np.ndarray, levels: int) -> np.ndarray:
    return np.minimum((x * levels).astype(np.int64), levels - 1).astype(np.uint8)


def _gabor_features(x: np.ndarray, params: dict) -> np.ndarray:
    """(n, H, W) in [0, 1] -> (n, 2 * n_freq * n_orient): mean, std of |response|."""
    f = int(params["gabor_downsample"])
    if f > 1:
        h, w = (x.shape[1] // f) * f, (x.shape[2] // f) * f
        x = block_reduce(x[:, :h, :w], (1, f, f), np.mean)
    kernels = [
        gabor_kernel(freq, theta=t)
        for freq in params["gabor_frequencies"]
        for t in _angles(params["gabor_n_orientations"])
    ]
    n, h, w = x.shape
    kmax = max(max(k.shape) for k in kernels)
    pad = kmax // 2 + 1
    # np.pad "symmetric" == ndimage "reflect" (what skimage.filters.gabor uses).
    xp = np.pad(x.astype(np.float32), ((0, 0), (pad, pad), (pad, pad)), mode="symmetric")
    # A circular convolution of the padded image is exact on the cropped centre as long
    # as the padding covers half a kernel, so no further zero padding is needed.
    shape = (sfft.next_fast_len(xp.shape[1]), sfft.next_fast_len(xp.shape[2]))
    fx = sfft.fft2(xp, s=shape, axes=(1, 2))  # complex64: single precision is ample here
    feats = np.empty((n, 2 * len(kernels)))
    for j, k in enumerate(kernels):
        full = sfft.ifft2(fx * sfft.fft2(k.astype(np.complex64), s=shape), axes=(1, 2))
        oy, ox = pad + (k.shape[0] - 1) // 2, pad + (k.shape[1] - 1) // 2
        mag = np.abs(full[:, oy : oy + h, ox : ox + w])
        feats[:, 2 * j] = mag.mean(axis=(1, 2), dtype=np.float64)
        feats[:, 2 * j + 1] = mag.std(axis=(1, 2), dtype=np.float64)
    return feats


def _uniform_lbp_histograms(images: np.ndarray, points: int, radius: float) -> np.ndarray:
    """Histograms of ``skimage.feature.local_binary_pattern(image, points, radius, "uniform")`` per image.

    The same codes as scikit-image's (its sampling points ``round(-R sin t, 5)``, ``round(R cos t,
    5)``, the same bilinear interpolation with zeros outside the image, the same comparison and
    count of 0/1 changes), computed with whole-image array operations instead of a loop over
    pixels, faster and equal bit for bit (``tests/features/test_texture.py``).

    Parameters
    ----------
    images : ndarray of shape (n, H, W)
        Grey images (any real dtype; compared as float64, as scikit-image does).
    points : int
        Neighbours P on the circle.
    radius : float
        Circle radius R in pixels.

    Returns
    -------
    ndarray of shape (n, points + 2), float64
        Per image, the share of pixels with each code 0 .. P + 1 (P + 1: not uniform).
    """
    images = np.asarray(images)
    n, rows, cols = images.shape
    angles = 2 * np.pi * np.arange(points, dtype=np.float64) / points
    pad = int(np.ceil(radius)) + 1
    r_pos, c_pos = np.arange(rows, dtype=np.float64), np.arange(cols, dtype=np.float64)
    # Each neighbour is read at (r + dr_i, c + dc_i). The offsets are rounded to 5 decimals, so
    # floor(r + dr_i) - r is one integer for every pixel row r (images far below 1e9 pixels); the
    # interpolation weights (r + dr_i) - floor(r + dr_i) are computed per row / column exactly as
    # scikit-image computes them per pixel (they differ in the last bit between rows).
    neighbours = []
    for dr_i, dc_i in zip(np.round(-radius * np.sin(angles), 5), np.round(radius * np.cos(angles), 5), strict=True):
        r, c = r_pos + dr_i, c_pos + dc_i
        wr, wc = (r - np.floor(r))[:, None], (c - np.floor(c))[None, :]
        r0, c0 = int(np.floor(dr_i)) + pad, int(np.floor(dc_i)) + pad
        r1, c1 = int(np.ceil(dr_i)) + pad, int(np.ceil(dc_i)) + pad
        # on the pixel grid the weights are 0: the interpolation returns the pixel itself
        neighbours.append((r0, r1, c0, c1, wr, wc, 1 - wr, 1 - wc, wr.any() or wc.any()))
    # a neighbour on the pixel grid is compared in the images' own dtype (``texture - image >= 0`` is
    # ``texture >= image`` for floats, and exact for integers), an interpolated one in float64
    padded = np.zeros((rows + 2 * pad, cols + 2 * pad))
    padded_raw = np.zeros((rows + 2 * pad, cols + 2 * pad), dtype=images.dtype)
    hists = np.empty((n, points + 2))
    for k in range(n):
        image_raw = images[k]
        image = image_raw.astype(np.float64)
        padded[pad:pad + rows, pad:pad + cols] = image
        padded_raw[pad:pad + rows, pad:pad + cols] = image_raw
        ones = np.zeros((rows, cols), dtype=np.int16)
        changes = np.zeros((rows, cols), dtype=np.int16)
        previous = None
        for r0, r1, c0, c1, wr, wc, wr_, wc_, between in neighbours:
            if between:
                top = wc_ * padded[r0:r0 + rows, c0:c0 + cols] + wc * padded[r0:r0 + rows, c1:c1 + cols]
                bottom = wc_ * padded[r1:r1 + rows, c0:c0 + cols] + wc * padded[r1:r1 + rows, c1:c1 + cols]
                signed = wr_ * top + wr * bottom >= image
            else:
                signed = padded_raw[r0:r0 + rows, c0:c0 + cols] >= image_raw
            ones += signed
            if previous is not None:  # changes between consecutive neighbours (not last to first)
                changes += signed != previous
            previous = signed
        codes = np.where(changes <= 2, ones, points + 1)
        hists[k] = np.bincount(codes.ravel(), minlength=points + 2) / codes.size
    return hists


def _describe(images: np.ndarray, params: dict) -> np.ndarray:
    """(n, H, W) raw -> (n, d) descriptors (one joblib task)."""
    x = _normalise(images, params)
    n = x.shape[0]
    stats = np.concatenate(
        [
            x.mean(axis=(1, 2))[:, None],
            x.std(axis=(1, 2))[:, None],
            np.percentile(x, params["percentiles"], axis=(1, 2)).T.reshape(n, -1),
        ],
        axis=1,
    )
    q256 = _quantise(x, 256)
    qg = _quantise(x, int(params["glcm_levels"]))
    p = int(params["lbp_points"])
    angles = _angles(int(params["glcm_n_angles"]))
    lbp = np.concatenate([_uniform_lbp_histograms(q256, p, r) for r in params["lbp_radii"]], axis=1)
    # scikit-image's GLCM works on one image at a time (compiled inner loops); images are spread
    # over joblib workers in chunks. The properties of every image's (distance, angle) matrices come
    # from one graycoprops call per property on the matrices side by side on its angle axis (each
    # matrix is normalised and reduced on its own, so the same numbers as one call per image).
    n_dist, n_angles = len(params["glcm_distances"]), len(angles)
    mats = np.concatenate([
        graycomatrix(qg[i], params["glcm_distances"], angles, levels=int(params["glcm_levels"]),
                     symmetric=True, normed=True)
        for i in range(n)], axis=3)  # (levels, levels, n_dist, n * n_angles)
    props = np.stack([graycoprops(mats, prop).reshape(n_dist, n, n_angles) for prop in _GLCM_PROPS])
    glcm = props.transpose(2, 0, 1, 3).reshape(n, -1)  # per image: property, distance, angle
    gabor = _gabor_features(x, params)
    return np.concatenate([stats, lbp, glcm, gabor], axis=1)


class TextureDescriptor(TransformerMixin, BaseEstimator):
    """Texture descriptor of grey / depth images (LBP, GLCM, Gabor, intensity statistics).

    See the module docstring for the blocks, the normalisation and the input shapes.
    ``fit`` learns nothing from the data; it fixes the input layout (images or videos of
    frames) and the feature names.

    Parameters
    ----------
    lbp_radii : tuple of float, default=(1, 3)
        LBP radii in pixels.
    lbp_points : int, default=8
        LBP neighbours per radius.
    glcm_distances : tuple of int, default=(1, 2, 4)
        GLCM pixel distances.
    glcm_n_angles : int, default=4
        GLCM angles (0, 45, 90, 135 degrees for 4).
    glcm_levels : int, default=32
        Grey levels of the GLCM.
    gabor_frequencies : tuple of float, default=(0.1, 0.2, 0.4)
        Gabor frequencies in cycles per pixel of the downsampled image.
    gabor_n_orientations : int, default=4
        Gabor orientations.
    gabor_downsample : int, default=2
        Block-averaging factor before Gabor filtering (1 = none).
    percentiles : tuple of float, default=(5, 25, 50, 75, 95)
        Percentiles of the normalised intensities.
    normalization : {"robust", "minmax", "fixed"}, default="robust"
        Mapping of each image to [0, 1].
    robust_percentiles : tuple of float, default=(1, 99)
        Percentiles mapped to 0 and 1 by ``"robust"``.
    value_range : tuple of float or None, default=None
        ``(lo, hi)`` in input units for ``"fixed"``.
    n_jobs : int or None, default=None
        joblib workers over chunks of 64 images (None = 1).

    Attributes
    ----------
    n_frames_ : int or None
        Frames per sample for 4-D input (video of frames), None for 3-D input.
    image_shape_ : tuple of int
        (H, W) seen in ``fit``.
    n_features_per_image_ : int
        Length ``d`` of one image's descriptor.
    n_features_out_ : int
        ``d`` or ``n_frames_ * d``.
    """

    def __init__(
        self,
        lbp_radii=(1, 3),
        lbp_points=8,
        glcm_distances=(1, 2, 4),
        glcm_n_angles=4,
        glcm_levels=32,
        gabor_frequencies=(0.1, 0.2, 0.4),
        gabor_n_orientations=4,
        gabor_downsample=2,
        percentiles=(5, 25, 50, 75, 95),
        normalization="robust",
        robust_percentiles=(1, 99),
        value_range=None,
        n_jobs=None,
    ) -> None:
        self.lbp_radii = lbp_radii
        self.lbp_points = lbp_points
        self.glcm_distances = glcm_distances
        self.glcm_n_angles = glcm_n_angles
        self.glcm_levels = glcm_levels
        self.gabor_frequencies = gabor_frequencies
        self.gabor_n_orientations = gabor_n_orientations
        self.gabor_downsample = gabor_downsample
        self.percentiles = percentiles
        self.normalization = normalization
        self.robust_percentiles = robust_percentiles
        self.value_range = value_range
        self.n_jobs = n_jobs

    # -- parameters -----------------------------------------------------------------
    def _params(self) -> dict:
        p = {k: getattr(self, k) for k in self.get_params() if k != "n_jobs"}
        for key in ("lbp_radii", "glcm_distances", "gabor_frequencies", "percentiles"):
            try:
                vals = tuple(float(v) for v in np.atleast_1d(p[key]))
            except (TypeError, ValueError):
                raise ConfigError(f"{key} must be a sequence of numbers; got {p[key]!r}") from None
            if not vals or (key != "percentiles" and any(v <= 0 for v in vals)):
                raise ConfigError(f"{key} must be a non-empty sequence of positive numbers; got {p[key]!r}")
            p[key] = vals
        if any(not 0 <= q <= 100 for q in p["percentiles"]):
            raise ConfigError(f"percentiles must lie in [0, 100]; got {self.percentiles!r}")
        p["glcm_distances"] = tuple(int(d) for d in p["glcm_distances"])
        for key, low in (("lbp_points", 1), ("glcm_n_angles", 1), ("glcm_levels", 2),
                         ("gabor_n_orientations", 1), ("gabor_downsample", 1)):
            v = p[key]
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < low:
                raise ConfigError(f"{key} must be an integer >= {low}; got {v!r}")
        if p["glcm_levels"] > 256:
            raise ConfigError(f"glcm_levels must be <= 256; got {p['glcm_levels']!r}")
        if p["normalization"] not in _NORMALIZATIONS:
            raise ConfigError(f"normalization must be one of {_NORMALIZATIONS}; got {p['normalization']!r}")
        lo_hi = p["robust_percentiles"]
        if len(tuple(lo_hi)) != 2 or not 0 <= lo_hi[0] < lo_hi[1] <= 100:
            raise ConfigError(f"robust_percentiles must be (lo, hi) with 0 <= lo < hi <= 100; got {lo_hi!r}")
        p["robust_percentiles"] = (float(lo_hi[0]), float(lo_hi[1]))
        if p["normalization"] == "fixed":
            vr = p["value_range"]
            if vr is None or len(tuple(vr)) != 2 or not float(vr[0]) < float(vr[1]):
                raise ConfigError(f'normalization="fixed" needs value_range=(lo, hi) with lo < hi; got {vr!r}')
        return p

    def _check_X(self, X, ndims=(3, 4)) -> np.ndarray:
        X = np.asarray(X)
        if X.ndim not in ndims:
            raise DataFileError(
                None,
                f"expected images of shape (n_images, H, W) or key frames of shape "
                f"(n_videos, n_frames, H, W); got an array of shape {X.shape}",
            )
        if not (np.issubdtype(X.dtype, np.integer) or np.issubdtype(X.dtype, np.floating)):
            raise DataFileError(None, f"images must be numeric; got dtype {X.dtype}")
        if X.size == 0 or min(X.shape[-2:]) < 2:
            raise DataFileError(None, f"images must be at least 2 x 2 pixels and non-empty; got shape {X.shape}")
        if np.issubdtype(X.dtype, np.floating):
            bad = ~np.isfinite(X.reshape(-1, *X.shape[-2:])).all(axis=(1, 2))
            if bad.any():
                raise DataFileError(
                    None, f"image {int(np.flatnonzero(bad)[0])} (flattened over frames) has NaN or infinite values"
                )
        return X

    # -- estimator API --------------------------------------------------------------
    def fit(self, X, y=None) -> TextureDescriptor:
        """Fix the input layout and feature names (no statistics are learnt).

        Parameters
        ----------
        X : ndarray of shape (n_images, H, W) or (n_videos, n_frames, H, W)
        y : ignored

        Returns
        -------
        self
        """
        params = self._params()
        X = self._check_X(X)
        self.n_frames_ = None if X.ndim == 3 else int(X.shape[1])
        self.image_shape_ = tuple(int(s) for s in X.shape[-2:])
        self.feature_names_per_image_ = texture_feature_names(params)
        self.n_features_per_image_ = len(self.feature_names_per_image_)
        self.n_features_out_ = self.n_features_per_image_ * (self.n_frames_ or 1)
        return self

    def transform(self, X) -> np.ndarray:
        """Descriptors of every image (frames concatenated in time order).

        Parameters
        ----------
        X : ndarray of shape (n_images, H, W) or (n_videos, n_frames, H, W)
            Same layout (3-D or 4-D, same ``n_frames``) as in ``fit``; image size may
            differ.

        Returns
        -------
        ndarray of shape (n_images, d) or (n_videos, n_frames * d), float64
        """
        check_is_fitted(self, "n_features_out_")
        params = self._params()
        X = self._check_X(X)
        want = 3 if self.n_frames_ is None else 4
        if X.ndim != want or (want == 4 and X.shape[1] != self.n_frames_):
            raise DataFileError(
                None,
                f"transform got shape {X.shape}; fitted on "
                + ("(n_images, H, W)" if want == 3 else f"(n_videos, {self.n_frames_}, H, W)"),
            )
        flat = X.reshape(-1, *X.shape[-2:])
        chunks = [flat[i : i + DESCRIPTOR_CHUNK] for i in range(0, flat.shape[0], DESCRIPTOR_CHUNK)]
        results = Parallel(n_jobs=self.n_jobs)(delayed(relayed(_describe))(c, params) for c in chunks)
        parts = [reissued(r) for r in results]
        out = np.concatenate(parts, axis=0)
        return out.reshape(X.shape[0], -1)

    def get_feature_names_out(self, input_features=None) -> np.ndarray:
        """Descriptor names; for frame input prefixed ``kf<k>_`` (k = 1..n_frames).

        Returns
        -------
        ndarray of str, shape (n_features_out,)
        """
        check_is_fitted(self, "n_features_out_")
        if self.n_frames_ is None:
            return np.asarray(self.feature_names_per_image_, dtype=object)
        return np.asarray(
            [f"kf{k + 1}_{name}" for k in range(self.n_frames_) for name in self.feature_names_per_image_], dtype=object
        )

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.input_tags.two_d_array = False
        tags.input_tags.three_d_array = True
        return tags
