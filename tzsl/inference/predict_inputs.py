"""Read the grasps given to ``tzsl predict`` into the feature matrix a saved model expects.

A bundle's *feature schema* (metadata ``input``, written by :func:`feature_schema`) says what the
model reads; :func:`read_inputs` turns input files into that matrix. The reader
depends on the data format only, never on the model:

``{"format": "features", "sensors": [s str], "feature_names": [d str], "ndim": 2 or 3, "signals": ...}``
    Per-sensor feature rows. ``ndim`` 3 gives ``X`` of shape (n, s, d) (per-sensor methods such
    as DAP), 2 gives (n, s * d) (sensors side by side). Inputs:

    * a feature CSV: one row per trial (and sensor), the model's feature columns (any order; other
      columns such as ``class`` or ``object_name`` are ignored, so a plain dataset's own
      ``trials.csv`` or a ``tzsl extract --out`` table works; no attribute table is read);
      ``trial_id`` names the trials (default ``<file stem>_<row>``); with several sensors a
      ``sensor`` column and ``trial_id`` are required;
    * a feature ``.npz`` with ``X`` (n, s, d), ``sensors``, ``feature_names`` and optionally
      ``trial_id`` (as written by ``tzsl extract --out``);
    * when the model was trained on signal files (``signals``: ``channels``, ``statistics``,
      ``baseline_rows``): one signal file (``.npz`` / ``.csv``, time x channels, the plain
      format's) per grasp for a one-sensor model, or a CSV with a ``signal_file`` column (paths
      relative to the CSV, e.g. the dataset's ``trials.csv``) and ``sensor`` / ``trial_id``
      columns as above. Features are the same per-channel statistics as in training.
``{"format": "hand-grasps", "feature_params": {...}}``
    Grasp ``.npz`` files or grasp folders (``data/README.md``); grasps in which no BioTac touched
    are skipped with a note (the paper drops them).
``{"format": "frames"}``
    Press videos (5 key frames are selected) or ``.npz`` files holding ``frames`` (5, H, W[, C]).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from tzsl._io import read_npz
from tzsl.datasets import FeatureSet, read_csv_table, read_grasps, read_signal_file, signal_from_arrays
from tzsl.exceptions import ConfigError, DataFileError, ModelBundleError

__all__ = ["INPUT_FORMATS", "Grasps", "describe_inputs", "feature_schema", "grasp_model_input", "read_feature_rows",
           "read_inputs"]

#: Feature-schema formats :func:`read_inputs` reads.
INPUT_FORMATS: tuple[str, ...] = ("features", "hand-grasps", "frames")


def feature_schema(features: FeatureSet, ndim: int) -> dict:
    """The ``input`` metadata of a model fitted on ``features``.

    Parameters
    ----------
    features : tzsl.datasets.FeatureSet
        The training features: their sensors and feature names are the layout the model reads.
        Signal datasets (``features.info`` holding ``statistics``) also record the channels,
        statistics and baseline rows, so signal files can be given at predict time.
    ndim : {2, 3}
        The method's input (:attr:`tzsl.models.Method.input_ndim`).
    """
    if ndim not in (2, 3):
        raise ConfigError(f"ndim must be 2 or 3, got {ndim!r}")
    schema: dict[str, Any] = {"format": "features", "sensors": [str(s) for s in features.sensors],
                              "feature_names": [str(f) for f in features.feature_names], "ndim": int(ndim)}
    info = features.info or {}
    if "statistics" in info:
        schema["signals"] = {"channels": list(info["channels"]), "statistics": list(info["statistics"]),
                             "baseline_rows": int(info.get("baseline_rows", 0))}
    return schema


@dataclass
class Grasps:
    """The grasps read from the input files, in order.

    Attributes
    ----------
    X : ndarray of shape (n, ...)
        Model input, one row per grasp.
    grasp_ids, sources, info : list of str, length n
        Id, file and a short description of every grasp kept.
    notes : list of str
        Grasps skipped and why.
    """

    X: np.ndarray
    grasp_ids: list[str]
    sources: list[str]
    info: list[str]
    notes: list[str] = field(default_factory=list)


def describe_inputs(schema: dict) -> str:
    """What a model with this feature schema takes as input, for help and error messages."""
    fmt = schema.get("format")
    if fmt == "hand-grasps":
        return "grasp .npz files or grasp folders"
    if fmt == "frames":
        return "press videos (.avi) or .npz files with a 'frames' array (5, H, W[, C])"
    text = f"feature files (.csv / .npz) with the columns of {len(schema['feature_names'])} features"
    if schema.get("signals"):
        text += " or signal files (.npz / .csv), or a CSV with a signal_file column"
    return text


def read_inputs(schema: dict, inputs: Sequence[str | Path]) -> Grasps:
    """Read ``inputs`` (in arrival order) as the model with feature ``schema`` expects them.

    Raises
    ------
    DataFileError
        Missing or unreadable file, missing sensors / features / channels, bad values
        (one line naming the file).
    """
    if not inputs:
        raise DataFileError(None, "no input given")
    fmt = schema.get("format")
    if fmt == "hand-grasps":
        return _hand_grasps(schema, inputs)
    if fmt == "frames":
        return _frames(inputs)
    if fmt != "features":
        raise ModelBundleError(f"model bundle: unknown input format {fmt!r}; known: {list(INPUT_FORMATS)}")
    parts = [read_feature_rows(Path(p), schema) for p in inputs]
    X = np.concatenate([x for x, _ in parts])
    ids = [i for _, trial_ids in parts for i in trial_ids]
    sources = [str(p) for p, (_, trial_ids) in zip(inputs, parts, strict=True) for _ in trial_ids]
    info = [f"{X.shape[1]} sensor{'s' if X.shape[1] > 1 else ''}"] * X.shape[0]
    return Grasps(_model_layout(X, schema), ids, sources, info)


def _model_layout(X: np.ndarray, schema: dict) -> np.ndarray:
    """Feature rows (n, s, d) in the model's layout: as they are (``ndim`` 3) or sensors side by side (2)."""
    return X.reshape(X.shape[0], -1) if int(schema.get("ndim", 3)) == 2 else X


