"""Random convolutional kernel (ROCKET) features of multichannel time series, through pyts.

A time-series transform beside the per-channel statistics of :mod:`tzsl.features._signal_stats`:
ROCKET (Dempster, Petitjean and Webb, 2020) convolves every series with random kernels (lengths 7,
9 or 11, random weights, bias, dilation and padding) and keeps two numbers per kernel, the maximum
of the convolution and the proportion of positive values (PPV). The kernels are those of
:class:`pyts.transformation.ROCKET` (pyts, the optional extra ``tzsl[timeseries]``). aeon's and
sktime's MiniRocket were the first choices but cannot be installed beside tzsl's locked versions
(aeon 1.6 caps numba below the first release that supports numpy 2.4; sktime 1.2 caps pandas below
3.1); pyts installs with them, and offers ROCKET, not MiniRocket.

How a trial of shape (n_rows, n_channels) becomes one vector, every step per trial and channel:

1. baseline (optional): the mean of the first ``baseline_rows`` rows is subtracted;
2. resampling: the channel is linearly interpolated to ``length`` points evenly spaced from its
   first to its last row (trials of any length >= 2 rows give series of one length; a longer
   trial is smoothed, a shorter one interpolated);
3. z-normalisation: minus the series' mean, divided by its standard deviation; a constant series
   (std <= 1e-12 times its scale) becomes all zeros rather than NaN;
4. ROCKET: ``2 * n_kernels`` numbers, the same kernels for every channel.

Output: ``n_channels * 2 * n_kernels`` values per trial, channel-major, named
``"<channel>_rocket<k>_max"`` / ``"<channel>_rocket<k>_ppv"``. Step 3 removes each series' level and
scale (a pressure level is lost): name ROCKET beside statistics (``statistics = ["mean", "std",
"min", "max", "rocket"]``) to keep both.

No leakage: :meth:`RocketFeatures.fit` reads only the channel count of the training trials and
draws the kernels from ``random_state`` (ROCKET's kernels, biases included, do not depend on the
data), and every later step is a function of one trial alone. A test trial's features are
therefore the same whatever trials the transformer was fitted on (a test checks it), which is why
a dataset's ROCKET features can be computed once, before its splits, like its statistics.

Cost: importing pyts compiles its numba kernels (about 20-60 CPU seconds on first use in a process,
not cached); the transform is about ``n_trials * n_channels * n_kernels * length * 9`` multiply-adds.
"""

from __future__ import annotations

from collections.abc import Sequence
from numbers import Integral
from typing import Any

import numpy as np
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.utils.validation import check_is_fitted

from tzsl.exceptions import ConfigError, DataFileError
from tzsl.features._signal_stats import subtract_baseline

__all__ = ["DEFAULT_ROCKET_KERNELS", "DEFAULT_ROCKET_LENGTH", "ROCKET_INSTALL_HINT", "SIGNAL_TRANSFORMS",
           "RocketFeatures", "rocket_class"]

#: Transform name -> one-line definition; a name that ``[signals] statistics`` accepts beside the statistics.
SIGNAL_TRANSFORMS: dict[str, str] = {
    "rocket": "ROCKET random convolutional kernels (pyts; tzsl[timeseries]): max and PPV per kernel and channel",
}

#: Kernels per channel when a dataset names ``"rocket"`` (2 features each).
DEFAULT_ROCKET_KERNELS = 25
#: Points every channel is resampled to before the kernels.
DEFAULT_ROCKET_LENGTH = 256
#: The one line a missing optional dependency gives.
ROCKET_INSTALL_HINT = "the 'rocket' signal transform needs pyts: pip install 'tzsl[timeseries]'"

#: Trials per batch of the transform (bounds the (n_trials * n_channels, length) intermediate array).
_BATCH = 64
#: A series whose std is at most this times its largest magnitude (or 1) counts as constant.
_FLAT = 1e-12


def rocket_class() -> Any:
    """:class:`pyts.transformation.ROCKET`, imported on first use.

    Raises
    ------
    ConfigError
        pyts is not installed (:data:`ROCKET_INSTALL_HINT`, one line).
    """
    try:
        from pyts.transformation import ROCKET  # noqa: PLC0415 (optional extra; its import compiles numba code)
    except ImportError:
        raise ConfigError(ROCKET_INSTALL_HINT) from None
    return ROCKET


