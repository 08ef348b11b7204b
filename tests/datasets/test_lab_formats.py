"""Readers for how labs record (issue 20, item 3): ROS bags, HDF5 layouts, folders of series.

Every recording here is SIMULATED and written with the libraries' own writers (rosbags, h5py,
numpy, pandas); the tests check that the converted dataset validates and that the values
round-trip, and that bad files are one line naming the file and the record.
"""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from tzsl.cli import cli

from tzsl.datasets import convert_lab_dataset, read_plain_dataset, read_signal_file, validate_dataset
from tzsl.exceptions import ConfigError, DataFileError

#: The BioTac messages (biotac_sensors package), the documented example of docs/user_guide/lab_formats.md.
BIOTAC_MSG = """int32 pdc_data
int32 tdc_data
int32 tac_data
int16[19] electrode_data
"""
HAND_MSG = """std_msgs/Header header
biotac_sensors/msg/BioTac[] bt_data
"""
CLASSES = pd.DataFrame({"hard": [1, 0, 1, 0], "porous": [0, 1, 1, 0], "smooth": [1, 1, 0, 0]},
                       index=pd.Index(["mug", "sponge", "brick", "felt"], name="class"))


def _store():
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    store.register({**get_types_from_msg(BIOTAC_MSG, "biotac_sensors/msg/BioTac"),
                    **get_types_from_msg(HAND_MSG, "biotac_sensors/msg/BioTacHand")})
    return store


def _hand_message(store, rng, t: int, n_fingers: int = 2):
    BioTac = store.types["biotac_sensors/msg/BioTac"]
    Hand = store.types["biotac_sensors/msg/BioTacHand"]
    Header = store.types["std_msgs/msg/Header"]
    Time = store.types["builtin_interfaces/msg/Time"]
    fingers = [BioTac(pdc_data=int(rng.integers(1000, 3000)), tdc_data=int(rng.integers(1000, 3000)),
                      tac_data=int(rng.integers(1000, 3000)),
                      electrode_data=rng.integers(100, 4000, size=19).astype(np.int16)) for _ in range(n_fingers)]
    return Hand(header=Header(stamp=Time(sec=t, nanosec=0), frame_id="hand"), bt_data=fingers)


def _write_bag(path: Path, store, messages: list, *, ros1: bool = False) -> None:
    if ros1:
        from rosbags.rosbag1 import Writer

        with Writer(path) as writer:
            conn = writer.add_connection("/biotac_pub", "biotac_sensors/msg/BioTacHand", typestore=store)
            for i, m in enumerate(messages):
                writer.write(conn, (i + 1) * 10**8, store.serialize_ros1(m, "biotac_sensors/msg/BioTacHand"))
        return
    from rosbags.rosbag2 import Writer

    with Writer(path, version=9) as writer:
        conn = writer.add_connection("/biotac_pub", "biotac_sensors/msg/BioTacHand", typestore=store)
        for i, m in enumerate(messages):
            writer.write(conn, (i + 1) * 10**8, store.serialize_cdr(m, "biotac_sensors/msg/BioTacHand"))


def _bag_mapping(folder: Path, bags: str, *, ros1: bool = False) -> Path:
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


@pytest.mark.parametrize("ros1", [False, True])
def test_ros_bags_become_a_valid_plain_dataset_with_the_same_values(tmp_path, ros1):
    store, rng = _store(), np.random.default_rng(0)
    messages = {}
    rows = []
    for b, cls in enumerate(CLASSES.index):
        name = f"bags/{cls}.bag" if ros1 else f"bags/{cls}"
        msgs = [_hand_message(store, rng, t) for t in range(10)]
        (tmp_path / "bags").mkdir(exist_ok=True)
        _write_bag(tmp_path / name, store, msgs, ros1=ros1)
        messages[cls] = msgs
        # two trials cut out of each bag by time (seconds from its first message)
        rows += [{"bag": name, "trial_id": f"{cls}-a", "class": cls, "start": 0.0, "end": 0.45},
                 {"bag": name, "trial_id": f"{cls}-b", "class": cls, "start": 0.45, "end": 10.0}]
    pd.DataFrame(rows).to_csv(tmp_path / "labels.csv", index=False)
    mapping = _bag_mapping(tmp_path, "bags/*.bag" if ros1 else "bags/*", ros1=ros1)
    folder, summary = convert_lab_dataset("ros-bag", mapping, tmp_path / "out", progress=False)
    assert validate_dataset(folder) == []
    assert summary["sensors"] == ["finger_0", "finger_1"] and summary["channels"] == ["pdc_data", "tdc_data", "tac_data"]
    data = read_plain_dataset(folder)
    assert data.n_trials == 8 and list(data.sensors) == ["finger_0", "finger_1"]
    trials = pd.read_csv(folder / "trials.csv")
    row = trials[(trials["trial_id"] == "brick-a") & (trials["sensor"] == "finger_1")].iloc[0]
    channels, values = read_signal_file(folder / row["signal_file"])
    expected = [[m.bt_data[1].pdc_data, m.bt_data[1].tdc_data, m.bt_data[1].tac_data] for m in messages["brick"][:5]]
    assert channels == ("pdc_data", "tdc_data", "tac_data")
    np.testing.assert_array_equal(values, np.array(expected, dtype=float))


