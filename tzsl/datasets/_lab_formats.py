"""Readers for how labs record tactile data, into the plain-file format (``tzsl convert --from``).

* ``ros-bag``: ROS 1 / ROS 2 bags, read with the ``rosbags`` library (no ROS install):
  :mod:`tzsl.datasets._lab_bags`;
* ``hdf5``: HDF5 files in the lab's own layout: :mod:`tzsl.datasets._lab_hdf5`;
* ``series``: a folder of per-trial ``.csv`` / ``.npy`` time series and a label table:
  :mod:`tzsl.datasets._lab_series`.

Each reads what its mapping (:mod:`tzsl.datasets._lab_mapping`) names, inside the mapping's folder
(unless ``allow_outside``), checks every value it takes (:mod:`tzsl.datasets._lab_checks`), gathers
per-trial, per-sensor signals (time x channels) and writes them with
:func:`tzsl.datasets.write_plain_dataset` (atomically; an existing folder needs ``force``).
A bad file or record is one line naming the file and the record (bag message, HDF5 group,
label-table line).
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Callable
from pathlib import Path

import pandas as pd

from tzsl._io import max_npz_bytes
from tzsl.datasets._lab_bags import read_bags
from tzsl.datasets._lab_checks import LabSource, Trials, read_class_table
from tzsl.datasets._lab_hdf5 import read_hdf5
from tzsl.datasets._lab_mapping import BagMapping, Hdf5Mapping, LabMapping, SeriesMapping, load_lab_mapping
from tzsl.datasets._lab_series import UNNAMED_SENSOR, read_series
from tzsl.datasets._plain_write import write_plain_dataset
from tzsl.datasets._tables import DEFAULT_SENSOR
from tzsl.exceptions import ConfigError

__all__ = ["LAB_FORMATS", "LAB_READERS", "convert_lab_dataset"]

#: Every lab format ``tzsl convert --from`` reads: its mapping file's model and its reader. A new format
#: is a mapping model (:mod:`tzsl.datasets._lab_mapping`), a reader module, and one line in this table.
LAB_READERS: dict[str, tuple[type[LabMapping], Callable[[LabSource], tuple[Trials, pd.DataFrame]]]] = {
    "ros-bag": (BagMapping, read_bags),
    "hdf5": (Hdf5Mapping, read_hdf5),
    "series": (SeriesMapping, read_series),
}
#: ``tzsl convert --from`` kinds read from a lab's own recordings.
LAB_FORMATS: tuple[str, ...] = tuple(LAB_READERS)


def _check_out(out: Path, root: str) -> None:
    """Refuse an output folder inside the input folder ``root`` (the next run's globs would read it) or holding it."""
    target = os.path.realpath(out)
    if target == root or target.startswith(root.rstrip(os.sep) + os.sep):
        raise ConfigError(f"--out {out}: inside the mapping's folder {root}; the next conversion would read the "
                          "written dataset as recordings: write it outside that folder")
    if root.startswith(target.rstrip(os.sep) + os.sep):
        raise ConfigError(f"--out {out}: holds the mapping's folder {root}; writing it would replace the recordings: "
                          "write it elsewhere")


def convert_lab_dataset(kind: str, mapping_file: str | os.PathLike, out: str | os.PathLike, *,
                        force: bool = False, progress: bool = True, allow_outside: bool = False) -> tuple[Path, dict]:
    """Read a lab's recordings as its mapping says and write them as a plain-file dataset.

    Parameters
    ----------
    kind : {"ros-bag", "hdf5", "series"}
    mapping_file : path-like
        The TOML mapping; the paths it names are relative to its folder.
    out : path-like
        The dataset folder to write; not inside the mapping's folder (nor holding it).
    force : bool, default False
        Replace an existing dataset folder.
    progress : bool, default True
        Show progress bars.
    allow_outside : bool, default False
        Read files outside the mapping's folder (absolute paths, ``..``, links pointing out).

    Returns
    -------
    folder : Path
    summary : dict
        ``classes``, ``attributes``, ``trials``, ``sensors``, ``channels``.

    Raises
    ------
    DataFileError, ConfigError
        One line naming the file and the record (label-table line, bag message, HDF5 group).
    """
    if kind not in LAB_FORMATS:
        raise ConfigError(f"--from {kind}: choose one of {', '.join(LAB_FORMATS)}")
    mapping_file = Path(mapping_file)
    model, reader = LAB_READERS[kind]
    mapping = load_lab_mapping(mapping_file, kind, model)
    source = LabSource(mapping_file, mapping, frozenset(), max_npz_bytes(), allow_outside, progress)
    _check_out(Path(out), source.root)
    classes = read_class_table(source)
    trials, table = reader(dataclasses.replace(source, classes=frozenset(classes.index)))
    sensors = list(dict.fromkeys(s for per in trials.values() for s in per))
    channels = next(iter(trials.values()))[sensors[0]][0]
    order = [str(t) for t in table["trial_id"]]
    signals = [[trials[t][s][1] for s in sensors] for t in order]
    settings = {"name": mapping.name or Path(out).name,
                "classes": {"allow_identical_rows": bool(mapping.allow_identical_rows)}}
    frame = pd.DataFrame({"trial_id": order, "class": table["class"].astype(str).to_numpy()})
    unnamed = sensors == [UNNAMED_SENSOR]  # written without a sensor column: read back as DEFAULT_SENSOR
    folder = write_plain_dataset(out, classes, frame, sensors=None if unnamed else sensors, signals=signals,
                                 channels=channels, settings=settings, force=force)
    summary = {"classes": len(classes), "attributes": classes.shape[1], "trials": len(order),
               "sensors": [DEFAULT_SENSOR] if unnamed else sensors, "channels": list(channels)}
    return folder, summary