def _check_int(name: str, value: object, low: int) -> int:
    if isinstance(value, bool) or not isinstance(value, Integral) or int(value) < low:
        raise ConfigError(f"{name} must be an integer >= {low}, got {value!r}")
    return int(value)


class RocketFeatures(TransformerMixin, BaseEstimator):
    """ROCKET features of multichannel time series, one vector per trial (see the module docstring).

    Parameters
    ----------
    n_kernels : int >= 1, default 25
        Random kernels; each gives 2 features per channel.
    length : int >= 16, default 256
        Points every channel is resampled to (linear interpolation).
    baseline_rows : int or None, default None
        If a positive int ``k``, subtract each channel's mean over its first ``k`` rows first.
    channels : sequence of str or None, default None
        Channel names for the output names; ``None``: ``ch0``, ``ch1``, ...
    random_state : int, default 0
        Seed of the kernels (the same seed gives the same features).

    Attributes
    ----------
    n_channels_ : int
        Channels seen in ``fit``; ``transform`` requires the same.
    rocket_ : pyts.transformation.ROCKET
        The fitted kernels.
    feature_names_out_ : ndarray of str, shape (n_channels * 2 * n_kernels,)

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> trials = [rng.normal(size=(n, 3)) for n in (120, 90)]
    >>> RocketFeatures(n_kernels=4, length=64).fit(trials).transform(trials).shape  # doctest: +SKIP
    (2, 24)
    """

    _parameter_constraints: dict = {
        "n_kernels": [Integral],
        "length": [Integral],
        "baseline_rows": [Integral, None],
        "channels": ["array-like", None],
        "random_state": [Integral],
    }

    def __init__(self, *, n_kernels: int = DEFAULT_ROCKET_KERNELS, length: int = DEFAULT_ROCKET_LENGTH,
                 baseline_rows: int | None = None, channels: Sequence[str] | None = None,
                 random_state: int = 0) -> None:
        self.n_kernels = n_kernels
        self.length = length
        self.baseline_rows = baseline_rows
        self.channels = channels
        self.random_state = random_state

    def _checked(self) -> tuple[int, int, int]:
        """(n_kernels, length, baseline rows or 0), each checked (ConfigError, one line)."""
        try:
            self._validate_params()  # the types of _parameter_constraints
        except (TypeError, ValueError) as exc:  # scikit-learn's InvalidParameterError is both
            raise ConfigError(" ".join(str(exc).split())) from None
        n_kernels = _check_int("n_kernels", self.n_kernels, 1)
        length = _check_int("length", self.length, 16)
        baseline = 0 if self.baseline_rows in (None, 0) else _check_int("baseline_rows", self.baseline_rows, 1)
        _check_int("random_state", self.random_state, 0)
        return n_kernels, length, baseline

    def _names(self, n_channels: int, n_kernels: int) -> list[str]:
        if self.channels is None:
            channels = [f"ch{j}" for j in range(n_channels)]
        else:
            if isinstance(self.channels, str) or not isinstance(self.channels, Sequence):
                raise ConfigError(f"channels must be a sequence of names, got {self.channels!r}")
            channels = [str(c) for c in self.channels]
            if len(channels) != n_channels:
                raise ConfigError(f"channels names {len(channels)} channels but the signals have {n_channels}")
        return [f"{c}_rocket{k}_{what}" for c in channels for k in range(n_kernels) for what in ("max", "ppv")]

    def fit(self, X: Sequence[np.ndarray] | np.ndarray, y: object = None) -> "RocketFeatures":
        """Check the parameters, record the channel count and draw the kernels. Returns self.

        Parameters
        ----------
        X : sequence of ndarray of shape (n_rows_i, n_channels), or ndarray (n_trials, n_rows, n_channels)
            The training trials; only their channel count is read.
        y : ignored
        """
        n_kernels, length, _ = self._checked()
        signals = _signals(X)
        n_channels = signals[0].shape[1]
        names = self._names(n_channels, n_kernels)
        rocket = rocket_class()(n_kernels=n_kernels, random_state=int(self.random_state))
        rocket.fit(np.zeros((1, length)))  # the kernels depend on the series length only
        self.rocket_ = rocket
        self.n_channels_ = n_channels
        self.feature_names_out_ = np.asarray(names, dtype=object)
        return self

    def transform(self, X: Sequence[np.ndarray] | np.ndarray) -> np.ndarray:
        """ROCKET features of every trial.

        Parameters
        ----------
        X : sequence of ndarray of shape (n_rows_i, n_channels), or ndarray (n_trials, n_rows, n_channels)
            Finite values, at least 2 rows per trial (and ``baseline_rows``).

        Returns
        -------
        ndarray of float64, shape (n_trials, n_channels * 2 * n_kernels)
            Channel-major (see ``feature_names_out_``): per kernel the maximum of the convolution (in
            units of the series' standard deviation) and the PPV (a proportion in [0, 1]).

        Raises
        ------
        DataFileError
            A trial that is not 2-D numeric, has another channel count, too few rows or a NaN/inf value
            (names the trial's position in ``X``).
        """
        check_is_fitted(self)
        n_kernels, length, baseline = self._checked()
        signals = _signals(X)
        out = np.empty((len(signals), self.n_channels_ * 2 * n_kernels))
        for lo in range(0, len(signals), _BATCH):
            part = signals[lo:lo + _BATCH]
            series = np.concatenate([_prepared(s, lo + i, self.n_channels_, length, baseline)
                                     for i, s in enumerate(part)], axis=0)
            out[lo:lo + len(part)] = self.rocket_.transform(series).reshape(len(part), -1)
        return out

    def get_feature_names_out(self, input_features: object = None) -> np.ndarray:
        """``"<channel>_rocket<k>_max"`` / ``_ppv``, shape (n_channels * 2 * n_kernels,)."""
        check_is_fitted(self)
        return self.feature_names_out_.copy()

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.input_tags.two_d_array = False
        tags.input_tags.three_d_array = True
        tags.non_deterministic = False
        return tags


