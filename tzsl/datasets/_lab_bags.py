"""``tzsl convert --from ros-bag``: ROS 1 / ROS 2 bags read with the ``rosbags`` library (no ROS install).

Every bag the mapping's ``bags`` globs match is a trial source named on at least one line of its
label table; each line cuts one trial out of its bag by time (``start``/``end``, seconds from the
bag's first message on the mapped topics). A bad bag or message is one line naming the bag and
the message index (counted over the mapped topics, from 0).
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np
import pandas as pd

from tzsl.datasets._lab_checks import (
    ChannelCheck,
    LabSource,
    TrialIds,
    Trials,
    channel_names,
    check_signal,
    check_size,
    lab_error,
    progress_bar,
    read_label_table,
    seconds,
    to_float,
)
from tzsl.datasets._lab_mapping import BagMapping, SensorFields
from tzsl.exceptions import ConfigError, DataFileError, error_text

__all__ = ["read_bags"]


def _field(message: object, path: str) -> object:
    """The value at ``bt_data[0].pdc_data`` of a deserialised message (message fields only)."""
    value = message
    for part in path.split("."):
        name, *indices = re.split(r"\[(\d+)\]", part)
        if name not in getattr(type(value), "__dataclass_fields__", {}):
            raise AttributeError(f"{type(value).__name__} has no field {name!r}")
        value = getattr(value, name)
        for index in (i for i in indices if i != ""):
            if not isinstance(value, (list, tuple, np.ndarray)):
                raise TypeError(f"{name} is not a list; [{index}] does not apply")
            if int(index) >= len(value):
                raise IndexError(f"{name}[{index}]: the list has {len(value)} item(s)")
            value = value[int(index)]
    return value


def _numbers(value: object) -> tuple[np.ndarray, bool]:
    """(values (k,), is_scalar) of a field's value; TypeError unless numbers."""
    if isinstance(value, (bool, int, float, np.number, np.bool_)):
        return np.asarray([value]), True
    if isinstance(value, (str, bytes)):
        raise TypeError(f"holds text {value[:40]!r}, not a number")
    if isinstance(value, np.ndarray) or (isinstance(value, (list, tuple))
                                         and all(isinstance(v, (bool, int, float, np.number)) for v in value)):
        array = np.asarray(value)
        if array.ndim == 1 and array.dtype.kind in "iufb":
            return array, False
    raise TypeError(f"holds {type(value).__name__}, not a number or a list of numbers; name one of its fields")


def _typestore(source: LabSource[BagMapping]):
    try:
        from rosbags.typesys import Stores, get_types_from_msg, get_typestore  # noqa: PLC0415
    except ImportError:
        raise ConfigError("--from ros-bag needs the rosbags library: pip install 'tzsl[ros]'") from None
    mapping: BagMapping = source.mapping
    store = get_typestore(Stores.ROS1_NOETIC if mapping.ros_distro == "ros1" else Stores.ROS2_HUMBLE)
    types = {}
    for msgtype, relative in mapping.messages.items():
        path = source.path(relative, f"messages.{msgtype}", source.mapping_file)
        try:
            types.update(get_types_from_msg(path.read_text(encoding="utf-8"), msgtype))
        except OSError as exc:
            raise lab_error(path, f"cannot read the message definition: {exc.strerror or exc}") from None
        except Exception as exc:  # noqa: BLE001 - rosbags' parser errors: one line naming the file
            raise lab_error(path, f"not a .msg definition of {msgtype}: {error_text(exc)}") from None
    try:
        store.register(types)
    except Exception as exc:  # noqa: BLE001 - conflicting definitions
        raise lab_error(source.mapping_file, f"messages: cannot register the definitions: {error_text(exc)}") from None
    return store


class _SensorRows:
    """Timestamps and values of one sensor in one bag, each message's fields checked."""

    def __init__(self, sensor: SensorFields) -> None:
        self.sensor = sensor
        self.stamps: list[int] = []
        self.values: list[np.ndarray] = []
        self.shape: list[int | None] | None = None  # per field: None (scalar) or its length

    def add(self, message: object, timestamp: int, bag: Path, record: str) -> int:
        """Append one message's fields; returns the number of values added."""
        arrays, shape = [], []
        for path in self.sensor.fields:
            try:
                array, scalar = _numbers(_field(message, path))
            except (AttributeError, IndexError, TypeError) as exc:
                raise lab_error(bag, f"{record}: field {path!r} of sensor {self.sensor.name!r}: {exc}") from None
            arrays.append(to_float(array, bag, f"{record}: field {path!r} of sensor {self.sensor.name!r}"))
            shape.append(None if scalar else array.size)
        if self.shape is None:
            kinds = {"a scalar" if w is None else f"a sequence of {w}" for w in shape}
            if len(kinds) > 1 or 0 in shape:
                described = ", ".join(f"{f!r} is {'a scalar' if w is None else f'a sequence of {w}'}"
                                      for f, w in zip(self.sensor.fields, shape, strict=True))
                raise lab_error(bag, f"{record}: sensor {self.sensor.name!r}: {described}; list fields of one "
                                     "kind (all scalars, or all non-empty sequences of one length)")
            self.shape = shape
        elif shape != self.shape:
            raise lab_error(bag, f"{record}: sensor {self.sensor.name!r}: fields give {shape} values (None: a "
                                 f"scalar); earlier messages gave {self.shape}")
        values = np.concatenate(arrays)
        check_signal(values[None, :], self.channels(), bag, f"{record}: sensor {self.sensor.name!r}", name_row=False)
        self.stamps.append(timestamp)
        self.values.append(values)
        return values.size

    def channels(self) -> list[str]:
        """Each field's name, indexed per item of a sequence field."""
        shape = self.shape or [None] * len(self.sensor.fields)
        return [name for path, w in zip(self.sensor.fields, shape, strict=True) for name in channel_names(path, w)]


