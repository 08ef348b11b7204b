"""``tzsl convert --from hdf5``: HDF5 files in a lab's own layout, read with ``h5py``.

Every group matching the mapping's ``trials`` pattern is one trial, named
``<file stem>_<group path>``; its class is an attribute or a dataset of the group, its sensors
datasets inside it. Nothing is read from another file: external links, external raw storage and
virtual datasets are refused. Each dataset's type, shape and stored size are checked before it
is read. A bad file or record is one line naming the file and the group.
"""

from __future__ import annotations

import fnmatch
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
    has_control,
    lab_error,
    one_line,
    progress_bar,
    to_float,
)
from tzsl.datasets._lab_mapping import Hdf5Mapping, SensorFields
from tzsl.exceptions import DataFileError, error_text

__all__ = ["read_hdf5"]

#: Soft links followed in a row before a path is refused as a loop.
_MAX_SOFT_LINKS = 16


def _matches(group: str, pattern: str) -> bool:
    """fnmatch per path segment: ``*`` does not cross ``/`` (``/trial_*`` is no ``/trial_1/f0``)."""
    parts, wanted = group.strip("/").split("/"), pattern.strip("/").split("/")
    return len(parts) == len(wanted) and all(fnmatch.fnmatchcase(p, w) for p, w in zip(parts, wanted, strict=True))


def _resolve(handle, group, name: str, path: Path, record: str, depth: int = 0):
    """The object at ``name`` (relative to ``group``, or absolute), or None; links to other files refused."""
    import h5py  # noqa: PLC0415

    current = handle if name.startswith("/") else group
    for part in (p for p in name.split("/") if p not in ("", ".")):
        if not isinstance(current, h5py.Group):
            raise lab_error(path, f"{record}: {name!r}: {current.name} is a dataset, not a group")
        link = current.get(part, getlink=True)
        if link is None:
            return None
        if isinstance(link, h5py.ExternalLink):
            raise lab_error(path, f"{record}: {name!r} is an external link to {link.filename}:{link.path}; "
                                  "the converter reads nothing outside the mapped files")
        if isinstance(link, h5py.SoftLink):
            if depth >= _MAX_SOFT_LINKS:
                raise lab_error(path, f"{record}: {name!r}: more than {_MAX_SOFT_LINKS} soft links in a row (a loop?)")
            current = _resolve(handle, current, link.path, path, record, depth + 1)
            if current is None:
                return None
        else:
            current = current[part]
    return current


def _dataset(handle, group, name: str, path: Path, record: str, what: str):
    """The h5py dataset ``name`` of ``group``: present, a dataset, stored inside this file."""
    import h5py  # noqa: PLC0415

    dataset = _resolve(handle, group, name, path, record)
    if dataset is None:
        raise lab_error(path, f"{record}: no dataset {name!r}{what}")
    if not isinstance(dataset, h5py.Dataset):
        raise lab_error(path, f"{record}: {name!r} is a group, not a dataset{what}")
    if dataset.is_virtual or dataset.external:
        raise lab_error(path, f"{record}: dataset {name!r} keeps its data in other files (external storage or a "
                              "virtual dataset); the converter reads nothing outside the mapped files")
    return dataset


def _class_text(value: object, path: Path, record: str) -> str:
    """The class of a trial from its label value (text, or one number)."""
    if isinstance(value, np.ndarray):
        value = value.reshape(-1)[0]
    if isinstance(value, (bytes, np.bytes_)):
        raw = bytes(value)
        try:
            value = raw.decode("utf-8")
        except UnicodeDecodeError:
            raise lab_error(path, f"{record}: the label {raw[:40]!r} is not UTF-8 text") from None
    if isinstance(value, (np.generic, bool, int, float)) and not isinstance(value, (np.str_, np.void)):
        value = np.asarray(value).item()
        if not isinstance(value, (bool, int, float)):
            raise lab_error(path, f"{record}: the label is {type(value).__name__}; expected text or a number")
        value = str(value)
    if not isinstance(value, str):
        raise lab_error(path, f"{record}: the label is {type(value).__name__}; expected text or a number")
    if not value.strip():
        raise lab_error(path, f"{record}: the label (the class) is empty")
    return value


def _label(handle, group, label: str, path: Path, record: str) -> str:
    """The class of the trial ``group``: ``attrs:NAME`` or ``dataset:PATH``, one value of text or a number."""
    where, _, name = label.partition(":")
    if where == "attrs":
        if name not in group.attrs:
            raise lab_error(path, f"{record}: no attribute {name!r} with the class (label = {label!r})")
        shape = group.attrs.get_id(name).shape
        if shape is None or int(np.prod(shape)) != 1:
            raise lab_error(path, f"{record}: attribute {name!r} has shape {shape}; expected one value (the class)")
        value = group.attrs[name]
    else:
        dataset = _dataset(handle, group, name, path, record, " with the class")
        if dataset.shape is None or dataset.size != 1:
            raise lab_error(path, f"{record}: dataset {name!r} has shape {dataset.shape}; expected one value "
                                  "(the class)")
        value = dataset[()]
    return _class_text(value, path, record)


