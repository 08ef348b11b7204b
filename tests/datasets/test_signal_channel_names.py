"""Any channel name a user recorded survives a write and a read of a signal file.

``np.savez_compressed(file, **arrays)`` takes the channel names as keyword arguments: a
channel named ``allow_pickle`` was silently dropped and one named ``file`` crashed with a
TypeError. The writer now writes the ``.npz`` members itself (the same format: one ``.npy``
member per channel, in channel order), so every name round-trips, and names no file can hold
(empty, repeated, a NUL character) are refused at write time with one line.
"""

from __future__ import annotations

import zipfile

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from tests.datasets.lab_recordings import CLASSES
from tzsl.cli import cli
from tzsl.datasets import read_plain_dataset, read_signal_file, validate_dataset, write_plain_dataset
from tzsl.exceptions import ConfigError
from tzsl.features import load_plain_dataset

#: Names numpy's savez takes as its own arguments, then names that are odd as file names.
ODD_NAMES = ["file", "allow_pickle", "args", "kwds", "a/b", "../up", "x.npy", "with space", "a,b",
             'q"uote', "pression ü", "0", "nan", "NA", " spaced ", "new\nline", "Unnamed: 0"]


def _classes() -> pd.DataFrame:
    return pd.DataFrame({"hard": [1, 0], "soft": [0, 1]}, index=pd.Index(["cube", "ball"], name="class"))


def _write(folder, channels, signal_format="npz", seed=0):
    rng = np.random.default_rng(seed)
    trials = pd.DataFrame({"trial_id": ["t1", "t2", "t3"], "class": ["cube", "ball", "cube"]})
    signals = [[rng.normal(size=(6, len(channels)))] for _ in range(3)]
    return write_plain_dataset(folder, _classes(), trials, signals=signals, channels=channels,
                               signal_format=signal_format), signals


@pytest.mark.parametrize("channels", [["file", "p"], ["p", "allow_pickle"], ODD_NAMES])
def test_every_channel_name_round_trips_through_npz(tmp_path, channels):
    folder, signals = _write(tmp_path / "ds", channels)
    for i in range(3):
        found, values = read_signal_file(folder / "signals" / f"t{i + 1}.npz")
        assert found == tuple(channels)
        np.testing.assert_array_equal(values, signals[i][0])  # exact, in channel order
    assert validate_dataset(folder) == []
    assert read_plain_dataset(folder).channels == tuple(channels)
    assert load_plain_dataset(folder).X.shape == (3, 1, 4 * len(channels))


def test_written_npz_is_a_standard_archive_numpy_reads(tmp_path):
    folder, signals = _write(tmp_path / "ds", ["file", "allow_pickle"])
    with np.load(folder / "signals" / "t1.npz", allow_pickle=False) as npz:
        assert list(npz.keys()) == ["file", "allow_pickle"]
        np.testing.assert_array_equal(npz["file"], signals[0][0][:, 0])
    with zipfile.ZipFile(folder / "signals" / "t1.npz") as zf:
        assert all(info.compress_type == zipfile.ZIP_DEFLATED for info in zf.infolist())


def test_files_written_by_savez_before_the_fix_still_read(tmp_path):
    folder, signals = _write(tmp_path / "ds", ["p", "q"])
    old = signals[1][0] * 2
    with open(folder / "signals" / "t2.npz", "wb") as fh:
        np.savez_compressed(fh, p=old[:, 0], q=old[:, 1])
    assert validate_dataset(folder) == []
    data = read_plain_dataset(folder)
    np.testing.assert_array_equal(data.read_signals([1], 0, n_threads=1)[0], old)


def test_channel_names_round_trip_through_csv_signal_files(tmp_path):
    channels = ["file", "allow_pickle", "a,b", 'q"uote', "pression ü", "0", "nan", "NA", "new\nline"]
    folder, signals = _write(tmp_path / "ds", channels, signal_format="csv")
    found, values = read_signal_file(folder / "signals" / "t1.csv")
    assert found == tuple(channels)
    np.testing.assert_array_equal(values, signals[0][0])
    assert validate_dataset(folder) == []


@pytest.mark.parametrize(("signal_format", "channels", "message"), [
    *[(fmt, ["p", "q", "p"], r"channel name\(s\) \['p'\] appear more than once") for fmt in ("npz", "csv")],
    *[(fmt, ["p", ""], r"channel 2 has an empty name") for fmt in ("npz", "csv")],
    *[(fmt, ["p", "a\0b"], r"channel 2, 'a\\x00b', holds a NUL character") for fmt in ("npz", "csv")],
    ("csv", ["p", " q"], r"channel 2, ' q', begins or ends with a space, which a CSV signal file does not keep"),
    ("csv", ["Unnamed: 0", "q"], r"channel 1, 'Unnamed: 0', reads back from a CSV signal file as an unnamed"),
])
def test_channel_names_a_file_cannot_hold_are_refused_at_write(tmp_path, signal_format, channels, message):
    with pytest.raises(ConfigError, match=message) as info:
        _write(tmp_path / "ds", channels, signal_format)
    assert "\n" not in str(info.value)
    assert not (tmp_path / "ds").exists()  # nothing half-written


def test_convert_keeps_channels_named_like_savez_arguments(tmp_path):
    lab = tmp_path / "lab"
    (lab / "series").mkdir(parents=True)
    rng = np.random.default_rng(5)
    rows, recorded = [], {}
    for i, cls in enumerate(CLASSES.index):
        recorded[f"t{i}"] = values = rng.normal(size=(10, 3))
        pd.DataFrame(values, columns=["file", "allow_pickle", "p"]).to_csv(lab / "series" / f"t{i}.csv", index=False)
        rows.append({"file": f"series/t{i}.csv", "trial_id": f"t{i}", "class": cls})
    pd.DataFrame(rows).to_csv(lab / "labels.csv", index=False)
    CLASSES.to_csv(lab / "classes.csv")
    (lab / "mapping.toml").write_text('kind = "series"\nclasses = "classes.csv"\nlabels = "labels.csv"\n')
    out = tmp_path / "out"
    result = CliRunner().invoke(cli, ["convert", "--from", "series", "--mapping", str(lab / "mapping.toml"),
                                      "--out", str(out), "--no-progress"])
    assert result.exit_code == 0, (result.output, result.exception)
    assert validate_dataset(out) == []
    table = pd.read_csv(out / "trials.csv", dtype=str, keep_default_na=False)
    for trial, file in zip(table["trial_id"], table["signal_file"], strict=True):
        found, values = read_signal_file(out / file)
        assert found == ("file", "allow_pickle", "p")
        np.testing.assert_array_equal(values, recorded[trial])
    validate = CliRunner().invoke(cli, ["validate", str(out)])
    assert validate.exit_code == 0, validate.output