def _bag_messages(bag: Path, source: LabSource[BagMapping], store) -> tuple[int, dict[str, _SensorRows]]:
    """(first timestamp ns, sensor name -> its checked messages) of one bag."""
    from rosbags.highlevel import AnyReader  # noqa: PLC0415

    mapping: BagMapping = source.mapping
    topics = {s.topic for s in mapping.sensors if s.topic is not None}  # BagMapping requires every sensor's topic
    rows = {s.name: _SensorRows(s) for s in mapping.sensors}
    first, index, total = None, -1, 0
    try:
        reader = AnyReader([bag], default_typestore=store)
        reader.open()
    except Exception as exc:  # noqa: BLE001 - rosbags' own errors: one line naming the bag
        raise lab_error(bag, f"not a readable ROS bag: {error_text(exc)}") from None
    try:
        found = {c.topic for c in reader.connections}
        absent = sorted(topics - found)
        if absent:
            raise lab_error(bag, f"topic(s) {absent} not in the bag (it has {sorted(found)})")
        connections = [c for c in reader.connections if c.topic in topics]
        for index, (connection, timestamp, raw) in enumerate(reader.messages(connections=connections)):
            record = f"message {index} on {connection.topic}"
            first = timestamp if first is None else min(first, timestamp)
            try:
                message = reader.deserialize(raw, connection.msgtype)
            except Exception as exc:  # noqa: BLE001 - a corrupt record
                raise lab_error(bag, f"{record}: cannot deserialise {connection.msgtype}: {error_text(exc)}") from None
            for sensor in (s for s in mapping.sensors if s.topic == connection.topic):
                total += rows[sensor.name].add(message, timestamp, bag, record)
                check_size(total, bag, f"{record}: the mapped messages so far", source.limit)
    except DataFileError:
        raise
    except Exception as exc:  # noqa: BLE001 - a truncated or corrupt bag, found while reading
        raise lab_error(bag, f"message {index + 1}: cannot read the bag: {error_text(exc)}") from None
    finally:
        try:
            reader.close()
        except Exception:  # noqa: BLE001 - closing a broken bag; the read error is reported
            pass
    if first is None:
        raise lab_error(bag, f"no message on {sorted(topics)}")
    empty = [name for name, r in rows.items() if not r.stamps]
    if empty:
        raise lab_error(bag, f"no message for sensor(s) {empty}")
    return first, rows


def _cut(bag: Path, rows: list, read: tuple[int, dict[str, _SensorRows]], source: LabSource[BagMapping],
         labels_path: Path, channels: ChannelCheck) -> Trials:
    """The trials of one bag: each label row's time window (start, end) of every sensor's messages."""
    first, messages = read
    for sensor_name, sensor_rows in messages.items():
        channels(sensor_rows.channels(), bag, f"sensor {sensor_name!r}")
    stacked = {name: ((np.asarray(r.stamps, dtype=np.int64) - first) / 1e9, np.stack(r.values), r.channels())
               for name, r in messages.items()}
    trials: Trials = {}
    for row, (start, end) in rows:
        per_sensor = {}
        for sensor in source.mapping.sensors:
            elapsed, values, names = stacked[sensor.name]
            keep = (elapsed >= start) & (elapsed < end)
            if not keep.any():
                raise lab_error(labels_path, f"trial {row.cells['trial_id']!r}: no {sensor.topic} message of {bag} "
                                             f"between {start:g} and {end:g} s (it has {elapsed.min():g} to "
                                             f"{elapsed.max():g} s)", row.line)
            per_sensor[sensor.name] = (names, values[keep])
        trials[row.cells["trial_id"]] = per_sensor
    return trials


def read_bags(source: LabSource[BagMapping]) -> tuple[Trials, pd.DataFrame]:
    """Trials (trial -> sensor -> (channels, values (n_messages, n_channels))) and their labels, in label order."""
    mapping: BagMapping = source.mapping
    store = _typestore(source)
    labels_path, labels = read_label_table(source, "labels", ("bag", "trial_id", "class"), ("start", "end"))
    bags = source.glob(mapping.bags, "bags")
    by_real = {os.path.realpath(b): b for b in bags}
    for bag in bags:
        if bag.is_dir():
            source.files_inside(bag)
    per_bag: dict[Path, list] = {}
    ids = TrialIds()
    for row in labels:
        listed = by_real.get(os.path.realpath(source.path(row.cells["bag"], "bag", labels_path, row.line)))
        if listed is None:
            raise lab_error(labels_path, f"bag {row.cells['bag']!r} is not among the files the mapping's bags "
                                         f"{mapping.bags} match", row.line)
        ids.add(row.cells["trial_id"], f"trial {row.cells['trial_id']!r}", labels_path, "", row.line)
        per_bag.setdefault(listed, []).append((row, seconds(row, labels_path)))
    unused = [b for b in bags if b not in per_bag]
    if unused:
        raise lab_error(source.mapping_file, f"bags: {unused[0]} matches {mapping.bags} but no line of "
                                             f"{labels_path} names it; name it there or narrow the pattern")
    trials: Trials = {}
    channels = ChannelCheck()
    with progress_bar(list(per_bag), "bags", source.progress) as bar:
        for bag in bar:
            trials.update(_cut(bag, per_bag[bag], _bag_messages(bag, source, store), source, labels_path, channels))
    table = pd.DataFrame([{"trial_id": r.cells["trial_id"], "class": r.cells["class"]} for r in labels])
    return trials, table