def _values(dataset, name: str, path: Path, record: str, limit: int) -> np.ndarray:
    """A sensor dataset as float64, shape (time,) or (time, k): type, shape and stored size checked before reading."""
    where = f"{record}: dataset {name!r}"
    to_float(np.empty(0, dtype=dataset.dtype), path, where)  # the type, before reading
    if dataset.shape is None or len(dataset.shape) not in (1, 2):
        raise lab_error(path, f"{where} has shape {dataset.shape}; expected (time,) or (time, k)")
    check_size(int(dataset.size), path, where, limit)
    declared = int(dataset.size) * dataset.dtype.itemsize
    if dataset.chunks is not None:  # every chunk the shape needs is stored (filtered or not)
        needed = int(np.prod([-(-n // c) for n, c in zip(dataset.shape, dataset.chunks, strict=True)], dtype=object))
        stored = dataset.id.get_num_chunks()
        if stored < needed:
            raise lab_error(path, f"{where} declares shape {dataset.shape} in {needed:,} chunks but stores {stored:,}: "
                                  "never written in part (reading it would give fill values)")
    elif dataset.id.get_storage_size() < declared:
        raise lab_error(path, f"{where} declares shape {dataset.shape} ({declared:,} bytes) but stores "
                              f"{dataset.id.get_storage_size():,}: truncated, or never written (reading it would give "
                              "fill values)")
    try:
        values = dataset[()]
    except Exception as exc:  # noqa: BLE001 - corrupt data, a missing filter: one line
        raise lab_error(path, f"{where}: cannot read it: {error_text(exc)}") from None
    return to_float(values, path, where)


def _sensor(handle, group, sensor: SensorFields, path: Path, record: str, limit: int) -> tuple[list[str], np.ndarray]:
    columns, names = [], []
    for name in sensor.datasets:
        values = _values(_dataset(handle, group, name, path, record, f" of sensor {sensor.name!r}"), name, path,
                         record, limit)
        names += channel_names(name, None if values.ndim == 1 else values.shape[1])
        columns.append(values[:, None] if values.ndim == 1 else values)
    lengths = [c.shape[0] for c in columns]
    if len(set(lengths)) > 1:
        raise lab_error(path, f"{record}: datasets {sensor.datasets} of sensor {sensor.name!r} have {lengths} "
                              "time steps; expected one length")
    values = np.hstack(columns)
    check_signal(values, names, path, f"{record}, sensor {sensor.name!r}")
    return names, values


def _groups(handle, path: Path, pattern: str) -> list[str]:
    import h5py  # noqa: PLC0415

    groups: list[str] = []
    try:
        handle.visititems(lambda name, obj: groups.append("/" + name) if isinstance(obj, h5py.Group) else None)
    except Exception as exc:  # noqa: BLE001 - a corrupt file found while listing its groups
        raise lab_error(path, f"cannot list its groups: {error_text(exc)}") from None
    matching = [g for g in groups if _matches(g, pattern)]
    if not matching:
        raise lab_error(path, f"no group matches trials = {pattern!r}; narrow the mapping's files or fix the "
                              "pattern")
    return matching


def _file_trials(path: Path, source: LabSource[Hdf5Mapping], ids: TrialIds, channels: ChannelCheck) -> list[tuple]:
    """[(trial id, class, sensor -> (channels, values))] of one HDF5 file, every group checked."""
    import h5py  # noqa: PLC0415

    mapping: Hdf5Mapping = source.mapping
    if path.is_dir():
        raise lab_error(path, "is a folder, not an HDF5 file (it matches the mapping's files)")
    try:
        handle = h5py.File(path, "r")
    except Exception as exc:  # noqa: BLE001 - h5py raises OSError, ValueError... for a bad file
        raise lab_error(path, f"not a readable HDF5 file: {error_text(exc)}") from None
    found = []
    with handle:
        for group_name in _groups(handle, path, mapping.trials):
            record = f"group {one_line(group_name)}"
            if has_control(group_name):
                raise lab_error(path, f"{record}: the group name holds a control character; it would be the trial id")
            try:
                group = handle[group_name]
                trial_id = f"{path.stem}{group_name.replace('/', '_')}"
                ids.add(trial_id, f"trial id {trial_id!r}", path, record)
                label = _label(handle, group, mapping.label, path, record)
                if label not in source.classes:
                    raise lab_error(path, f"{record}: class {label!r} is not in the class table ({mapping.classes})")
                per_sensor = {}
                for sensor in mapping.sensors:
                    names, values = _sensor(handle, group, sensor, path, record, source.limit)
                    channels(names, path, f"{record}, sensor {sensor.name!r}")
                    per_sensor[sensor.name] = (names, values)
            except DataFileError:
                raise
            except Exception as exc:  # noqa: BLE001 - a corrupt object found while reading the group
                raise lab_error(path, f"{record}: cannot read it: {error_text(exc)}") from None
            found.append((trial_id, label, per_sensor))
    return found


def read_hdf5(source: LabSource[Hdf5Mapping]) -> tuple[Trials, pd.DataFrame]:
    """Trials (trial -> sensor -> (channels, values (time, n_channels))) and their classes, file by file."""
    trials: Trials = {}
    rows = []
    ids, channels = TrialIds(), ChannelCheck()
    with progress_bar(source.glob(source.mapping.files, "files"), "HDF5 files", source.progress) as bar:
        for path in bar:
            for trial_id, label, per_sensor in _file_trials(path, source, ids, channels):
                trials[trial_id] = per_sensor
                rows.append({"trial_id": trial_id, "class": label})
    return trials, pd.DataFrame(rows)