def _signals(X: object) -> list[np.ndarray]:
    """A 3-D array or a sequence of 2-D numeric arrays -> list of arrays (DataFileError otherwise)."""
    if isinstance(X, np.ndarray):
        if X.ndim != 3:
            raise DataFileError(None, f"signals must be (n_rows, n_channels) arrays or one (n_trials, n_rows, "
                                      f"n_channels) array; got an array of shape {X.shape}")
        X = list(X)
    if isinstance(X, (str, bytes)) or not isinstance(X, Sequence) or len(X) == 0:
        raise DataFileError(None, "signals must be a non-empty sequence of (n_rows, n_channels) arrays")
    out = []
    for i, sig in enumerate(X):
        arr = np.asarray(sig)
        if arr.ndim != 2 or arr.dtype.kind not in "iufb":
            raise DataFileError(None, f"signal {i} is not a numeric (n_rows, n_channels) array "
                                      f"(shape {arr.shape}, dtype {arr.dtype})")
        out.append(arr)
    return out


def _prepared(signal: np.ndarray, index: int, n_channels: int, length: int, baseline: int) -> np.ndarray:
    """One trial -> (n_channels, length): baseline, linear resampling, z-normalisation (see the module)."""
    values = signal.astype(np.float64, copy=False)
    n_rows = values.shape[0]
    if values.shape[1] != n_channels:
        raise DataFileError(None, f"signal {index} has {values.shape[1]} channels; fitted on {n_channels}")
    need = max(2, baseline)
    if n_rows < need:
        raise DataFileError(None, f"signal {index} has {n_rows} rows; the rocket transform needs at least {need}")
    if not np.isfinite(values).all():
        row = int(np.argwhere(~np.isfinite(values))[0, 0])
        raise DataFileError(None, f"signal {index} holds NaN/inf (first at row {row})")
    if baseline:
        values = subtract_baseline(values, baseline)
    grid = np.linspace(0.0, n_rows - 1.0, length)
    rows = np.arange(n_rows, dtype=np.float64)
    series = np.stack([np.interp(grid, rows, values[:, c]) for c in range(n_channels)])
    mean = series.mean(axis=1, keepdims=True)
    std = series.std(axis=1, keepdims=True)
    scale = np.maximum(np.abs(series).max(axis=1, keepdims=True), 1.0)
    flat = std <= _FLAT * scale
    return np.where(flat, 0.0, (series - mean) / np.where(flat, 1.0, std))
