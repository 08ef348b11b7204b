"""The mapping files of ``tzsl convert --from ros-bag|hdf5|series``: where a lab's recordings keep
their trials, sensors, channels and labels.

One small TOML file per dataset, checked by pydantic (unknown keys, wrong types: every problem at
once, on one line, naming the mapping file and each key). Paths in it are relative to the mapping
file's folder, and a reader opens nothing outside that folder (unless ``--allow-outside``) nor
anything the mapping does not name.
"""

from __future__ import annotations

import os
import re
import tomllib
from pathlib import Path
from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator

from tzsl.exceptions import ConfigError, DataFileError

__all__ = ["BagMapping", "Hdf5Mapping", "LabMapping", "SeriesMapping", "SensorFields", "load_lab_mapping"]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


_CONTROL = re.compile(r"[\x00-\x1f\x7f]")
#: A message field: dotted names (no leading underscore), each with optional ``[i]`` items.
_FIELD_PATH = re.compile(r"[A-Za-z]\w*(\[\d+\])*(\.[A-Za-z]\w*(\[\d+\])*)*")
#: A path, glob, field or dataset named in a mapping: non-empty text.
_Text = Annotated[str, Field(min_length=1)]


def _distinct_sensors(sensors: list[SensorFields]) -> list[SensorFields]:
    names = [s.name for s in sensors]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise ValueError(f"sensor name(s) {twice} occur twice; each sensor needs its own name")
    return sensors


class SensorFields(_Strict):
    """One sensor: where its channels are.

    ``fields`` (ROS bags): dotted paths into the message of ``topic``, with ``[i]`` for list
    items (``bt_data[0].pdc_data``); a field holding a sequence gives one channel per item.
    ``datasets`` (HDF5): paths relative to a trial group; a 1-D dataset is one channel, a 2-D
    dataset (time x k) k channels.
    """

    name: str = Field(min_length=1)
    topic: str | None = None
    fields: list[_Text] = []
    datasets: list[_Text] = []

    @field_validator("fields")
    @classmethod
    def _field_paths(cls, v):
        bad = [f for f in v if not _FIELD_PATH.fullmatch(f)]
        if bad:
            raise ValueError(f"field(s) {bad} are not dotted paths of field names with [i] items, "
                             "like 'bt_data[0].pdc_data'")
        return v

    @field_validator("name")
    @classmethod
    def _plain(cls, v):
        if _CONTROL.search(v) or not v.strip():
            raise ValueError("a sensor name is text without control characters")
        return v


class _Common(_Strict):
    classes: _Text = Field(description="class-attribute table: class,<attribute>,... (one 0/1 row per class)")
    name: str | None = Field(None, description="dataset name (default: the output folder's name)")
    allow_identical_rows: bool = False


class BagMapping(_Common):
    """ROS 1 (``.bag``) or ROS 2 (folder with ``metadata.yaml``) bags read with ``rosbags``.

    ``labels``: CSV with ``bag`` (a path as listed in ``bags``, relative to the mapping), ``trial_id``
    and ``class``, and optionally ``start`` / ``end`` (seconds from the bag's first message) to cut
    several trials (or exploratory procedures, one row each) out of one bag; without them a bag is
    one trial. ``messages``: message type -> ``.msg`` file, for types the bags do not define.
    """

    kind: Literal["ros-bag"]
    bags: list[_Text] = Field(min_length=1)
    labels: _Text
    sensors: list[SensorFields] = Field(min_length=1)
    messages: dict[str, _Text] = {}
    ros_distro: Literal["ros1", "ros2"] = "ros2"

    @field_validator("sensors")
    @classmethod
    def _topics(cls, v):
        missing = [s.name for s in v if not s.topic or not s.fields]
        if missing:
            raise ValueError(f"sensor(s) {missing} need a topic and fields")
        return _distinct_sensors(v)


class Hdf5Mapping(_Common):
    """HDF5 files in a lab's own layout: every group matching ``trials`` is one trial."""

    kind: Literal["hdf5"]
    files: list[_Text] = Field(min_length=1)
    trials: _Text = Field(description="group pattern, fnmatch per path segment ('*' does not cross '/'), "
                                    "e.g. '/trial_*' or '/session_*/trial_*'")
    label: _Text = Field(description="'attrs:NAME' (an attribute of the trial group) or 'dataset:PATH' "
                                   "(a string dataset inside it)")
    sensors: list[SensorFields] = Field(min_length=1)

    @field_validator("label")
    @classmethod
    def _label(cls, v):
        if not v.startswith(("attrs:", "dataset:")) or v.partition(":")[2] == "":
            raise ValueError("use 'attrs:NAME' or 'dataset:PATH'")
        if v.startswith("dataset:/"):
            raise ValueError("the label dataset is a path inside the trial group, not from the file's root")
        return v

    @field_validator("sensors")
    @classmethod
    def _datasets(cls, v):
        missing = [s.name for s in v if not s.datasets]
        if missing:
            raise ValueError(f"sensor(s) {missing} need datasets")
        rooted = [d for s in v for d in s.datasets if d.startswith("/")]
        if rooted:
            raise ValueError(f"dataset(s) {rooted} start at the file's root; every trial would read the same data: "
                             "name them relative to the trial group")
        return _distinct_sensors(v)


class SeriesMapping(_Common):
    """A folder of per-trial time series: ``.csv`` (a header of channel names) or ``.npy`` (time x k).

    ``labels``: CSV with ``file`` (relative to the mapping), ``trial_id``, ``class`` and, for
    several sensors, ``sensor``. ``channels``: names of ``.npy`` columns (default ``ch0``, ...).
    """

    kind: Literal["series"]
    labels: _Text
    channels: list[_Text] | None = None

    @field_validator("channels")
    @classmethod
    def _channels(cls, v):
        if v is not None and (len(set(v)) != len(v) or any(_CONTROL.search(c) for c in v)):
            raise ValueError("channel names must be distinct text without control characters")
        return v


LabMapping = BagMapping | Hdf5Mapping | SeriesMapping


def load_lab_mapping(path: str | os.PathLike, kind: str, model: type[LabMapping]) -> LabMapping:
    """The checked mapping of ``kind`` in ``path``, validated by ``model``.

    Raises
    ------
    DataFileError, ConfigError
        One line naming the mapping file and every key in error (``key: problem; key: problem``).
    """
    path = Path(path)
    try:
        raw = tomllib.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise DataFileError(path, f"cannot read the mapping: {exc.strerror or exc}") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise DataFileError(path, f"not a TOML file: {str(exc).splitlines()[0]}") from None
    except RecursionError:
        raise DataFileError(path, "not a TOML file for tzsl: values nested too deeply") from None
    raw.setdefault("kind", kind)
    if raw["kind"] != kind:
        raise ConfigError(f"{path}: kind: the mapping is for {raw['kind']!r}, not --from {kind}")
    try:
        return model.model_validate(raw)
    except ValidationError as exc:
        problems = [f"{'.'.join(map(str, e['loc'])) or '(top)'}: {e['msg']}" for e in exc.errors()]
        text = _CONTROL.sub(lambda m: repr(m.group())[1:-1], "; ".join(problems))
        raise ConfigError(f"{path}: {text}") from None
