"""Readers for how labs record tactile data, into the plain-file format (``tzsl convert --from``).

* ``ros-bag``: ROS 1 / ROS 2 bags, read with the ``rosbags`` library (no ROS install);
* ``hdf5``: HDF5 files in the lab's own layout;
* ``series``: a folder of per-trial ``.csv`` / ``.npy`` time series and a label table.

Each reads what its mapping (:mod:`tzsl.datasets._lab_mapping`) names and nothing else, gathers
per-trial, per-sensor signals (time x channels) and writes them with
:func:`tzsl.datasets.write_plain_dataset` (atomically; an existing folder needs ``force``).
A bad file or record is one line naming the file and the record (message, group, row).
"""

from __future__ import annotations

import fnmatch
import os
import re
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd
from tqdm.auto import tqdm

from tzsl.datasets._lab_mapping import BagMapping, Hdf5Mapping, SeriesMapping, load_lab_mapping, mapped_path
from tzsl.datasets._plain_write import write_plain_dataset
from tzsl.datasets._signal_files import read_signal_file
from tzsl.datasets._feature_table import read_csv_table
from tzsl.exceptions import ConfigError, DataFileError

__all__ = ["LAB_FORMATS", "LAB_READERS", "convert_lab_dataset"]

#: ``tzsl convert --from`` kinds read from a lab's own recordings.

Trials = dict[str, dict[str, tuple[list[str], np.ndarray]]]  # trial -> sensor -> (channels, values)


def _classes(mapping_file: Path, mapping) -> pd.DataFrame:
    path = mapped_path(mapping_file, mapping.classes)
    table = read_csv_table(path)
    table = table.set_index(table.columns[0])
    table.index = table.index.astype(str)
    values = table.to_numpy()
    bad = ~np.isin(values, (0, 1))
    if bad.any():
        row, col = (int(v) for v in np.argwhere(bad)[0])
        raise DataFileError(path, f"class {table.index[row]!r}, attribute {table.columns[col]!r}: "
                                  f"{values[row, col]!r} is not 0 or 1", line=row + 2)
    return table.astype(int).rename_axis("class")


def _labels(mapping_file: Path, relative: str, required: tuple[str, ...]) -> tuple[Path, pd.DataFrame]:
    path = mapped_path(mapping_file, relative)
    table = read_csv_table(path)
    missing = [c for c in required if c not in table.columns]
    if missing:
        raise DataFileError(path, f"missing column(s) {missing}; has {list(table.columns)}", line=1)
    return path, table


def _channel_names(path: str, values: np.ndarray) -> list[str]:
    """``pdc_data`` for a scalar field, ``electrode_data_0`` ... for a sequence."""
    base = re.sub(r"\[\d+\]", "", path).rsplit(".", 1)[-1].rsplit("/", 1)[-1]
    return [base] if values.size == 1 else [f"{base}_{i}" for i in range(values.size)]


# --------------------------------------------------------------------------- ROS bags


def _field(message, path: str):
    """``bt_data[0].pdc_data`` of a deserialised message."""
    value = message
    for part in path.split("."):
        name, *indices = re.split(r"\[(\d+)\]", part)
        value = getattr(value, name)
        for index in (i for i in indices if i != ""):
            value = value[int(index)]
    return value


def _typestore(mapping_file: Path, mapping: BagMapping):
    try:
        from rosbags.typesys import Stores, get_types_from_msg, get_typestore  # noqa: PLC0415
    except ImportError:
        raise ConfigError("--from ros-bag needs the rosbags library: pip install 'tzsl[ros]'") from None

    store = get_typestore(Stores.ROS1_NOETIC if mapping.ros_distro == "ros1" else Stores.ROS2_HUMBLE)
    types = {}
    for msgtype, relative in mapping.messages.items():
        path = mapped_path(mapping_file, relative)
        try:
            types.update(get_types_from_msg(path.read_text(encoding="utf-8"), msgtype))
        except OSError as exc:
            raise DataFileError(path, f"cannot read the message definition: {exc.strerror or exc}") from None
        except Exception as exc:  # noqa: BLE001 - rosbags' parser errors: one line naming the file
            raise DataFileError(path, f"not a .msg definition of {msgtype}: {str(exc).splitlines()[0]}") from None
    store.register(types)
    return store


