"""SIMULATED lab recordings for the ``tzsl convert --from`` tests, written with the libraries' own
writers (rosbags, h5py, numpy, pandas): a valid lab folder per reader, which tests then break.

Each ``*_lab`` function writes a lab folder (recordings, ``classes.csv``, labels, ``mapping.toml``)
and returns the mapping's path; the converted dataset must go outside that folder.
"""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pandas as pd

#: The BioTac messages (biotac_sensors package), the documented example of docs/user_guide/lab_formats.md.
BIOTAC_MSG = """int32 pdc_data
int32 tdc_data
int32 tac_data
int16[19] electrode_data
"""
HAND_MSG = """std_msgs/Header header
biotac_sensors/msg/BioTac[] bt_data
"""
#: A float message (NaN/inf can be recorded): one pressure and three taxels.
READING_MSG = """float64 pressure
float64[3] taxels
"""
CLASSES = pd.DataFrame({"hard": [1, 0, 1, 0], "porous": [0, 1, 1, 0], "smooth": [1, 1, 0, 0]},
                       index=pd.Index(["mug", "sponge", "brick", "felt"], name="class"))


def biotac_store(ros1: bool = False):
    """A rosbags type store knowing the BioTac and reading messages."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    store.register({**get_types_from_msg(BIOTAC_MSG, "biotac_sensors/msg/BioTac"),
                    **get_types_from_msg(HAND_MSG, "biotac_sensors/msg/BioTacHand"),
                    **get_types_from_msg(READING_MSG, "lab_msgs/msg/Reading")})
    return store


def hand_message(store, rng, t: int, n_fingers: int = 2):
    """A BioTacHand message of random readings at second ``t``."""
    BioTac = store.types["biotac_sensors/msg/BioTac"]
    Hand = store.types["biotac_sensors/msg/BioTacHand"]
    Header = store.types["std_msgs/msg/Header"]
    Time = store.types["builtin_interfaces/msg/Time"]
    fingers = [BioTac(pdc_data=int(rng.integers(1000, 3000)), tdc_data=int(rng.integers(1000, 3000)),
                      tac_data=int(rng.integers(1000, 3000)),
                      electrode_data=rng.integers(100, 4000, size=19).astype(np.int16)) for _ in range(n_fingers)]
    if "std_msgs/msg/Header" in store.types and "seq" in store.types["std_msgs/msg/Header"].__dataclass_fields__:
        return Hand(header=Header(seq=t, stamp=Time(sec=t, nanosec=0), frame_id="hand"), bt_data=fingers)
    return Hand(header=Header(stamp=Time(sec=t, nanosec=0), frame_id="hand"), bt_data=fingers)


def reading_message(store, pressure: float, taxels) -> object:
    """A lab_msgs/msg/Reading message."""
    return store.types["lab_msgs/msg/Reading"](pressure=float(pressure), taxels=np.asarray(taxels, dtype=np.float64))


def write_bag(path: Path, store, messages: list, *, ros1: bool = False, topic: str = "/biotac_pub",
              msgtype: str = "biotac_sensors/msg/BioTacHand", step_ns: int = 10**8) -> None:
    """A ROS 1 ``.bag`` file or a ROS 2 bag folder of ``messages`` on ``topic``, one every ``step_ns``."""
    if ros1:
        from rosbags.rosbag1 import Writer

        with Writer(path) as writer:
            conn = writer.add_connection(topic, msgtype, typestore=store)
            for i, m in enumerate(messages):
                writer.write(conn, (i + 1) * step_ns, store.serialize_ros1(m, msgtype))
        return
    from rosbags.rosbag2 import Writer

    with Writer(path, version=9) as writer:
        conn = writer.add_connection(topic, msgtype, typestore=store)
        for i, m in enumerate(messages):
            writer.write(conn, (i + 1) * step_ns, store.serialize_cdr(m, msgtype))


def bag_mapping(folder: Path, bags: str, *, ros1: bool = False) -> Path:
    """The documented two-finger BioTac mapping (msg files, classes.csv) in ``folder``; labels.csv not written."""
    (folder / "msg").mkdir(exist_ok=True)
    (folder / "msg" / "BioTac.msg").write_text(BIOTAC_MSG)
    (folder / "msg" / "BioTacHand.msg").write_text(HAND_MSG)
    CLASSES.to_csv(folder / "classes.csv")
    fields = '["bt_data[{i}].pdc_data", "bt_data[{i}].tdc_data", "bt_data[{i}].tac_data"]'
    text = f"""kind = "ros-bag"