def grasp_model_input(schema: dict, features: np.ndarray) -> np.ndarray:
    """One grasp's feature array as the model input of a ``"features"`` schema.

    Parameters
    ----------
    schema : dict
        The bundle's feature schema (``format`` ``"features"``).
    features : array-like of shape (n_sensors, n_features)
        The grasp's features, rows in the schema's ``sensors`` order, columns in its
        ``feature_names`` order, in the units of the training features (a one-sensor model also
        takes shape (n_features,)).

    Returns
    -------
    ndarray of shape (1, n_sensors, n_features) or (1, n_sensors * n_features)
        As :func:`read_inputs` gives one grasp (``ndim`` 3 or 2).

    Raises
    ------
    ConfigError
        Another input format, a wrong shape, or NaN / infinite values.
    """
    if schema.get("format") != "features":
        raise ConfigError(f"this model reads {describe_inputs(schema)}: give the grasp's file, not an array")
    shape = (len(schema["sensors"]), len(schema["feature_names"]))
    try:
        X = np.asarray(features, dtype=np.float64)
    except (TypeError, ValueError):
        raise ConfigError(f"grasp features must be numbers of shape {shape} (sensors x features)") from None
    if X.shape != shape and not (shape[0] == 1 and X.shape == shape[1:]):
        raise ConfigError(f"grasp features have shape {X.shape}; the model needs {shape} "
                          f"(sensors {list(schema['sensors'])} x {shape[1]} features)")
    if not np.isfinite(X).all():
        raise ConfigError("grasp features hold NaN or infinite values")
    return _model_layout(X.reshape((1, *shape)), schema)


# ---------------------------------------------------------------------------- feature rows
def read_feature_rows(path: Path, schema: dict) -> tuple[np.ndarray, list[str]]:
    """Feature rows of one input file, laid out as the schema's sensors and features.

    Returns
    -------
    X : ndarray of shape (n_trials, n_sensors, n_features), finite float64
    trial_ids : list of str, length n_trials
    """
    if not path.is_file():
        raise DataFileError(path, "input file not found")
    suffix = path.suffix.lower()
    if suffix == ".npz":
        arrays = read_npz(path)
        if "X" in arrays:
            return _npz_rows(path, arrays, schema)
        return _one_signal(path, schema, arrays)
    if suffix != ".csv":
        raise DataFileError(path, f"unsupported input type {path.suffix!r}; use .csv or .npz")
    frame = read_csv_table(path)
    if "signal_file" in frame.columns:
        return _signal_manifest(path, frame, schema)
    if schema.get("signals") and not set(schema["feature_names"]) & set(frame.columns):
        return _one_signal(path, schema)
    return _csv_rows(path, frame, schema)