def _bag_messages(bag: Path, mapping: BagMapping, store) -> tuple[int, dict[str, tuple[np.ndarray, np.ndarray]]]:
    """(first timestamp ns, sensor -> (timestamps ns (n,), values (n, k))) of one bag."""
    from rosbags.highlevel import AnyReader  # noqa: PLC0415

    topics = {s.topic for s in mapping.sensors}
    rows: dict[str, tuple[list[int], list[np.ndarray]]] = {s.name: ([], []) for s in mapping.sensors}
    first = None
    try:
        reader = AnyReader([bag], default_typestore=store)
        reader.open()
    except Exception as exc:  # noqa: BLE001 - rosbags' own errors: one line naming the bag
        raise DataFileError(bag, f"not a readable ROS bag: {str(exc).splitlines()[0]}") from None
    try:
        found = {c.topic for c in reader.connections}
        absent = sorted(topics - found)
        if absent:
            raise DataFileError(bag, f"topic(s) {absent} not in the bag (it has {sorted(found)})")
        connections = [c for c in reader.connections if c.topic in topics]
        for index, (connection, timestamp, raw) in enumerate(reader.messages(connections=connections)):
            first = timestamp if first is None else min(first, timestamp)
            try:
                message = reader.deserialize(raw, connection.msgtype)
            except Exception as exc:  # noqa: BLE001 - a corrupt record
                raise DataFileError(bag, f"message {index} on {connection.topic}: cannot deserialise "
                                         f"{connection.msgtype}: {str(exc).splitlines()[0]}") from None
            for sensor in (s for s in mapping.sensors if s.topic == connection.topic):
                try:
                    values = [np.asarray(_field(message, f), dtype=np.float64).ravel() for f in sensor.fields]
                except (AttributeError, IndexError, TypeError, ValueError) as exc:
                    raise DataFileError(bag, f"message {index} on {connection.topic}: field of sensor "
                                             f"{sensor.name!r}: {exc}") from None
                rows[sensor.name][0].append(timestamp)
                rows[sensor.name][1].append(np.concatenate(values))
    finally:
        reader.close()
    if first is None:
        raise DataFileError(bag, f"no message on {sorted(topics)}")
    out = {}
    for name, (stamps, values) in rows.items():
        widths = {v.size for v in values}
        if len(widths) > 1:
            raise DataFileError(bag, f"sensor {name!r}: messages give {sorted(widths)} values; expected one width")
        out[name] = (np.asarray(stamps, dtype=np.int64), np.stack(values) if values else np.empty((0, 0)))
    return first, out


def _read_bags(mapping_file: Path, mapping: BagMapping, progress: bool) -> tuple[Trials, pd.DataFrame]:
    store = _typestore(mapping_file, mapping)
    labels_path, labels = _labels(mapping_file, mapping.labels, ("bag", "trial_id", "class"))
    bags = sorted({p for pattern in mapping.bags for p in mapping_file.parent.glob(pattern)})
    if not bags:
        raise ConfigError(f"{mapping_file}: bags: no file matches {mapping.bags}")
    by_name = {str(p.relative_to(mapping_file.parent)): p for p in bags}
    unknown = [(i, b) for i, b in enumerate(labels["bag"].astype(str)) if b not in by_name]
    if unknown:
        i, b = unknown[0]
        raise DataFileError(labels_path, f"bag {b!r} is not among the mapping's bags", line=i + 2)
    trials: Trials = {}
    for bag_name, rows in tqdm(labels.groupby("bag", sort=False), desc="bags", disable=not progress):
        first, messages = _bag_messages(by_name[str(bag_name)], mapping, store)
        for i, row in rows.iterrows():
            start = float(row["start"]) if "start" in rows.columns and pd.notna(row["start"]) else -np.inf
            end = float(row["end"]) if "end" in rows.columns and pd.notna(row["end"]) else np.inf
            per_sensor = {}
            for sensor in mapping.sensors:
                stamps, values = messages[sensor.name]
                seconds = (stamps - first) / 1e9
                keep = (seconds >= start) & (seconds < end)
                if not keep.any():
                    raise DataFileError(labels_path, f"trial {row['trial_id']!r}: no {sensor.topic} message "
                                                     f"between {start:g} and {end:g} s", line=int(i) + 2)
                per_sensor[sensor.name] = (_field_channels(sensor, values.shape[1]), values[keep])
            trials[str(row["trial_id"])] = per_sensor
    return trials, labels