def test_bag_problems_are_one_line_naming_file_and_record(tmp_path):
    store, rng = _store(), np.random.default_rng(1)
    (tmp_path / "bags").mkdir()
    _write_bag(tmp_path / "bags" / "mug", store, [_hand_message(store, rng, t) for t in range(3)])
    pd.DataFrame([{"bag": "bags/mug", "trial_id": "t1", "class": "mug"}]).to_csv(tmp_path / "labels.csv", index=False)
    mapping = _bag_mapping(tmp_path, "bags/*")
    text = mapping.read_text()
    mapping.write_text(text.replace('topic = "/biotac_pub"\nfields = ["bt_data[1]', 'topic = "/other"\nfields = ["bt_data[1]'))
    with pytest.raises(DataFileError) as info:
        convert_lab_dataset("ros-bag", mapping, tmp_path / "out", progress=False)
    assert str(info.value).splitlines() == [f"{tmp_path / 'bags' / 'mug'}: topic(s) ['/other'] not in the bag "
                                            "(it has ['/biotac_pub'])"]
    mapping.write_text(text.replace("bt_data[1]", "bt_data[5]"))  # the hand has 2 fingers
    with pytest.raises(DataFileError, match=r"mug: message 0 on /biotac_pub: field of sensor 'finger_1'"):
        convert_lab_dataset("ros-bag", mapping, tmp_path / "out", progress=False)
    mapping.write_text(text)
    pd.DataFrame([{"bag": "bags/nope", "trial_id": "t1", "class": "mug"}]).to_csv(tmp_path / "labels.csv", index=False)
    with pytest.raises(DataFileError, match=r"labels.csv:2: bag 'bags/nope' is not among"):
        convert_lab_dataset("ros-bag", mapping, tmp_path / "out", progress=False)
    mapping.write_text("colour = 'red'\n" + text)
    with pytest.raises(ConfigError, match=r"mapping.toml: colour: Extra inputs"):
        convert_lab_dataset("ros-bag", mapping, tmp_path / "out", progress=False)


def test_hdf5_in_a_labs_own_layout(tmp_path):
    rng = np.random.default_rng(2)
    stored = {}
    with h5py.File(tmp_path / "session.h5", "w") as f:
        for i, cls in enumerate(list(CLASSES.index) * 2):
            g = f.create_group(f"trial_{i:03d}")
            g.attrs["material"] = cls
            for finger in ("f0", "f1"):
                pressure = rng.normal(size=50)
                electrodes = rng.normal(size=(50, 3))
                g.create_dataset(f"{finger}/pressure", data=pressure)
                g.create_dataset(f"{finger}/electrodes", data=electrodes)
                stored[(i, finger)] = np.column_stack([pressure, electrodes])
        f.create_group("calibration")  # not a trial: the pattern leaves it out
    CLASSES.to_csv(tmp_path / "classes.csv")
    (tmp_path / "mapping.toml").write_text(
        'kind = "hdf5"\nfiles = ["*.h5"]\nclasses = "classes.csv"\ntrials = "/trial_*"\nlabel = "attrs:material"\n'
        '[[sensors]]\nname = "f0"\ndatasets = ["f0/pressure", "f0/electrodes"]\n'
        '[[sensors]]\nname = "f1"\ndatasets = ["f1/pressure", "f1/electrodes"]\n')
    folder, summary = convert_lab_dataset("hdf5", tmp_path / "mapping.toml", tmp_path / "out", progress=False)
    assert validate_dataset(folder) == [] and summary["trials"] == 8
    assert summary["channels"] == ["pressure", "electrodes_0", "electrodes_1", "electrodes_2"]
    trials = pd.read_csv(folder / "trials.csv")
    row = trials[(trials["trial_id"] == "session_trial_005") & (trials["sensor"] == "f1")].iloc[0]
    assert row["class"] == CLASSES.index[1]
    np.testing.assert_allclose(read_signal_file(folder / row["signal_file"])[1], stored[(5, "f1")])
    with h5py.File(tmp_path / "session.h5", "a") as f:
        del f["trial_002/f0/electrodes"]
    with pytest.raises(DataFileError, match=r"session.h5: group /trial_002: no dataset 'f0/electrodes'"):
        convert_lab_dataset("hdf5", tmp_path / "mapping.toml", tmp_path / "out2", progress=False)