def _check_layout(path: Path, sensors: Sequence[str], names: Sequence[str], schema: dict) -> tuple[list, list]:
    """Indices of the schema's sensors and features in the file's ``sensors`` and ``names``."""
    want_s, want_f = list(schema["sensors"]), list(schema["feature_names"])
    missing_s = [s for s in want_s if s not in sensors]
    if missing_s:
        raise DataFileError(path, f"sensor(s) {missing_s} missing; the model needs sensors {want_s}, "
                                  f"the file has {list(sensors)}")
    missing_f = [f for f in want_f if f not in names]
    if missing_f:
        raise DataFileError(path, f"{len(missing_f)} feature column(s) the model needs are missing, e.g. "
                                  f"{missing_f[:5]}; extract the features with the settings used for training")
    return [list(sensors).index(s) for s in want_s], [list(names).index(f) for f in want_f]


def _finite(path: Path, X: np.ndarray, ids: list[str]) -> tuple[np.ndarray, list[str]]:
    if not np.isfinite(X).all():
        bad = int(np.argwhere(~np.isfinite(X))[0, 0])
        raise DataFileError(path, "NaN or infinite feature value", trial=ids[bad])
    return X, ids


def _npz_rows(path: Path, arrays: dict, schema: dict) -> tuple[np.ndarray, list[str]]:
    X = np.asarray(arrays["X"])
    if X.ndim != 3 or X.dtype.kind not in "iuf":
        raise DataFileError(path, f"X has shape {X.shape} and dtype {X.dtype}; expected numbers (n_trials, "
                                  "n_sensors, n_features)")
    missing = [k for k in ("sensors", "feature_names") if k not in arrays]
    if missing:
        raise DataFileError(path, f"missing arrays {missing} naming the axes of X")
    sensors, names = [str(s) for s in arrays["sensors"]], [str(f) for f in arrays["feature_names"]]
    if (len(sensors), len(names)) != X.shape[1:]:
        raise DataFileError(path, f"X has shape {X.shape} but {len(sensors)} sensors and {len(names)} feature names")
    s_idx, f_idx = _check_layout(path, sensors, names, schema)
    ids = ([str(t) for t in arrays["trial_id"]] if "trial_id" in arrays and len(arrays["trial_id"]) == len(X)
           else [f"{path.stem}_{i}" for i in range(len(X))])
    return _finite(path, X[:, s_idx][:, :, f_idx].astype(np.float64), ids)


def _trial_index(path: Path, frame: pd.DataFrame, schema: dict) -> tuple[pd.DataFrame, list[str], list[str]]:
    """``frame`` indexed by (trial, sensor), the trial order and the sensors present."""
    sensors = list(schema["sensors"])
    frame = frame.copy()
    if "sensor" not in frame.columns:
        if len(sensors) > 1:
            raise DataFileError(path, f"no 'sensor' column; the model needs one row per trial and sensor {sensors}")
        frame["sensor"] = sensors[0]
    if "trial_id" not in frame.columns:
        if len(sensors) > 1:
            raise DataFileError(path, "no 'trial_id' column to group the sensors' rows into trials")
        frame["trial_id"] = [f"{path.stem}_{i}" for i in range(len(frame))]
    frame["trial_id"], frame["sensor"] = frame["trial_id"].astype(str), frame["sensor"].astype(str)
    present = list(pd.unique(frame["sensor"]))
    _check_layout(path, present, [*schema["feature_names"]] if "signal_file" in frame.columns else frame.columns,
                  schema)
    frame = frame[frame["sensor"].isin(sensors)].set_index(["trial_id", "sensor"])
    if frame.index.duplicated().any():
        dup = frame.index[frame.index.duplicated()][0]
        raise DataFileError(path, f"duplicate row for trial {dup[0]!r}, sensor {dup[1]!r}")
    order = list(pd.unique(frame.index.get_level_values(0)))
    if len(frame) != len(order) * len(sensors):
        raise DataFileError(path, f"every trial needs exactly one row per sensor {sensors}")
    return frame, order, sensors


def _csv_rows(path: Path, frame: pd.DataFrame, schema: dict) -> tuple[np.ndarray, list[str]]:
    frame, order, sensors = _trial_index(path, frame, schema)
    names = list(schema["feature_names"])
    try:
        X = frame.loc[pd.MultiIndex.from_product([order, sensors]), names].to_numpy(dtype=np.float64)
    except ValueError:
        raise DataFileError(path, "a feature column holds text that is not a number") from None
    return _finite(path, X.reshape(len(order), len(sensors), len(names)), order)