def _field_channels(sensor, total: int) -> list[str]:
    """Channel names of a bag sensor: each field's name, indexed per item of a sequence field.

    ``total`` values per message from ``len(sensor.fields)`` fields of one kind (all scalars, or
    all sequences of one length).
    """
    n = len(sensor.fields)
    if total % n:
        raise ConfigError(f"sensor {sensor.name!r}: {total} values from {n} fields; list fields of one length")
    return [name for path in sensor.fields for name in _channel_names(path, np.empty(total // n))]


# --------------------------------------------------------------------------- HDF5


def _read_hdf5(mapping_file: Path, mapping: Hdf5Mapping, progress: bool) -> tuple[Trials, pd.DataFrame]:
    import h5py  # noqa: PLC0415

    files = sorted({p for pattern in mapping.files for p in mapping_file.parent.glob(pattern)})
    if not files:
        raise ConfigError(f"{mapping_file}: files: no file matches {mapping.files}")
    trials: Trials = {}
    rows = []
    for path in tqdm(files, desc="HDF5 files", disable=not progress):
        try:
            handle = h5py.File(path, "r")
        except OSError as exc:
            raise DataFileError(path, f"not a readable HDF5 file: {str(exc).splitlines()[0]}") from None
        with handle:
            groups: list[str] = []
            handle.visititems(lambda name, obj: groups.append("/" + name) if isinstance(obj, h5py.Group) else None)
            for group_name in (g for g in groups if _matches(g, mapping.trials)):
                group = handle[group_name]
                trial_id = f"{path.stem}{group_name.replace('/', '_')}"
                rows.append({"trial_id": trial_id, "class": _hdf5_label(path, group, mapping.label)})
                trials[trial_id] = {s.name: _hdf5_sensor(path, group, s.datasets) for s in mapping.sensors}
    if not rows:
        raise ConfigError(f"{mapping_file}: trials: no group matches {mapping.trials!r} in {len(files)} file(s)")
    return trials, pd.DataFrame(rows)


def _matches(group: str, pattern: str) -> bool:
    """fnmatch per path segment: ``*`` does not cross ``/`` (``/trial_*`` is no ``/trial_1/f0``)."""
    parts, wanted = group.strip("/").split("/"), pattern.strip("/").split("/")
    return len(parts) == len(wanted) and all(fnmatch.fnmatchcase(p, w) for p, w in zip(parts, wanted, strict=True))


def _hdf5_label(path: Path, group, label: str) -> str:
    where, _, name = label.partition(":")
    try:
        value = group.attrs[name] if where == "attrs" else group[name][()]
    except KeyError:
        raise DataFileError(path, f"group {group.name}: no {'attribute' if where == 'attrs' else 'dataset'} "
                                  f"{name!r} with the class") from None
    value = value.decode() if isinstance(value, bytes) else value
    return str(value.item() if isinstance(value, np.ndarray) and value.size == 1 else value)


def _hdf5_sensor(path: Path, group, datasets: list[str]) -> tuple[list[str], np.ndarray]:
    columns, names = [], []
    for name in datasets:
        if name not in group:
            raise DataFileError(path, f"group {group.name}: no dataset {name!r}")
        values = np.asarray(group[name][()], dtype=np.float64)
        values = values[:, None] if values.ndim == 1 else values
        if values.ndim != 2:
            raise DataFileError(path, f"group {group.name}: dataset {name!r} has shape {values.shape}; expected "
                                      "(time,) or (time, k)")
        columns.append(values)
        names += _channel_names(name, np.empty(values.shape[1]))
    lengths = {c.shape[0] for c in columns}
    if len(lengths) > 1:
        raise DataFileError(path, f"group {group.name}: datasets {datasets} have {sorted(lengths)} time steps")
    return names, np.hstack(columns)


# --------------------------------------------------------------------------- folders of series


def _read_series(mapping_file: Path, mapping: SeriesMapping, progress: bool) -> tuple[Trials, pd.DataFrame]:
    labels_path, labels = _labels(mapping_file, mapping.labels, ("file", "trial_id", "class"))
    trials: Trials = {}
    for i, row in tqdm(labels.iterrows(), total=len(labels), desc="series", disable=not progress):
        path = mapped_path(mapping_file, str(row["file"]))
        if not path.is_file():
            raise DataFileError(labels_path, f"file {row['file']!r} not found", line=int(i) + 2)
        if path.suffix.lower() == ".npy":
            try:
                values = np.load(path, allow_pickle=False)
            except ValueError as exc:
                raise DataFileError(path, f"not a numeric .npy array: {str(exc).splitlines()[0]}") from None
            values = np.asarray(values, dtype=np.float64)
            values = values[:, None] if values.ndim == 1 else values
            channels = mapping.channels or [f"ch{k}" for k in range(values.shape[1])]
            if values.ndim != 2 or values.shape[1] != len(channels):
                raise DataFileError(path, f"array of shape {values.shape}; expected (time, {len(channels)})")
        else:
            names, values = read_signal_file(path)
            channels = list(names)
        sensor = str(row["sensor"]) if "sensor" in labels.columns else "sensor"
        trials.setdefault(str(row["trial_id"]), {})[sensor] = (list(channels), values)
    table = labels.drop_duplicates("trial_id")[["trial_id", "class"]]
    return trials, table


# --------------------------------------------------------------------------- writing


#: Every lab format ``tzsl convert --from`` reads: its mapping file's model and its reader. A new format
#: is a mapping model (:mod:`tzsl.datasets._lab_mapping`), a reader here, and one line in this table.
LAB_READERS: dict[str, tuple[type, Callable[[Path, object, bool], tuple[Trials, pd.DataFrame]]]] = {
    "ros-bag": (BagMapping, _read_bags),
    "hdf5": (Hdf5Mapping, _read_hdf5),
    "series": (SeriesMapping, _read_series),
}
LAB_FORMATS: tuple[str, ...] = tuple(LAB_READERS)


def convert_lab_dataset(kind: str, mapping_file: str | os.PathLike, out: str | os.PathLike, *,
                        force: bool = False, progress: bool = True) -> tuple[Path, dict]:
    """Read a lab's recordings as its mapping says and write them as a plain-file dataset.

    Returns the folder and a summary (``classes``, ``attributes``, ``trials``, ``sensors``,
    ``channels``).
    """
    if kind not in LAB_FORMATS:
        raise ConfigError(f"--from {kind}: choose one of {', '.join(LAB_FORMATS)}")
    mapping_file = Path(mapping_file)
    model, reader = LAB_READERS[kind]
    mapping = load_lab_mapping(mapping_file, kind, model)
    classes = _classes(mapping_file, mapping)
    trials, table = reader(mapping_file, mapping, progress)
    unknown = sorted(set(table["class"].astype(str)) - set(classes.index))
    if unknown:
        raise DataFileError(mapped_path(mapping_file, mapping.classes), f"class(es) {unknown[:5]} of the recordings "
                                                                        "are not in the class table")
    sensors = list(dict.fromkeys(s for per in trials.values() for s in per))
    channel_sets = {tuple(c) for per in trials.values() for c, _ in per.values()}
    if len(channel_sets) > 1:
        raise ConfigError(f"{mapping_file}: sensors and trials give different channels {sorted(channel_sets)[:2]}; "
                          "every sensor must record the same channels")
    lacking = [t for t, per in trials.items() if set(per) != set(sensors)]
    if lacking:
        raise ConfigError(f"{mapping_file}: trial {lacking[0]!r} lacks a recording of some of {sensors}")
    order = [str(t) for t in table["trial_id"]]
    signals = [[trials[t][s][1] for s in sensors] for t in order]
    name = mapping.name or Path(out).name
    settings = {"name": name, "classes": {"allow_identical_rows": bool(mapping.allow_identical_rows)}}
    frame = pd.DataFrame({"trial_id": order, "class": table["class"].astype(str).to_numpy()})
    folder = write_plain_dataset(out, classes, frame, sensors=sensors if len(sensors) > 1 else None,
                                 signals=signals, channels=list(next(iter(channel_sets))), settings=settings,
                                 force=force)
    summary = {"classes": len(classes), "attributes": classes.shape[1], "trials": len(order), "sensors": sensors,
               "channels": list(next(iter(channel_sets)))}
    return folder, summary