bags = ["{bags}"]
classes = "classes.csv"
labels = "labels.csv"
ros_distro = "{'ros1' if ros1 else 'ros2'}"
[messages]
"biotac_sensors/msg/BioTac" = "msg/BioTac.msg"
"biotac_sensors/msg/BioTacHand" = "msg/BioTacHand.msg"
[[sensors]]
name = "finger_0"
topic = "/biotac_pub"
fields = {fields.format(i=0)}
[[sensors]]
name = "finger_1"
topic = "/biotac_pub"
fields = {fields.format(i=1)}
"""
    path = folder / "mapping.toml"
    path.write_text(text)
    return path


def bag_lab(folder: Path, *, ros1: bool = True, n_messages: int = 6, seed: int = 0) -> Path:
    """Four BioTac bags (one per class), each cut into two trials by time; returns the mapping."""
    store, rng = biotac_store(ros1), np.random.default_rng(seed)
    (folder / "bags").mkdir(parents=True)
    rows = []
    for cls in CLASSES.index:
        name = f"bags/{cls}.bag" if ros1 else f"bags/{cls}"
        write_bag(folder / name, store, [hand_message(store, rng, t) for t in range(n_messages)], ros1=ros1)
        rows += [{"bag": name, "trial_id": f"{cls}-a", "class": cls, "start": 0.0, "end": 0.25},
                 {"bag": name, "trial_id": f"{cls}-b", "class": cls, "start": 0.25, "end": ""}]
    pd.DataFrame(rows).to_csv(folder / "labels.csv", index=False)
    return bag_mapping(folder, "bags/*.bag" if ros1 else "bags/*", ros1=ros1)


def reading_lab(folder: Path, readings: list[list[tuple[float, list[float]]]], *, ros1: bool = True) -> Path:
    """One bag per trial of lab_msgs/msg/Reading messages on /reading (a float sensor); returns the mapping."""
    store = biotac_store(ros1)
    (folder / "bags").mkdir(parents=True, exist_ok=True)
    (folder / "msg").mkdir(exist_ok=True)
    (folder / "msg" / "Reading.msg").write_text(READING_MSG)
    rows = []
    for i, messages in enumerate(readings):
        name = f"bags/t{i}.bag" if ros1 else f"bags/t{i}"
        write_bag(folder / name, store, [reading_message(store, p, t) for p, t in messages], ros1=ros1,
                  topic="/reading", msgtype="lab_msgs/msg/Reading")
        rows.append({"bag": name, "trial_id": f"t{i}", "class": CLASSES.index[i % len(CLASSES)]})
    pd.DataFrame(rows).to_csv(folder / "labels.csv", index=False)
    CLASSES.to_csv(folder / "classes.csv")
    path = folder / "mapping.toml"
    path.write_text(f'kind = "ros-bag"\nbags = ["bags/*"]\nclasses = "classes.csv"\nlabels = "labels.csv"\n'
                    f'ros_distro = "{"ros1" if ros1 else "ros2"}"\n'
                    '[messages]\n"lab_msgs/msg/Reading" = "msg/Reading.msg"\n'
                    '[[sensors]]\nname = "pad"\ntopic = "/reading"\nfields = ["pressure"]\n')
    return path


def hdf5_mapping(folder: Path, files: str = "*.h5", label: str = "attrs:material") -> Path:
    """The two-sensor HDF5 mapping (f0, f1: pressure + 3 electrodes) and classes.csv in ``folder``."""
    CLASSES.to_csv(folder / "classes.csv")
    path = folder / "mapping.toml"
    path.write_text(f'kind = "hdf5"\nfiles = ["{files}"]\nclasses = "classes.csv"\ntrials = "/trial_*"\n'
                    f'label = "{label}"\n'
                    '[[sensors]]\nname = "f0"\ndatasets = ["f0/pressure", "f0/electrodes"]\n'
                    '[[sensors]]\nname = "f1"\ndatasets = ["f1/pressure", "f1/electrodes"]\n')
    return path


def hdf5_lab(folder: Path, *, n_trials: int = 4, n_rows: int = 20, seed: int = 2) -> Path:
    """``session.h5`` with ``n_trials`` trial groups (a calibration group besides); returns the mapping."""
    rng = np.random.default_rng(seed)
    folder.mkdir(parents=True, exist_ok=True)
    with h5py.File(folder / "session.h5", "w") as f:
        for i in range(n_trials):
            g = f.create_group(f"trial_{i:03d}")
            g.attrs["material"] = CLASSES.index[i % len(CLASSES)]
            for finger in ("f0", "f1"):
                g.create_dataset(f"{finger}/pressure", data=rng.normal(size=n_rows))
                g.create_dataset(f"{finger}/electrodes", data=rng.normal(size=(n_rows, 3)))
        f.create_group("calibration")
    return hdf5_mapping(folder)


def series_lab(folder: Path, *, seed: int = 3) -> Path:
    """Four trials: two ``.csv`` and two ``.npy`` series of channels ch0, ch1; returns the mapping."""
    rng = np.random.default_rng(seed)
    (folder / "series").mkdir(parents=True)
    rows = []
    for i, cls in enumerate(CLASSES.index):
        values = rng.normal(size=(12, 2))
        if i % 2:
            np.save(folder / "series" / f"t{i}.npy", values)
            rows.append({"file": f"series/t{i}.npy", "trial_id": f"t{i}", "class": cls})
        else:
            pd.DataFrame(values, columns=["ch0", "ch1"]).to_csv(folder / "series" / f"t{i}.csv", index=False)
            rows.append({"file": f"series/t{i}.csv", "trial_id": f"t{i}", "class": cls})
    pd.DataFrame(rows).to_csv(folder / "labels.csv", index=False)
    CLASSES.to_csv(folder / "classes.csv")
    path = folder / "mapping.toml"
    path.write_text('kind = "series"\nclasses = "classes.csv"\nlabels = "labels.csv"\n')
    return path