def test_a_folder_of_series_csv_and_npy(tmp_path):
    rng = np.random.default_rng(3)
    (tmp_path / "series").mkdir()
    rows = []
    for i, cls in enumerate(CLASSES.index):
        values = rng.normal(size=(20, 2))
        if i % 2:
            np.save(tmp_path / "series" / f"t{i}.npy", values)
            rows.append({"file": f"series/t{i}.npy", "trial_id": f"t{i}", "class": cls})
        else:
            pd.DataFrame(values, columns=["ch0", "ch1"]).to_csv(tmp_path / "series" / f"t{i}.csv", index=False)
            rows.append({"file": f"series/t{i}.csv", "trial_id": f"t{i}", "class": cls})
    pd.DataFrame(rows).to_csv(tmp_path / "labels.csv", index=False)
    CLASSES.to_csv(tmp_path / "classes.csv")
    (tmp_path / "mapping.toml").write_text('kind = "series"\nclasses = "classes.csv"\nlabels = "labels.csv"\n')
    folder, summary = convert_lab_dataset("series", tmp_path / "mapping.toml", tmp_path / "out", progress=False)
    assert validate_dataset(folder) == [] and summary["channels"] == ["ch0", "ch1"]
    np.testing.assert_allclose(read_signal_file(folder / "signals" / "t1.npz")[1], np.load(tmp_path / "series" / "t1.npy"))
    rows[2]["class"] = "stone"
    pd.DataFrame(rows).to_csv(tmp_path / "labels.csv", index=False)
    with pytest.raises(DataFileError, match=r"classes.csv: class\(es\) \['stone'\] of the recordings"):
        convert_lab_dataset("series", tmp_path / "mapping.toml", tmp_path / "out3", progress=False)


def test_from_a_bag_to_a_report_in_three_commands(tmp_path):
    """Issue 20's goal: convert, validate, run the template (its paths changed only)."""
    store, rng = _store(), np.random.default_rng(4)
    classes = pd.DataFrame((rng.random((12, 4)) < 0.5).astype(int), columns=["hard", "porous", "smooth", "cold"],
                           index=pd.Index([f"m{i}" for i in range(12)], name="class"))
    (tmp_path / "bags").mkdir()
    rows = []
    for cls, attrs in classes.iterrows():
        msgs = []
        for t in range(9):  # the signals follow the attributes, with noise: SIMULATED
            m = _hand_message(store, rng, t)
            for finger in m.bt_data:
                finger.pdc_data = int(2000 + 400 * attrs["hard"] + rng.integers(0, 100))
                finger.tdc_data = int(2000 + 400 * attrs["cold"] + rng.integers(0, 100))
                finger.tac_data = int(2000 + 400 * attrs["porous"] - 300 * attrs["smooth"] + rng.integers(0, 100))
            msgs.append(m)
        _write_bag(tmp_path / "bags" / cls, store, msgs)
        rows += [{"bag": f"bags/{cls}", "trial_id": f"{cls}-{k}", "class": cls, "start": 0.3 * k, "end": 0.3 * k + 0.3}
                 for k in range(3)]
    pd.DataFrame(rows).to_csv(tmp_path / "labels.csv", index=False)
    mapping = _bag_mapping(tmp_path, "bags/*")
    mapping.write_text("allow_identical_rows = true  # materials sharing an attribute row\n" + mapping.read_text())
    classes.to_csv(tmp_path / "classes.csv")
    runner = CliRunner()
    convert = runner.invoke(cli, ["convert", "--from", "ros-bag", "--mapping", str(mapping), "--out",
                                  str(tmp_path / "my_dataset"), "--no-progress"])
    assert convert.exit_code == 0, convert.output + convert.stderr
    validate = runner.invoke(cli, ["validate", str(tmp_path / "my_dataset")])
    assert validate.exit_code == 0 and "dataset card:" in validate.output, validate.output + validate.stderr
    template = (Path(__file__).resolve().parents[2] / "experiments" / "my_dataset_template.toml").read_text()
    experiment = tmp_path / "my_experiment.toml"
    experiment.write_text(template.replace('folder = "results/my_dataset"', f'folder = "{tmp_path / "results"}"'))
    run = runner.invoke(cli, ["run", str(experiment), "--n-jobs", "2", "--no-progress"])
    assert run.exit_code == 0, run.output
    comparison = pd.read_csv(tmp_path / "results" / "method_comparison.csv")
    assert (comparison["data"] == "my_dataset").all() and "paper_accuracy" not in comparison.columns