# ---------------------------------------------------------------------------- signals
def _signal_features(path: Path, schema: dict, arrays: dict | None = None) -> np.ndarray:
    """The schema's per-channel statistics of one signal file, shape (n_features,).

    ``arrays``: the file's arrays when the caller has read the ``.npz`` already (not read twice).
    """
    from tzsl.features import SignalStatistics  # noqa: PLC0415 - only for signal inputs

    signals = schema.get("signals")
    if not signals:
        raise DataFileError(path, "holds no feature table (no 'X' array / feature columns), and the model was not "
                                  "trained on signal files")
    channels, values = read_signal_file(path) if arrays is None else signal_from_arrays(path, arrays)
    want = list(signals["channels"])
    missing = [c for c in want if c not in channels]
    if missing:
        raise DataFileError(path, f"channel(s) {missing} missing; the model needs channels {want}, "
                                  f"the file has {list(channels)}")
    values = values[:, [list(channels).index(c) for c in want]]
    if not np.isfinite(values).all():
        raise DataFileError(
            path, f"NaN or infinite signal value in time step {int(np.argwhere(~np.isfinite(values))[0, 0])}")
    extractor = SignalStatistics(statistics=tuple(signals["statistics"]),
                                 baseline_rows=int(signals.get("baseline_rows", 0)) or None, channels=want)
    try:
        return extractor.fit([values]).transform([values])[0]
    except ValueError as exc:
        raise DataFileError(path, f"cannot summarise the signal: {str(exc).splitlines()[0]}") from None


def _one_signal(path: Path, schema: dict, arrays: dict | None = None) -> tuple[np.ndarray, list[str]]:
    sensors = list(schema["sensors"])
    if len(sensors) > 1 and schema.get("signals"):
        raise DataFileError(path, f"one signal file is one sensor's recording; the model needs sensors {sensors}: "
                                  "give a CSV with trial_id, sensor and signal_file columns")
    return _finite(path, _signal_features(path, schema, arrays)[None, None, :], [path.stem])


def _signal_manifest(path: Path, frame: pd.DataFrame, schema: dict) -> tuple[np.ndarray, list[str]]:
    frame, order, sensors = _trial_index(path, frame, schema)
    X = np.empty((len(order), len(sensors), len(schema["feature_names"])))
    for i, trial in enumerate(order):
        for j, sensor in enumerate(sensors):
            X[i, j] = _signal_features(path.parent / str(frame.loc[(trial, sensor), "signal_file"]), schema)
    return _finite(path, X, order)


# ---------------------------------------------------------------------------- hand grasps, frames
def _hand_grasps(schema: dict, inputs: Sequence[str | Path]) -> Grasps:
    from tzsl.datasets import grasp_from_arrays  # noqa: PLC0415
    from tzsl.features import grasp_features  # noqa: PLC0415

    grasps = []
    for item in inputs:
        path = Path(item)
        if path.is_dir():
            grasps += read_grasps(path)
            continue
        if path.suffix != ".npz":
            raise DataFileError(path, "a hand-model input must be a grasp .npz file or a grasp folder")
        if not path.is_file():
            raise DataFileError(path, "grasp file not found")
        grasps.append(grasp_from_arrays(read_npz(path), path.stem, "", str(path)))
    if not grasps:
        raise DataFileError(None, "no grasps given")
    feats = grasp_features(grasps, **schema["feature_params"])
    touched = np.asarray(feats.contact.any(axis=1))  # an array: numpy's stub also allows a scalar
    notes = [f"skipped grasp {gid} ({g.source}): no BioTac touched the object"
             for gid, g, t in zip(feats.grasp_ids, grasps, touched, strict=True) if not t]
    if not touched.any():
        raise DataFileError(None, "no grasp with a touching BioTac: nothing to classify")
    kept = feats.subset(touched)
    sources = [g.source for g, t in zip(grasps, touched, strict=True) if t]
    info = [f"{int(b)} BioTac(s) touching" for b in kept.n_contacts]
    return Grasps(kept.to_array(), list(kept.grasp_ids), sources, info, notes)


def _frames(inputs: Sequence[str | Path]) -> Grasps:
    frames = []
    for item in inputs:
        path = Path(item)
        if not path.is_file():
            raise DataFileError(path, "input file not found")
        if path.suffix == ".npz":
            arrays = read_npz(path)
            if "frames" not in arrays:
                raise DataFileError(path, f"no 'frames' array (found {list(arrays)})")
            frames.append(np.asarray(arrays["frames"]))
            continue
        from tzsl.features import KeyFrameSelector  # noqa: PLC0415

        frames.append(KeyFrameSelector().transform([str(path)])[0])
    shapes = {f.shape for f in frames}
    if len(shapes) != 1:
        raise DataFileError(None, f"inputs have different frame shapes {sorted(shapes)}")
    paths = [Path(p) for p in inputs]
    return Grasps(np.stack(frames), [p.stem for p in paths], [str(p) for p in paths],
                  [f"{f.shape[0]} key frames" for f in frames])
