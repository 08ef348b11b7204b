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

from tests.datasets.lab_recordings import CLASSES
from tests.datasets.lab_recordings import bag_mapping as _bag_mapping
from tests.datasets.lab_recordings import biotac_store as _store
from tests.datasets.lab_recordings import hand_message as _hand_message
from tests.datasets.lab_recordings import write_bag as _write_bag
from tzsl.cli import cli
from tzsl.datasets import convert_lab_dataset, read_plain_dataset, read_signal_file, validate_dataset
from tzsl.exceptions import ConfigError, DataFileError


@pytest.mark.parametrize("ros1", [False, True])
def test_ros_bags_become_a_valid_plain_dataset_with_the_same_values(tmp_path, ros1):
    lab = tmp_path / "lab"
    lab.mkdir()
    store, rng = _store(), np.random.default_rng(0)
    messages = {}
    rows = []
    for cls in CLASSES.index:
        name = f"bags/{cls}.bag" if ros1 else f"bags/{cls}"
        msgs = [_hand_message(store, rng, t) for t in range(10)]
        (lab / "bags").mkdir(exist_ok=True)
        _write_bag(lab / name, store, msgs, ros1=ros1)
        messages[cls] = msgs
        # two trials cut out of each bag by time (seconds from its first message)
        rows += [{"bag": name, "trial_id": f"{cls}-a", "class": cls, "start": 0.0, "end": 0.45},
                 {"bag": name, "trial_id": f"{cls}-b", "class": cls, "start": 0.45, "end": 10.0}]
    pd.DataFrame(rows).to_csv(lab / "labels.csv", index=False)
    mapping = _bag_mapping(lab, "bags/*.bag" if ros1 else "bags/*", ros1=ros1)
    folder, summary = convert_lab_dataset("ros-bag", mapping, tmp_path / "out", progress=False)
    assert validate_dataset(folder) == []
    assert (summary["sensors"] == ["finger_0", "finger_1"]
            and summary["channels"] == ["pdc_data", "tdc_data", "tac_data"])
    data = read_plain_dataset(folder)
    assert data.n_trials == 8 and list(data.sensors) == ["finger_0", "finger_1"]
    trials = pd.read_csv(folder / "trials.csv")
    row = trials[(trials["trial_id"] == "brick-a") & (trials["sensor"] == "finger_1")].iloc[0]
    channels, values = read_signal_file(folder / row["signal_file"])
    expected = [[m.bt_data[1].pdc_data, m.bt_data[1].tdc_data, m.bt_data[1].tac_data] for m in messages["brick"][:5]]
    assert channels == ("pdc_data", "tdc_data", "tac_data")
    np.testing.assert_array_equal(values, np.array(expected, dtype=float))


def test_bag_problems_are_one_line_naming_file_and_record(tmp_path):
    lab = tmp_path / "lab"
    lab.mkdir()
    store, rng = _store(), np.random.default_rng(1)
    (lab / "bags").mkdir()
    _write_bag(lab / "bags" / "mug", store, [_hand_message(store, rng, t) for t in range(3)])
    pd.DataFrame([{"bag": "bags/mug", "trial_id": "t1", "class": "mug"}]).to_csv(lab / "labels.csv", index=False)
    mapping = _bag_mapping(lab, "bags/*")
    text = mapping.read_text()
    mapping.write_text(text.replace('topic = "/biotac_pub"\nfields = ["bt_data[1]',
                                    'topic = "/other"\nfields = ["bt_data[1]'))
    with pytest.raises(DataFileError) as info:
        convert_lab_dataset("ros-bag", mapping, tmp_path / "out", progress=False)
    assert str(info.value).splitlines() == [f"{lab / 'bags' / 'mug'}: topic(s) ['/other'] not in the bag "
                                            "(it has ['/biotac_pub'])"]
    mapping.write_text(text.replace("bt_data[1]", "bt_data[5]"))  # the hand has 2 fingers
    with pytest.raises(DataFileError,
                       match=r"mug: message 0 on /biotac_pub: field 'bt_data\[5\].pdc_data' of sensor 'finger_1'"):
        convert_lab_dataset("ros-bag", mapping, tmp_path / "out", progress=False)
    mapping.write_text(text)
    pd.DataFrame([{"bag": "bags/nope", "trial_id": "t1", "class": "mug"}]).to_csv(lab / "labels.csv", index=False)
    with pytest.raises(DataFileError, match=r"labels.csv:2: bag 'bags/nope' is not among"):
        convert_lab_dataset("ros-bag", mapping, tmp_path / "out", progress=False)
    mapping.write_text("colour = 'red'\n" + text)
    with pytest.raises(ConfigError, match=r"mapping.toml: colour: Extra inputs"):
        convert_lab_dataset("ros-bag", mapping, tmp_path / "out", progress=False)


