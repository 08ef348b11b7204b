"""Hostile inputs to ``tzsl convert --from`` (issue 31, item 3): every broken file or record ends in
exit 3 with ONE stderr line naming the source file and the record (bag + message index, HDF5 file +
group, labels.csv line), no traceback and no output folder; nothing outside the mapping's folder
is read unless ``--allow-outside``.

Every recording is SIMULATED (tests/datasets/lab_recordings.py), then broken here.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from tests.datasets.lab_recordings import bag_lab, hdf5_lab, reading_lab, series_lab
from tzsl.cli import EXIT_TZSL_ERROR, cli


def _labels(lab: Path) -> pd.DataFrame:
    return pd.read_csv(lab / "labels.csv", dtype=str, keep_default_na=False)


def _set(row: int, column: str, value: str) -> Callable[[Path], None]:
    """A breaker: labels.csv row ``row`` (0-based; file line row + 2), ``column`` = ``value``."""
    def breaks(lab: Path) -> None:
        table = _labels(lab)
        table.loc[row, column] = value
        table.to_csv(lab / "labels.csv", index=False)
    return breaks


def _replace(old: str, new: str, file: str = "mapping.toml") -> Callable[[Path], None]:
    def breaks(lab: Path) -> None:
        text = (lab / file).read_text()
        assert old in text, old
        (lab / file).write_text(text.replace(old, new, 1))
    return breaks


def _outside(lab: Path, name: str, source: str) -> Path:
    """A copy of the lab's ``source`` file outside the lab folder (a sibling folder)."""
    target = lab.parent / "elsewhere" / name
    target.parent.mkdir(exist_ok=True)
    target.write_bytes((lab / source).read_bytes())
    return target


def _link_outside(relative: str) -> Callable[[Path], None]:
    def breaks(lab: Path) -> None:
        target = _outside(lab, Path(relative).name, relative)
        (lab / relative).unlink()
        os.symlink(target, lab / relative)
    return breaks


def _truncate(relative: str, keep: float) -> Callable[[Path], None]:
    def breaks(lab: Path) -> None:
        data = (lab / relative).read_bytes()
        (lab / relative).write_bytes(data[: int(len(data) * keep)])
    return breaks


def _h5(edit: Callable[[h5py.File], None], name: str = "session.h5") -> Callable[[Path], None]:
    def breaks(lab: Path) -> None:
        with h5py.File(lab / name, "a") as f:
            edit(f)
    return breaks


def _h5_replace(path: str, **create) -> Callable[[Path], None]:
    def edit(f: h5py.File) -> None:
        del f[path]
        f.create_dataset(path, **create)
    return _h5(edit)


def _npy_header(shape: tuple, descr: str = "<f8", data: bytes = b"") -> Callable[[Path], None]:
    """t1.npy replaced by a header declaring ``shape`` of ``descr``, followed by ``data``."""
    def breaks(lab: Path) -> None:
        with open(lab / "series" / "t1.npy", "wb") as fh:
            np.lib.format.write_array_header_1_0(fh, {"descr": descr, "fortran_order": False, "shape": shape})
            fh.write(data)
    return breaks


def _save(relative: str, values, **kwargs) -> Callable[[Path], None]:
    def breaks(lab: Path) -> None:
        if relative.endswith(".npy"):
            np.save(lab / relative, values, **kwargs)
        else:
            (lab / relative).write_text(values)
    return breaks


def _nan_reading(lab: Path) -> None:
    for p in (lab / "bags").iterdir():
        p.unlink()
    reading_lab(lab, [[(1.0, [0, 0, 0]), (2.0, [0, 0, 0]), (float("nan"), [0, 0, 0])]])


def _inf_taxel(lab: Path) -> None:
    for p in (lab / "bags").iterdir():
        p.unlink()
    reading_lab(lab, [[(1.0, [0, 0, 0]), (2.0, [0, float("inf"), 0])]])
    text = (lab / "mapping.toml").read_text().replace('fields = ["pressure"]', 'fields = ["taxels"]')
    (lab / "mapping.toml").write_text(text)


