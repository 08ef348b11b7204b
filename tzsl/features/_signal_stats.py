"""Per-channel summary statistics of generic time series (any tactile sensor).

Input: ``n_trials`` signals, each an array of shape ``(n_rows_i, n_channels)`` (rows are
time steps, lengths may differ), e.g. the per-trial signal files of a plain-file dataset
(see ``data/README.md``). Output: one vector per trial of ``n_channels * n_statistics``
values, channel-major (every statistic of channel 0, then of channel 1, ...), named
``"<channel>_<statistic>"`` like Penn's ``"pdc_max"``.

The statistics (:data:`SIGNAL_STATISTICS`) are all computed over the rows of one trial,
per channel, in the units of the signal (after baseline removal when requested):

==================  ==========================================================  ========
name                definition (x = one channel of one trial, n rows)            min rows
==================  ==========================================================  ========
``mean``            arithmetic mean                                              1
``std``             population standard deviation, sqrt(mean((x - mean)**2))    1
``min``, ``max``    smallest / largest value                                     1
``range``           max - min                                                    1
``median``          50th percentile (linear interpolation, numpy's default)      1
``iqr``             75th - 25th percentile (same interpolation)                  1
``skew``            g1 = m3 / m2**1.5 (biased; = ``scipy.stats.skew``)            1
``kurtosis``        excess g2 = m4 / m2**2 - 3 (biased; = ``scipy.stats.kurtosis``) 1
``rms``             sqrt(mean(x**2))                                             1
``energy``          sum(x**2) (grows with the number of rows)                    1
``mean_abs_diff``   mean(|x[t+1] - x[t]|), per row                               2
``slope``           least-squares slope of x against the row index, per row      2
==================  ==========================================================  ========

``m_k`` is the k-th central moment. For a channel whose variance is zero up to rounding
(scipy's rule: ``m2 <= (1e-15 * mean)**2``) ``skew`` and ``kurtosis`` are defined as 0
rather than NaN. ``slope`` and ``mean_abs_diff`` are in signal units per row; divide by the
sampling period to get units per second.

Baseline removal (optional, ``baseline_rows=k``): the mean of the first ``k`` rows of each
channel is subtracted from the whole trial first - the DAP paper's "mean of the first 100
readings" (:mod:`tzsl.features._baseline`), here on plain arrays. The BioTac version
(:func:`~tzsl.features.remove_baseline`) works on :class:`~tzsl.datasets.RawTrial` objects and
cannot take a plain array, hence the small array-level :func:`subtract_baseline`; both share
the parameter check :func:`~tzsl.features._baseline.check_baseline_rows`. A time average
alone is ``statistics=("mean",)``.

All trials of one call are concatenated and reduced per segment with ``np.ufunc.reduceat``
(one pass over the data, no Python loop over trials or rows).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.utils.validation import check_is_fitted

from tzsl.exceptions import ConfigError, DataFileError
from tzsl.features._baseline import check_baseline_rows

#: Statistic name -> one-line definition (see the module docstring for details).
SIGNAL_STATISTICS: dict[str, str] = {
    "mean": "arithmetic mean over the rows",
    "std": "population standard deviation (ddof=0)",
    "min": "smallest value",
    "max": "largest value",
    "range": "max - min",
    "median": "50th percentile (linear interpolation)",
    "iqr": "75th - 25th percentile (linear interpolation)",
    "skew": "biased Fisher-Pearson skewness m3 / m2**1.5 (0 for a constant channel)",
    "kurtosis": "biased excess kurtosis m4 / m2**2 - 3 (0 for a constant channel)",
    "rms": "root mean square sqrt(mean(x**2))",
    "energy": "sum of squares sum(x**2)",
    "mean_abs_diff": "mean absolute difference of consecutive rows (per row)",
    "slope": "least-squares slope against the row index (per row)",
}

#: Statistics computed when none are configured.
DEFAULT_SIGNAL_STATISTICS: tuple[str, ...] = ("mean", "std", "min", "max")

#: Minimum number of rows per trial each statistic needs (1 when not listed).
_MIN_ROWS: dict[str, int] = {"mean_abs_diff": 2, "slope": 2}

_QUANTILE_STATS = {"median", "iqr"}
_MOMENT_STATS = {"std", "skew", "kurtosis"}


def check_statistics(statistics: object) -> tuple[str, ...]:
    """Validate a ``statistics`` parameter: a non-empty sequence of distinct known names.

    Raises
    ------
    ConfigError
        A single string instead of a sequence, an empty sequence, a repeated or an unknown
        name (the message lists the known names).
    """
    if isinstance(statistics, str) or not isinstance(statistics, Sequence) or len(statistics) == 0:
        raise ConfigError(
            f"statistics must be a non-empty sequence of names such as ('mean', 'std'), got {statistics!r}"
        )
    names = tuple(statistics)
    unknown = [s for s in names if s not in SIGNAL_STATISTICS]
    if unknown:
        raise ConfigError(
            f"unknown signal statistic(s) {unknown}; choose from {', '.join(SIGNAL_STATISTICS)}"
        )
    if len(set(names)) != len(names):
        raise ConfigError(f"statistics lists a name twice: {list(names)}")
    return names


def min_rows_for(statistics: Sequence[str], baseline_rows: int | None = None) -> int:
    """Fewest rows a trial needs for ``statistics`` after a baseline of ``baseline_rows`` rows."""
    need = max((_MIN_ROWS.get(s, 1) for s in statistics), default=1)
    return max(need, int(baseline_rows or 0))


def _check_baseline(baseline_rows: object) -> int:
    """``None``/0 -> 0 (no baseline), else a positive int (ConfigError otherwise)."""
    if baseline_rows is None or (isinstance(baseline_rows, (int, np.integer)) and not isinstance(baseline_rows, bool)
                                 and baseline_rows == 0):
        return 0
    return check_baseline_rows(baseline_rows)


def _segment_baseline(values: np.ndarray, starts: np.ndarray, baseline_rows: int) -> np.ndarray:
    """Mean of the first ``baseline_rows`` rows of every segment, shape (n_segments, n_channels)."""
    rows = starts[:, None] + np.arange(baseline_rows)[None, :]
    return values[rows].mean(axis=1)


def subtract_baseline(signal: np.ndarray, baseline_rows: int) -> np.ndarray:
    """Subtract from each channel the mean of its first ``baseline_rows`` rows.

    Parameters
    ----------
    signal : array-like of shape (n_rows, n_channels)
        One trial; ``n_rows >= baseline_rows``.
    baseline_rows : int >= 1
        Number of leading rows that define the baseline.

    Returns
    -------
    ndarray of float64, shape (n_rows, n_channels)
        The signal relative to its baseline (same units).
    """
    baseline_rows = check_baseline_rows(baseline_rows)
    values = np.asarray(signal, dtype=np.float64)
    if values.ndim != 2:
        raise DataFileError(None, f"signal has shape {values.shape}; expected (n_rows, n_channels)")
    if values.shape[0] < baseline_rows:
        raise DataFileError(None, f"signal has {values.shape[0]} rows; baseline removal needs {baseline_rows}")
    return values - _segment_baseline(values, np.array([0]), baseline_rows)


def _as_signals(X: object) -> list[np.ndarray]:
    """A 3-D array or a sequence of 2-D arrays -> list of 2-D float64 arrays (checked)."""
    if isinstance(X, np.ndarray):
        if X.ndim != 3:
            raise DataFileError(
                None, f"signals must be a sequence of (n_rows, n_channels) arrays or one array of shape "
                f"(n_trials, n_rows, n_channels); got an array of shape {X.shape}"
            )
        X = list(X)
    if isinstance(X, (str, bytes)) or not isinstance(X, Sequence):
        raise DataFileError(None, f"signals must be a sequence of 2-D arrays, got {type(X).__name__}")
    if len(X) == 0:
        raise DataFileError(None, "no signals to summarise")
    out = []
    for i, sig in enumerate(X):
        arr = np.asarray(sig)
        if arr.ndim != 2:
            raise DataFileError(None, f"signal {i} has shape {arr.shape}; expected (n_rows, n_channels)")
        if arr.dtype.kind not in "iufb":
            raise DataFileError(None, f"signal {i} is not numeric (dtype {arr.dtype})")
        out.append(arr.astype(np.float64, copy=False))
    return out


class SignalStatistics(TransformerMixin, BaseEstimator):
    """Per-channel summary statistics of time series, one vector per trial.

    Stateless apart from the channel count: ``fit`` records the number of channels and the
    output names; ``transform`` summarises each trial independently, so fitting on training
    trials and transforming test trials leaks nothing.

    Parameters
    ----------
    statistics : sequence of str, default ("mean", "std", "min", "max")
        Names from :data:`SIGNAL_STATISTICS`, in output order within each channel.
        ``("mean",)`` is a plain time average.
    baseline_rows : int or None, default None
        If a positive int ``k``, subtract each channel's mean over the first ``k`` rows of
        the trial before summarising (every trial needs at least ``k`` rows). ``None`` or 0:
        no baseline removal.
    channels : sequence of str or None, default None
        Channel names used in the output names; ``None`` names them ``ch0``, ``ch1``, ...

    Attributes
    ----------
    n_channels_ : int
        Number of channels seen in ``fit``; ``transform`` requires the same.
    feature_names_out_ : ndarray of str, shape (n_channels * n_statistics,)
        ``"<channel>_<statistic>"``, channel-major.

    Examples
    --------
    >>> import numpy as np
    >>> sig = np.array([[0.0, 1.0], [2.0, 1.0], [4.0, 1.0]])
    >>> SignalStatistics(statistics=("mean", "slope")).fit_transform([sig])
    array([[2., 2., 1., 0.]])
    """

    def __init__(
        self,
        statistics: Sequence[str] = DEFAULT_SIGNAL_STATISTICS,
        baseline_rows: int | None = None,
        channels: Sequence[str] | None = None,
    ) -> None:
        self.statistics = statistics
        self.baseline_rows = baseline_rows
        self.channels = channels

    def _names(self, n_channels: int) -> list[str]:
        if self.channels is None:
            channels = [f"ch{j}" for j in range(n_channels)]
        else:
            if isinstance(self.channels, str) or not isinstance(self.channels, Sequence):
                raise ConfigError(f"channels must be a sequence of names, got {self.channels!r}")
            channels = [str(c) for c in self.channels]
            if len(channels) != n_channels:
                raise ConfigError(f"channels names {len(channels)} channels but the signals have {n_channels}")
            if len(set(channels)) != len(channels):
                raise ConfigError(f"channels lists a name twice: {channels}")
        return [f"{c}_{s}" for c in channels for s in check_statistics(self.statistics)]

    def fit(self, X: Sequence[np.ndarray] | np.ndarray, y: object = None) -> "SignalStatistics":
        """Check the parameters and record the channel count. Returns self.

        Parameters
        ----------
        X : sequence of ndarray of shape (n_rows_i, n_channels), or ndarray of shape
            (n_trials, n_rows, n_channels)
        y : ignored
        """
        check_statistics(self.statistics)
        _check_baseline(self.baseline_rows)
        signals = _as_signals(X)
        n_channels = signals[0].shape[1]
        self.feature_names_out_ = np.asarray(self._names(n_channels), dtype=object)
        self.n_channels_ = n_channels
        return self

    def transform(self, X: Sequence[np.ndarray] | np.ndarray) -> np.ndarray:
        """Summary statistics of every trial.

        Parameters
        ----------
        X : sequence of ndarray of shape (n_rows_i, n_channels), or ndarray of shape
            (n_trials, n_rows, n_channels)
            Finite values; every trial needs at least :func:`min_rows_for` rows.

        Returns
        -------
        ndarray of float64, shape (n_trials, n_channels * n_statistics)
            Channel-major (see ``feature_names_out_``), in the signal's units.

        Raises
        ------
        DataFileError
            A signal that is not 2-D numeric, has another channel count, too few rows or a
            NaN/inf value (names the trial's position in ``X``).
        """
        check_is_fitted(self)
        stats = check_statistics(self.statistics)
        baseline = _check_baseline(self.baseline_rows)
        signals = _as_signals(X)
        lengths = np.array([s.shape[0] for s in signals])
        widths = np.array([s.shape[1] for s in signals])
        if (widths != self.n_channels_).any():
            i = int(np.flatnonzero(widths != self.n_channels_)[0])
            raise DataFileError(None, f"signal {i} has {widths[i]} channels; fitted on {self.n_channels_}")
        need = min_rows_for(stats, baseline)
        if (lengths < need).any():
            i = int(np.flatnonzero(lengths < need)[0])
            raise DataFileError(
                None, f"signal {i} has {lengths[i]} rows; statistics {list(stats)} with baseline_rows="
                f"{baseline} need at least {need}"
            )
        values = np.concatenate(signals, axis=0)
        finite = np.isfinite(values)
        if not finite.all():
            row = int(np.argwhere(~finite)[0, 0])
            ends = np.cumsum(lengths)
            i = int(np.searchsorted(ends, row, side="right"))
            raise DataFileError(None, f"signal {i} holds NaN/inf (first at row {row - (ends[i] - lengths[i])})")
        return signal_statistics(values, lengths, stats, baseline)

    def get_feature_names_out(self, input_features: object = None) -> np.ndarray:
        """Output names ``"<channel>_<statistic>"``, shape (n_channels * n_statistics,)."""
        check_is_fitted(self)
        return self.feature_names_out_.copy()

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.input_tags.two_d_array = False
        tags.input_tags.three_d_array = True
        return tags


def signal_statistics(
    values: np.ndarray, lengths: np.ndarray, statistics: Sequence[str], baseline_rows: int = 0
) -> np.ndarray:
    """Statistics of concatenated trials (the vectorised core of :class:`SignalStatistics`).

    Parameters
    ----------
    values : ndarray of float64, shape (sum(lengths), n_channels)
        The trials stacked along the rows, finite.
    lengths : ndarray of int, shape (n_trials,)
        Rows of each trial, each >= ``min_rows_for(statistics, baseline_rows)``.
    statistics : sequence of str
        Checked names from :data:`SIGNAL_STATISTICS`.
    baseline_rows : int, default 0
        Rows of the per-trial baseline subtracted first (0: none).

    Returns
    -------
    ndarray of float64, shape (n_trials, n_channels * len(statistics))
        Channel-major.
    """
    lengths = np.asarray(lengths, dtype=np.int64)
    starts = np.concatenate([[0], np.cumsum(lengths)[:-1]])
    n_trials, n_channels = len(lengths), values.shape[1]
    counts = lengths[:, None].astype(np.float64)
    if baseline_rows:
        values = values - np.repeat(_segment_baseline(values, starts, baseline_rows), lengths, axis=0)
    wanted = set(statistics)
    out: dict[str, np.ndarray] = {}

    mean = np.add.reduceat(values, starts, axis=0) / counts
    out["mean"] = mean
    if wanted & {"min", "range"}:
        out["min"] = np.minimum.reduceat(values, starts, axis=0)
    if wanted & {"max", "range"}:
        out["max"] = np.maximum.reduceat(values, starts, axis=0)
    if "range" in wanted:
        out["range"] = out["max"] - out["min"]
    if wanted & {"rms", "energy"}:
        energy = np.add.reduceat(values * values, starts, axis=0)
        out["energy"] = energy
        out["rms"] = np.sqrt(energy / counts)
    if wanted & (_MOMENT_STATS | {"slope"}):
        centred = values - np.repeat(mean, lengths, axis=0)
        m2 = np.add.reduceat(centred**2, starts, axis=0) / counts
        out["std"] = np.sqrt(m2)
        if wanted & {"skew", "kurtosis"}:
            flat = m2 <= (np.finfo(np.float64).resolution * mean) ** 2  # scipy's "constant" rule
            safe = np.where(flat, 1.0, m2)
            if "skew" in wanted:
                m3 = np.add.reduceat(centred**3, starts, axis=0) / counts
                out["skew"] = np.where(flat, 0.0, m3 / safe**1.5)
            if "kurtosis" in wanted:
                m4 = np.add.reduceat(centred**4, starts, axis=0) / counts
                out["kurtosis"] = np.where(flat, 0.0, m4 / safe**2 - 3.0)
        if "slope" in wanted:
            # row index within the trial, centred: t - (n - 1) / 2
            t = np.arange(values.shape[0]) - np.repeat(starts, lengths) - np.repeat((lengths - 1) / 2.0, lengths)
            sxt = np.add.reduceat(centred * t[:, None], starts, axis=0)
            stt = (lengths * (lengths.astype(np.float64) ** 2 - 1) / 12.0)[:, None]
            out["slope"] = sxt / stt
    if "mean_abs_diff" in wanted:
        diffs = np.abs(np.diff(values, axis=0))
        diffs = np.concatenate([diffs, np.zeros((1, n_channels))])  # row j: |x[j+1] - x[j]|
        ends = starts + lengths - 1
        diffs[ends] = 0.0  # the difference across two trials does not count
        out["mean_abs_diff"] = np.add.reduceat(diffs, starts, axis=0) / (counts - 1)
    if wanted & _QUANTILE_STATS:
        q = _segment_quantiles(values, starts, lengths, (0.25, 0.5, 0.75))
        out["median"] = q[1]
        out["iqr"] = q[2] - q[0]
    stacked = np.stack([out[s] for s in statistics], axis=2)  # (n_trials, n_channels, n_stats)
    return stacked.reshape(n_trials, n_channels * len(statistics))


def _segment_quantiles(
    values: np.ndarray, starts: np.ndarray, lengths: np.ndarray, qs: Sequence[float]
) -> list[np.ndarray]:
    """Quantiles (numpy's "linear" method) of every trial and channel, each (n_trials, n_channels).

    One ``np.lexsort`` orders the values by (trial, channel, value); the quantile of a
    group of ``n`` sorted values at ``q`` interpolates between positions floor/ceil of
    ``q * (n - 1)``.
    """
    n_rows, n_channels = values.shape
    seg = np.repeat(np.arange(len(lengths)), lengths)
    flat = values.T.reshape(-1)  # channel-major: element (c, r)
    chan = np.repeat(np.arange(n_channels), n_rows)
    order = np.lexsort((flat, chan, np.tile(seg, n_channels)))
    ordered = flat[order]  # grouped by trial, then channel, then sorted value
    group_start = (starts * n_channels)[:, None] + np.arange(n_channels)[None, :] * lengths[:, None]
    result = []
    for q in qs:
        pos = q * (lengths - 1).astype(np.float64)
        lo = np.floor(pos).astype(np.int64)
        hi = np.minimum(lo + 1, lengths - 1)
        frac = (pos - lo)[:, None]
        a = ordered[group_start + lo[:, None]]
        b = ordered[group_start + hi[:, None]]
        result.append(a + frac * (b - a))
    return result