def test_hdf5_in_a_labs_own_layout(tmp_path):
    lab = tmp_path / "lab"
    lab.mkdir()
    rng = np.random.default_rng(2)
    stored = {}
    with h5py.File(lab / "session.h5", "w") as f:
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
    CLASSES.to_csv(lab / "classes.csv")
    (lab / "mapping.toml").write_text(
        'kind = "hdf5"\nfiles = ["*.h5"]\nclasses = "classes.csv"\ntrials = "/trial_*"\nlabel = "attrs:material"\n'
        '[[sensors]]\nname = "f0"\ndatasets = ["f0/pressure", "f0/electrodes"]\n'
        '[[sensors]]\nname = "f1"\ndatasets = ["f1/pressure", "f1/electrodes"]\n')
    folder, summary = convert_lab_dataset("hdf5", lab / "mapping.toml", tmp_path / "out", progress=False)
    assert validate_dataset(folder) == [] and summary["trials"] == 8
    assert summary["channels"] == ["pressure", "electrodes_0", "electrodes_1", "electrodes_2"]
    trials = pd.read_csv(folder / "trials.csv")
    row = trials[(trials["trial_id"] == "session_trial_005") & (trials["sensor"] == "f1")].iloc[0]
    assert row["class"] == CLASSES.index[1]
    np.testing.assert_allclose(read_signal_file(folder / row["signal_file"])[1], stored[(5, "f1")])
    with h5py.File(lab / "session.h5", "a") as f:
        del f["trial_002/f0/electrodes"]
    with pytest.raises(DataFileError, match=r"session.h5: group /trial_002: no dataset 'f0/electrodes'"):
        convert_lab_dataset("hdf5", lab / "mapping.toml", tmp_path / "out2", progress=False)


def test_a_folder_of_series_csv_and_npy(tmp_path):
    lab = tmp_path / "lab"
    lab.mkdir()
    rng = np.random.default_rng(3)
    (lab / "series").mkdir()
    rows = []
    for i, cls in enumerate(CLASSES.index):
        values = rng.normal(size=(20, 2))
        if i % 2:
            np.save(lab / "series" / f"t{i}.npy", values)
            rows.append({"file": f"series/t{i}.npy", "trial_id": f"t{i}", "class": cls})
        else:
            pd.DataFrame(values, columns=["ch0", "ch1"]).to_csv(lab / "series" / f"t{i}.csv", index=False)
            rows.append({"file": f"series/t{i}.csv", "trial_id": f"t{i}", "class": cls})
    pd.DataFrame(rows).to_csv(lab / "labels.csv", index=False)
    CLASSES.to_csv(lab / "classes.csv")
    (lab / "mapping.toml").write_text('kind = "series"\nclasses = "classes.csv"\nlabels = "labels.csv"\n')
    folder, summary = convert_lab_dataset("series", lab / "mapping.toml", tmp_path / "out", progress=False)
    assert validate_dataset(folder) == [] and summary["channels"] == ["ch0", "ch1"]
    np.testing.assert_allclose(read_signal_file(folder / "signals" / "t1.npz")[1], np.load(lab / "series" / "t1.npy"))
    rows[2]["class"] = "stone"
    pd.DataFrame(rows).to_csv(lab / "labels.csv", index=False)
    with pytest.raises(DataFileError, match=r"labels.csv:4: class 'stone' is not in the class table"):
        convert_lab_dataset("series", lab / "mapping.toml", tmp_path / "out3", progress=False)


def test_from_a_bag_to_a_report_in_three_commands(tmp_path):
    """Issue 20's goal: convert, validate, run the template (its paths changed only)."""
    lab = tmp_path / "lab"
    lab.mkdir()
    store, rng = _store(), np.random.default_rng(4)
    classes = pd.DataFrame((rng.random((12, 4)) < 0.5).astype(int), columns=["hard", "porous", "smooth", "cold"],
                           index=pd.Index([f"m{i}" for i in range(12)], name="class"))
    (lab / "bags").mkdir()
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
        _write_bag(lab / "bags" / cls, store, msgs)
        rows += [{"bag": f"bags/{cls}", "trial_id": f"{cls}-{k}", "class": cls, "start": 0.3 * k, "end": 0.3 * k + 0.3}
                 for k in range(3)]
    pd.DataFrame(rows).to_csv(lab / "labels.csv", index=False)
    mapping = _bag_mapping(lab, "bags/*")
    mapping.write_text("allow_identical_rows = true  # materials sharing an attribute row\n" + mapping.read_text())
    classes.to_csv(lab / "classes.csv")
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