def _sensors(lab: Path) -> None:
    table = _labels(lab)
    table["sensor"] = "left"
    extra = table.iloc[[0]].assign(sensor="right", **{"class": "sponge"})
    pd.concat([table, extra]).to_csv(lab / "labels.csv", index=False)


def _lacking_sensor(lab: Path) -> None:
    table = _labels(lab)
    table["sensor"] = "left"
    pd.concat([table, table.iloc[[0]].assign(sensor="right")]).to_csv(lab / "labels.csv", index=False)


def _duplicate_ids(lab: Path) -> None:
    (lab / "sub").mkdir()
    (lab / "sub" / "session.h5").write_bytes((lab / "session.h5").read_bytes())
    _replace('files = ["*.h5"]', 'files = ["**/*.h5"]')(lab)


def _no_groups(lab: Path) -> None:
    with h5py.File(lab / "other.h5", "w") as f:
        f.create_group("calibration")


def _unlabelled_bag(lab: Path) -> None:
    table = _labels(lab)
    table[~table["bag"].str.contains("felt")].to_csv(lab / "labels.csv", index=False)


def _dup_row(lab: Path) -> None:
    table = _labels(lab)
    pd.concat([table, table.iloc[[1]]]).to_csv(lab / "labels.csv", index=False)


def _external_link(f: h5py.File) -> None:
    del f["trial_001/f0/pressure"]
    f["trial_001/f0/pressure"] = h5py.ExternalLink("/etc/outside.h5", "/pressure")


def _external_storage(lab: Path) -> None:
    raw = lab.parent / "elsewhere.bin"
    np.arange(20.0).tofile(raw)
    with h5py.File(lab / "session.h5", "a") as f:
        del f["trial_001/f0/pressure"]
        f.create_dataset("trial_001/f0/pressure", shape=(20,), dtype="<f8", external=[(str(raw), 0, 160)])


def _soft_loop(f: h5py.File) -> None:
    del f["trial_001/f0/pressure"]
    f["trial_001/f0/pressure"] = h5py.SoftLink("/trial_001/f0/loop")
    f["trial_001/f0/loop"] = h5py.SoftLink("/trial_001/f0/pressure")


@dataclass(frozen=True)
class Case:
    """A hostile case: a valid lab of ``kind`` broken by ``breaks``; the error line must hold every ``names``."""

    kind: str
    breaks: Callable[[Path], object]
    names: tuple[str, ...]
    args: tuple[str, ...] = ()
    env: tuple[tuple[str, str], ...] = ()


_BUILD = {"ros-bag": bag_lab, "hdf5": hdf5_lab, "series": series_lab,
          "ros2-bag": lambda lab: bag_lab(lab, ros1=False)}


def _ros2_db_outside(lab: Path) -> None:
    (db,) = (lab / "bags" / "mug").glob("*.db3") or (lab / "bags" / "mug").glob("*.mcap")
    target = _outside(lab, db.name, str(db.relative_to(lab)))
    db.unlink()
    os.symlink(target, db)


def _fifo(relative: str) -> Callable[[Path], None]:
    def breaks(lab: Path) -> None:
        (lab / relative).unlink()
        os.mkfifo(lab / relative)
    return breaks


def _link_loops(lab: Path) -> None:
    """Two links to the lab folder inside it: a glob following them would never end."""
    for name in ("a", "b"):
        os.symlink(lab, lab / "bags" / name)
    _replace('bags = ["bags/*.bag"]', 'bags = ["bags/**/*.bag"]')(lab)


def _npz_big_int(lab: Path) -> None:
    np.savez(lab / "series" / "t1.npz", ch0=np.array([1.0, 2.0]), ch1=np.array([0, 2**60]))
    _set(1, "file", "series/t1.npz")(lab)


def _npz(lab: Path) -> None:
    np.savez(lab / "series" / "t1.npz", ch0=np.array([1.0, np.nan]), ch1=np.array([0.0, 1.0]))
    _set(1, "file", "series/t1.npz")(lab)

CASES = {
    # ------------------------------------------------------------------ ROS bags: labels.csv
    "bag-start-not-a-number": Case("ros-bag", _set(0, "start", "abc"), ("labels.csv:2", "start 'abc'")),
    "bag-start-nan": Case("ros-bag", _set(1, "start", "nan"), ("labels.csv:3", "start")),
    "bag-start-negative": Case("ros-bag", _set(0, "start", "-1"), ("labels.csv:2", "negative")),
    "bag-times-reversed": Case("ros-bag", _set(2, "start", "0.3"),
                               ("labels.csv:4", "not after start")),
    "bag-duplicate-trial-id": Case("ros-bag", _set(1, "trial_id", "mug-a"), ("labels.csv:3", "twice", "labels.csv:2")),
    "bag-unknown-class": Case("ros-bag", _set(2, "class", "stone"), ("labels.csv:4", "'stone'")),
    "bag-empty-trial-id": Case("ros-bag", _set(0, "trial_id", ""), ("labels.csv:2", "trial_id")),
    "bag-cell-with-line-break": Case("ros-bag", _set(0, "trial_id", "a\nb"), ("labels.csv:3", "control character")),
    "bag-unknown-column": Case("ros-bag", lambda lab: _labels(lab).assign(note="x").to_csv(lab / "labels.csv",
                                                                                         index=False),
                               ("labels.csv:1", "note")),
    "bag-labels-zero-bytes": Case("ros-bag", lambda lab: (lab / "labels.csv").write_text(""),
                                  ("labels.csv:1", "empty")),
    "bag-labels-short-line": Case("ros-bag", _replace("mug-b,mug,0.25,", "mug-b,mug", "labels.csv"),
                                  ("labels.csv:3", "3 fields; the header has 5")),
    "bag-labels-binary": Case("ros-bag", lambda lab: (lab / "labels.csv").write_bytes(b"\x00\xff" * 50),
                              ("labels.csv", "cannot read the file")),
    "bag-path-parent": Case("ros-bag", _set(0, "bag", "../elsewhere/x.bag"), ("labels.csv:2", "'..'")),
    "bag-path-absolute": Case("ros-bag", lambda lab: _set(0, "bag", str(_outside(lab, "x.bag", "bags/mug.bag")))(lab),
                              ("labels.csv:2", "absolute")),
    "bag-not-listed": Case("ros-bag", _set(0, "bag", "bags/nope.bag"), ("labels.csv:2", "bags/nope.bag")),
    "bag-matched-but-unlabelled": Case("ros-bag", _unlabelled_bag, ("mapping.toml", "felt.bag", "labels.csv")),
    "bag-window-without-messages": Case("ros-bag", _set(1, "start", "100"), ("labels.csv:3", "no /biotac_pub message")),
    # ------------------------------------------------------------------ ROS bags: mapping and files
    "bag-absolute-glob": Case("ros-bag", _replace('bags = ["bags/*.bag"]', 'bags = ["/tmp/*.bag"]'),
                              ("mapping.toml", "bags pattern", "/tmp/*.bag")),
    "bag-parent-glob": Case("ros-bag", _replace('bags = ["bags/*.bag"]', 'bags = ["../*/*.bag"]'),
                            ("mapping.toml", "bags pattern")),
    "bag-symlink-outside": Case("ros-bag", _link_outside("bags/mug.bag"), ("mapping.toml", "mug.bag", "outside")),
    "bag-msg-outside": Case("ros-bag", _replace('"msg/BioTac.msg"', '"../BioTac.msg"'),
                            ("mapping.toml", "messages.biotac_sensors/msg/BioTac")),
    "bag-zero-bytes": Case("ros-bag", lambda lab: (lab / "bags" / "mug.bag").write_bytes(b""),
                           ("mug.bag", "not a readable ROS bag")),
    "bag-truncated": Case("ros-bag", _truncate("bags/mug.bag", 0.6), ("mug.bag",)),
    "bag-mixed-scalar-and-sequence": Case(
        "ros-bag", _replace('fields = ["bt_data[0].pdc_data", "bt_data[0].tdc_data", "bt_data[0].tac_data"]',
                            'fields = ["bt_data[0].pdc_data", "bt_data[0].electrode_data"]'),
        ("bags/mug.bag", "message 0", "sensor 'finger_0'", "a sequence of 19")),
    "bag-field-is-a-message": Case("ros-bag", _replace('"bt_data[0].pdc_data", ', '"bt_data[0]", '),
                                   ("bags/mug.bag", "message 0", "'bt_data[0]'")),
    "bag-field-is-text": Case("ros-bag", _replace('"bt_data[0].pdc_data", ', '"header.frame_id", '),
                              ("bags/mug.bag", "message 0", "text")),
    "bag-field-private": Case("ros-bag", _replace('"bt_data[0].pdc_data", ', '"__class__", '),
                              ("mapping.toml", "sensors.0.fields")),
    "bag-channel-mismatch": Case("ros-bag", _replace('"bt_data[1].pdc_data", "bt_data[1].tdc_data", ',
                                                     '"bt_data[1].pdc_data", '),
                                 ("bags/mug.bag", "sensor 'finger_1'", "channels")),
    "bag-duplicate-sensor": Case("ros-bag", _replace('name = "finger_1"', 'name = "finger_0"'),
                                 ("mapping.toml", "sensors", "twice")),
    "bag-two-mapping-errors": Case("ros-bag", _replace('ros_distro = "ros1"', 'ros_distro = "ros3"\ncolour = "red"'),
                                   ("mapping.toml", "ros_distro", "colour")),
    "bag-nan-in-message": Case("ros-bag", _nan_reading, ("bags/t0.bag", "message 2", "NaN")),
    "bag-inf-in-sequence": Case("ros-bag", _inf_taxel, ("bags/t0.bag", "message 1", "taxels_1", "infinite")),
    "bag-out-inside-input": Case("ros-bag", lambda lab: None, ("--out", "inside"), ("--out", "{lab}/out")),
    "bag-out-holds-input": Case("ros-bag", lambda lab: None, ("--out", "holds"), ("--out", "{tmp}", "--force")),
    "bag-mapping-is-a-folder": Case("ros-bag", lambda lab: None, ("lab", "cannot read the mapping"),
                                    ("--mapping", "{lab}")),
    "bag-classes-not-binary": Case("ros-bag", _replace("sponge,0,1,1", "sponge,0,2,1", "classes.csv"),
                                   ("classes.csv:3", "porous")),
    "bag-classes-twice": Case("ros-bag", _replace("brick,1,1,0", "mug,1,1,0", "classes.csv"),
                              ("classes.csv:4", "twice")),
    "bag-classes-identical-rows": Case("ros-bag", _replace("felt,0,0,0", "felt,1,0,1", "classes.csv"),
                                       ("classes.csv:5", "same attribute row", "mapping.toml")),
    "bag-classes-constant-column": Case("ros-bag", lambda lab: (lab / "classes.csv").write_text(
                                            "class,hard,porous,smooth\nmug,1,0,1\nsponge,1,1,1\nbrick,1,1,0\n"
                                            "felt,1,0,0\n"), ("classes.csv:1", "'hard'")),
    "bag-classes-outside": Case("ros-bag", _replace('classes = "classes.csv"', 'classes = "../classes.csv"'),
                                ("mapping.toml", "classes")),
    "bag-mapping-path-with-nul": Case("ros-bag", _replace('classes = "classes.csv"', 'classes = "cla\\u0000sses.csv"'),
                                      ("mapping.toml", "classes", "control character")),
    "bag-glob-with-nul": Case("ros-bag", _replace('bags = ["bags/*.bag"]', 'bags = ["bags/\\u0000*.bag"]'),
                              ("mapping.toml", "bags pattern", "control character")),
    "bag-mapping-not-toml": Case("ros-bag", _replace("[messages]", "[messages"), ("mapping.toml", "TOML")),
    "bag-over-the-size-limit": Case("ros-bag", lambda lab: None, ("bags/mug.bag", "message 2", "TZSL_MAX_NPZ_BYTES"),
                                    env=(("TZSL_MAX_NPZ_BYTES", "100"),)),
    "bag2-database-linked-outside": Case("ros2-bag", _ros2_db_outside, ("bags/mug", "symbolic link", "outside")),
    "bag2-metadata-zero-bytes": Case("ros2-bag", lambda lab: (lab / "bags" / "mug" / "metadata.yaml").write_text(""),
                                     ("bags/mug", "not a readable ROS bag")),
    "bag-labels-is-a-pipe": Case("ros-bag", _fifo("labels.csv"), ("mapping.toml", "labels", "pipe")),
    "bag-is-a-pipe": Case("ros-bag", _fifo("bags/mug.bag"), ("mapping.toml", "mug.bag", "pipe")),
    "bag-mapping-nested-deeply": Case("ros-bag", lambda lab: (lab / "mapping.toml").write_text(
        "bags = " + "[" * 5000 + "]" * 5000 + "\n"), ("mapping.toml", "nested")),
    "bag-out-is-the-input": Case("ros-bag", lambda lab: None, ("--out", "inside"), ("--out", "{lab}", "--force")),
    # ------------------------------------------------------------------ HDF5
    "h5-dataset-is-a-group": Case("hdf5", _h5(lambda f: (f.__delitem__("trial_001/f0/pressure"),
                                                         f.create_group("trial_001/f0/pressure"))),
                                  ("session.h5", "group /trial_001", "is a group")),
    "h5-absolute-glob": Case("hdf5", _replace('files = ["*.h5"]', 'files = ["/tmp/*.h5"]'),
                             ("mapping.toml", "files pattern")),
    "h5-string-dataset": Case("hdf5", _h5_replace("trial_001/f0/pressure", data=np.array([b"a"] * 20)),
                              ("session.h5", "group /trial_001", "'f0/pressure'")),
    "h5-vlen-string-dataset": Case("hdf5", _h5_replace("trial_001/f0/pressure", data=["abc"] * 20,
                                                       dtype=h5py.string_dtype()),
                                   ("session.h5", "group /trial_001", "'f0/pressure'")),
    "h5-huge-declared-shape": Case("hdf5", _h5_replace("trial_001/f0/pressure", shape=(10**15,), dtype="<f8",
                                                       chunks=(1000,), compression="gzip"),
                                   ("session.h5", "group /trial_001", "limit")),
    "h5-compressed-never-written": Case("hdf5", _h5_replace("trial_001/f0/pressure", shape=(20,), dtype="<f8",
                                                            chunks=(5,), compression="gzip"),
                                        ("session.h5", "group /trial_001", "fill values")),
    "h5-never-written": Case("hdf5", _h5_replace("trial_001/f0/pressure", shape=(20,), dtype="<f8"),
                             ("session.h5", "group /trial_001", "never written")),
    "h5-label-array": Case("hdf5", _h5(lambda f: f["trial_001"].attrs.__setitem__("material", np.arange(50))),
                           ("session.h5", "group /trial_001", "shape (50,)")),
    "h5-label-missing": Case("hdf5", _h5(lambda f: f["trial_002"].attrs.__delitem__("material")),
                             ("session.h5", "group /trial_002", "no attribute 'material'")),
    "h5-label-not-utf8": Case("hdf5", _h5(lambda f: f["trial_002"].attrs.__setitem__("material", np.bytes_(b"\xff"))),
                              ("session.h5", "group /trial_002", "UTF-8")),
    "h5-unknown-class": Case("hdf5", _h5(lambda f: f["trial_002"].attrs.__setitem__("material", "stone")),
                             ("session.h5", "group /trial_002", "'stone'")),
    "h5-nan": Case("hdf5", _h5(lambda f: f["trial_002/f1/electrodes"].__setitem__((3, 1), np.nan)),
                   ("session.h5", "group /trial_002", "sensor 'f1'", "row 3")),
    "h5-inf": Case("hdf5", _h5(lambda f: f["trial_000/f0/pressure"].__setitem__(5, np.inf)),
                   ("session.h5", "group /trial_000", "infinite")),
    "h5-empty": Case("hdf5", lambda lab: [_h5_replace(f"trial_000/f0/{n}", shape=s, dtype="<f8")(lab)
                                          for n, s in (("pressure", (0,)), ("electrodes", (0, 3)))],
                     ("session.h5", "group /trial_000", "empty")),
    "h5-scalar-dataset": Case("hdf5", _h5_replace("trial_000/f0/pressure", data=1.0),
                              ("session.h5", "group /trial_000", "shape ()")),
    "h5-3d-dataset": Case("hdf5", _h5_replace("trial_000/f0/electrodes", data=np.zeros((20, 3, 2))),
                          ("session.h5", "group /trial_000", "shape (20, 3, 2)")),
    "h5-complex": Case("hdf5", _h5_replace("trial_000/f0/pressure", data=np.zeros(20, dtype=complex)),
                       ("session.h5", "group /trial_000", "complex")),
    "h5-int-beyond-float64": Case("hdf5", _h5_replace("trial_000/f0/pressure", data=np.full(20, 2**60)),
                                  ("session.h5", "group /trial_000", "2**53")),
    "h5-channel-mismatch": Case("hdf5", _h5_replace("trial_003/f1/electrodes", data=np.zeros((20, 4))),
                                ("session.h5", "group /trial_003", "sensor 'f1'", "channels")),
    "h5-length-mismatch": Case("hdf5", _h5_replace("trial_003/f1/electrodes", data=np.zeros((19, 3))),
                               ("session.h5", "group /trial_003", "time steps")),
    "h5-external-link": Case("hdf5", _h5(_external_link), ("session.h5", "group /trial_001", "external link")),
    "h5-external-storage": Case("hdf5", _external_storage, ("session.h5", "group /trial_001", "other files")),
    "h5-soft-link-loop": Case("hdf5", _h5(_soft_loop), ("session.h5", "group /trial_001")),
    "h5-zero-bytes": Case("hdf5", lambda lab: (lab / "session.h5").write_bytes(b""),
                          ("session.h5", "not a readable HDF5")),
    "h5-truncated": Case("hdf5", _truncate("session.h5", 0.5), ("session.h5",)),
    "h5-not-hdf5": Case("hdf5", lambda lab: (lab / "notes.h5").write_text("not hdf5\n"), ("notes.h5",)),
    "h5-duplicate-trial-ids": Case("hdf5", _duplicate_ids, ("session.h5", "group /trial_000", "twice")),
    "h5-file-without-trials": Case("hdf5", _no_groups, ("other.h5", "no group matches")),
    "h5-symlink-outside": Case("hdf5", _link_outside("session.h5"), ("mapping.toml", "session.h5", "outside")),
    "h5-folder-matches": Case("hdf5", lambda lab: (lab / "dir.h5").mkdir(), ("dir.h5", "folder")),
    "h5-same-file-twice": Case("hdf5", lambda lab: os.symlink(lab / "session.h5", lab / "alias.h5"),
                               ("mapping.toml", "alias.h5", "same file")),
    "h5-group-name-with-line-break": Case("hdf5", _h5(lambda f: f.move("trial_001", "trial_\n1")),
                                          ("session.h5", "group /trial_\\n1", "control character")),
    "h5-dataset-from-the-root": Case("hdf5", _replace('"f1/pressure"', '"/trial_000/f1/pressure"'),
                                     ("mapping.toml", "sensors", "root")),
    "h5-label-dataset-missing": Case("hdf5", _replace('label = "attrs:material"', 'label = "dataset:meta/class"'),
                                     ("session.h5", "group /trial_000", "'meta/class'")),
    # ------------------------------------------------------------------ folders of series
    "series-duplicate-row": Case("series", _dup_row, ("labels.csv:6", "twice", "labels.csv:3")),
    "series-path-parent": Case("series", lambda lab: _set(
        0, "file", f"../elsewhere/{_outside(lab, 'x.csv', 'series/t0.csv').name}")(lab),
                               ("labels.csv:2", "'..'")),
    "series-path-absolute": Case("series", lambda lab: _set(
        0, "file", str(_outside(lab, "x.csv", "series/t0.csv")))(lab),
                                 ("labels.csv:2", "absolute")),
    "series-symlink-outside": Case("series", _link_outside("series/t0.csv"), ("labels.csv:2", "symbolic link")),
    "series-missing-file": Case("series", _set(0, "file", "series/none.csv"), ("labels.csv:2", "not found")),
    "series-unsupported-type": Case("series", _set(0, "file", "series/t0.txt"), ("labels.csv:2", "unsupported")),
    "series-unknown-class": Case("series", _set(1, "class", "stone"), ("labels.csv:3", "'stone'")),
    "series-class-conflict": Case("series", _sensors, ("labels.csv:6", "class 'sponge'", "line 2")),
    "series-lacking-sensor": Case("series", _lacking_sensor, ("labels.csv:3", "'right'")),
    "series-empty-sensor": Case("series", lambda lab: _labels(lab).assign(sensor="").to_csv(lab / "labels.csv",
                                                                                            index=False),
                                ("labels.csv:2", "sensor")),
    "series-npy-zero-bytes": Case("series", lambda lab: (lab / "series" / "t1.npy").write_bytes(b""),
                                  ("t1.npy", "not a readable .npy")),
    "series-npy-huge-shape": Case("series", _npy_header((10**9, 10**6)), ("t1.npy", "limit")),
    "series-npy-truncated": Case("series", _npy_header((1000, 2), data=b"\0" * 10), ("t1.npy", "truncated")),
    "series-npy-pickle": Case("series", _save("series/t1.npy", np.array([{"a": 1}] * 3, dtype=object),
                                              allow_pickle=True), ("t1.npy", "pickle")),
    "series-npy-3d": Case("series", _save("series/t1.npy", np.zeros((4, 2, 2))), ("t1.npy", "shape (4, 2, 2)")),
    "series-npy-text": Case("series", _save("series/t1.npy", np.array([["a", "b"]] * 3)), ("t1.npy", "<U1")),
    "series-npy-inf": Case("series", _save("series/t1.npy", np.array([[0.0, 1.0], [np.inf, 0.0]])),
                           ("t1.npy", "infinite", "row 1")),
    "series-npy-empty": Case("series", _save("series/t1.npy", np.zeros((0, 2))), ("t1.npy", "empty")),
    "series-npy-int-beyond-float64": Case("series", _save("series/t1.npy", np.full((3, 2), 2**60)),
                                          ("t1.npy", "2**53")),
    "series-npy-width": Case("series", _save("series/t1.npy", np.zeros((3, 3))),
                             ("t1.npy", "labels.csv line 3", "channels")),
    "series-csv-nan": Case("series", _save("series/t0.csv", "ch0,ch1\n1,2\n3,4\n,5\n"), ("t0.csv:4", "NaN or empty")),
    "series-csv-inf": Case("series", _save("series/t0.csv", "ch0,ch1\n1,inf\n"), ("t0.csv:2", "infinite")),
    "series-csv-header-only": Case("series", _save("series/t0.csv", "ch0,ch1\n"), ("t0.csv:1",)),
    "series-csv-zero-bytes": Case("series", _save("series/t0.csv", ""), ("t0.csv:1",)),
    "series-csv-text-cell": Case("series", _save("series/t0.csv", "ch0,ch1\n1,2\nx,3\n"), ("t0.csv:3", "'x'")),
    "series-csv-channel-mismatch": Case("series", _save("series/t2.csv", "a,b\n1,2\n"),
                                        ("t2.csv", "labels.csv line 4", "channels")),
    "series-labels-binary": Case("series", lambda lab: (lab / "labels.csv").write_bytes(b"\x00\x01" * 20),
                                 ("labels.csv:1", "missing column")),
    "series-labels-only-header": Case("series", lambda lab: (lab / "labels.csv").write_text("file,trial_id,class\n"),
                                      ("labels.csv:1", "no trial")),
    "series-labels-long-lines": Case("series", _replace("series/t0.csv,t0,mug", "series/t0.csv,t0,mug,extra",
                                                        "labels.csv"), ("labels.csv:2", "4 fields; the header has 3")),
    "series-out-inside-input": Case("series", lambda lab: None, ("--out", "inside"), ("--out", "{lab}/series/out")),
    "series-file-is-a-pipe": Case("series", _fifo("series/t0.csv"), ("labels.csv:2", "pipe")),
    "series-hidden-file": Case("series", _set(0, "file", ".hidden/t0.csv"), ("labels.csv:2", "not found")),
    "series-npz-nan": Case("series", _npz, ("t1.npz", "NaN", "row 1")),
    "series-npz-int-beyond-float64": Case("series", _npz_big_int, ("t1.npz", "channel 'ch1'", "2**53")),
    "series-channels-twice": Case("series", lambda lab: (lab / "mapping.toml").write_text(
        (lab / "mapping.toml").read_text() + 'channels = ["a", "a"]\n'), ("mapping.toml", "channels")),
}


def _convert(case: Case, lab: Path, tmp: Path, *extra: str):
    mapping = str(lab / "mapping.toml")
    args = [a.format(lab=lab, tmp=tmp) for a in case.args]
    if "--mapping" in args:
        mapping = args[args.index("--mapping") + 1]
        args = [a for i, a in enumerate(args) if a != "--mapping" and (i == 0 or args[i - 1] != "--mapping")]
    out = [] if "--out" in args else ["--out", str(tmp / "out")]
    kind = "ros-bag" if case.kind == "ros2-bag" else case.kind
    return CliRunner(env=dict(case.env)).invoke(cli, ["convert", "--from", kind, "--mapping", mapping, *out, *args,
                                                      "--no-progress", *extra])


@pytest.mark.parametrize("name", list(CASES))
def test_hostile_input_is_one_line_naming_file_and_record(tmp_path, name):
    case = CASES[name]
    lab = tmp_path / "lab"
    lab.mkdir()
    _BUILD[case.kind](lab)
    case.breaks(lab)
    result = _convert(case, lab, tmp_path)
    lines = result.stderr.strip().splitlines()
    assert result.exit_code == EXIT_TZSL_ERROR, (result.exit_code, result.output, result.exception)
    assert isinstance(result.exception, SystemExit), result.exception
    assert len(lines) == 1 and lines[0].startswith("tzsl: error: "), result.stderr
    assert "Traceback" not in result.output
    for text in case.names:
        assert text in lines[0], (text, lines[0])
    assert not (tmp_path / "out").exists()


def test_allow_outside_reads_an_absolute_path_and_a_link(tmp_path):
    lab = tmp_path / "lab"
    lab.mkdir()
    series_lab(lab)
    outside = _outside(lab, "x.csv", "series/t0.csv")
    _set(0, "file", str(outside))(lab)
    _link_outside("series/t2.csv")(lab)
    case = Case("series", lambda _: None, ())
    refused = _convert(case, lab, tmp_path)
    assert refused.exit_code == EXIT_TZSL_ERROR and "--allow-outside" in refused.stderr
    result = _convert(case, lab, tmp_path, "--allow-outside")
    assert result.exit_code == 0, result.output
    assert "4 trials" in result.output


def test_a_glob_does_not_follow_links_to_folders(tmp_path):
    """Two links back to the lab folder: ``**`` following them would never end (2**depth paths)."""
    lab = tmp_path / "lab"
    lab.mkdir()
    bag_lab(lab)
    _link_loops(lab)
    result = _convert(Case("ros-bag", lambda _: None, ()), lab, tmp_path)
    assert result.exit_code == 0, result.output
    assert "8 trials" in result.output
