"""Property tests of the lab readers (issue 31, item 3): recordings written with the libraries' own
writers (rosbags, h5py, numpy, pandas) from drawn trials convert exactly (every trial, every
sample, the channel names, the classes); the same recordings broken in a drawn place end in exit 3
with one line naming the broken file.

Every recording is SIMULATED.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import h5py
import numpy as np
import pandas as pd
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tests.datasets.lab_recordings import CLASSES, bag_lab, hdf5_lab, hdf5_mapping, reading_lab, series_lab
from tzsl.cli import EXIT_TZSL_ERROR, cli
from tzsl.datasets import read_signal_file

SETTINGS = settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])

#: Finite float64 values of every magnitude (a converter must keep each bit).
finite = st.floats(allow_nan=False, allow_infinity=False, width=64)
#: Trial ids as a lab might type them: leading zeros, spaces, dots, non-ASCII letters.
trial_ids = st.text(alphabet="abcXYZ019 -_.é", min_size=1, max_size=8).filter(lambda t: t.strip() == t and t)
classes = st.sampled_from(list(CLASSES.index))


def _convert(kind: str, mapping: Path, out: Path):
    return CliRunner().invoke(cli, ["convert", "--from", kind, "--mapping", str(mapping), "--out", str(out),
                                    "--no-progress"])


def _written(out: Path) -> dict[tuple[str, str], tuple[str, tuple[str, ...], np.ndarray]]:
    """(trial, sensor) -> (class, channels, values) of a converted dataset, read as text where it is text."""
    table = pd.read_csv(out / "trials.csv", dtype=str, keep_default_na=False)
    sensors = table["sensor"] if "sensor" in table.columns else [""] * len(table)
    return {(t, s): (c, *read_signal_file(out / f)) for t, s, c, f in
            zip(table["trial_id"], sensors, table["class"], table["signal_file"], strict=True)}


def _refused(result, file: str) -> None:
    lines = result.stderr.strip().splitlines()
    assert result.exit_code == EXIT_TZSL_ERROR, (result.output, result.exception)
    assert len(lines) == 1 and lines[0].startswith("tzsl: error: ") and file in lines[0], result.stderr
    assert "Traceback" not in result.output


# --------------------------------------------------------------------------- folders of series


@st.composite
def series_trials(draw):
    """{trial id: (class, file type, values (rows, k))}, k shared."""
    k = draw(st.integers(1, 3))
    ids = draw(st.lists(trial_ids, min_size=1, max_size=4, unique=True))
    return {t: (draw(classes), draw(st.sampled_from(["csv", "npy"])),
                np.array(draw(st.lists(st.lists(finite, min_size=k, max_size=k), min_size=1, max_size=6))))
            for t in ids}


def _series_lab(lab: Path, trials: dict) -> Path:
    (lab / "series").mkdir(parents=True)
    rows = []
    for i, (trial, (cls, kind, values)) in enumerate(trials.items()):
        name = f"series/s{i}.{kind}"
        if kind == "npy":
            np.save(lab / name, values)
        else:
            pd.DataFrame(values, columns=[f"ch{j}" for j in range(values.shape[1])]).to_csv(lab / name, index=False)
        rows.append({"file": name, "trial_id": trial, "class": cls})
    pd.DataFrame(rows).to_csv(lab / "labels.csv", index=False)
    CLASSES.to_csv(lab / "classes.csv")
    (lab / "mapping.toml").write_text('kind = "series"\nclasses = "classes.csv"\nlabels = "labels.csv"\n')
    return lab / "mapping.toml"


@SETTINGS
@given(series_trials())
def test_series_round_trip_exactly(trials):
    with tempfile.TemporaryDirectory() as tmp:
        mapping = _series_lab(Path(tmp) / "lab", trials)
        result = _convert("series", mapping, Path(tmp) / "out")
        assert result.exit_code == 0, result.output
        written = _written(Path(tmp) / "out")
        assert list(written) == [(t, "") for t in trials]
        for trial, (cls, _, values) in trials.items():
            got_class, channels, got = written[(trial, "")]
            assert got_class == cls and channels == tuple(f"ch{j}" for j in range(values.shape[1]))
            np.testing.assert_array_equal(got, values)


@SETTINGS
@given(series_trials(), st.sampled_from(["nan", "inf", "duplicate", "empty", "unknown class", "outside"]),
       st.data())
def test_series_broken_is_one_line(trials, breakage, data):
    with tempfile.TemporaryDirectory() as tmp:
        mapping = _series_lab(Path(tmp) / "lab", trials)
        lab = mapping.parent
        labels = pd.read_csv(lab / "labels.csv", dtype=str, keep_default_na=False)
        i = data.draw(st.integers(0, len(labels) - 1))
        file, (_, kind, values) = labels.loc[i, "file"], list(trials.values())[i]
        if breakage in ("nan", "inf"):
            values = values.copy()
            values[data.draw(st.integers(0, values.shape[0] - 1)), 0] = np.nan if breakage == "nan" else -np.inf
            broken = Path(tmp) / "lab" / file
            if kind == "npy":
                np.save(broken, values)
            else:
                pd.DataFrame(values, columns=[f"ch{j}" for j in range(values.shape[1])]).to_csv(broken, index=False)
            where = file
        elif breakage == "empty":
            np.save(lab / file.replace(".csv", ".npy"), np.zeros((0, values.shape[1])))
            labels.loc[i, "file"] = file.replace(".csv", ".npy")
            where = file.replace(".csv", ".npy")
        elif breakage == "duplicate":
            labels = pd.concat([labels, labels.iloc[[i]]])
            where = f"labels.csv:{len(labels) + 1}"
        elif breakage == "unknown class":
            labels.loc[i, "class"] = "stone"
            where = f"labels.csv:{i + 2}"
        else:
            labels.loc[i, "file"] = "../" + file
            where = f"labels.csv:{i + 2}"
        labels.to_csv(lab / "labels.csv", index=False)
        _refused(_convert("series", mapping, Path(tmp) / "out"), where)
        assert not (Path(tmp) / "out").exists()


# --------------------------------------------------------------------------- HDF5


@st.composite
def hdf5_trials(draw):
    """[(class, {sensor: (pressure (rows,), electrodes (rows, k))})], dtypes drawn."""
    k = draw(st.integers(1, 3))
    dtype = draw(st.sampled_from([np.float64, np.float32, np.int32, np.int16]))
    values = finite if dtype == np.float64 else st.integers(-30000, 30000)
    trials = []
    for _ in range(draw(st.integers(1, 4))):
        rows = draw(st.integers(1, 6))
        sensors = {}
        for name in ("f0", "f1"):
            flat = np.array(draw(st.lists(values, min_size=rows * (k + 1), max_size=rows * (k + 1))), dtype=dtype)
            sensors[name] = (flat[:rows], flat[rows:].reshape(rows, k))
        trials.append((draw(classes), sensors))
    return trials


def _hdf5_lab(lab: Path, trials: list) -> Path:
    lab.mkdir(parents=True)
    with h5py.File(lab / "session.h5", "w") as f:
        for i, (cls, sensors) in enumerate(trials):
            g = f.create_group(f"trial_{i:03d}")
            g.attrs["material"] = cls
            for name, (pressure, electrodes) in sensors.items():
                g.create_dataset(f"{name}/pressure", data=pressure)
                g.create_dataset(f"{name}/electrodes", data=electrodes)
    return hdf5_mapping(lab)


@SETTINGS
@given(hdf5_trials())
def test_hdf5_round_trip_exactly(trials):
    with tempfile.TemporaryDirectory() as tmp:
        mapping = _hdf5_lab(Path(tmp) / "lab", trials)
        result = _convert("hdf5", mapping, Path(tmp) / "out")
        assert result.exit_code == 0, result.output
        written = _written(Path(tmp) / "out")
        assert list(written) == [(f"session_trial_{i:03d}", s) for i in range(len(trials)) for s in ("f0", "f1")]
        for i, (cls, sensors) in enumerate(trials):
            for name, (pressure, electrodes) in sensors.items():
                got_class, channels, got = written[(f"session_trial_{i:03d}", name)]
                k = electrodes.shape[1]
                assert got_class == cls and channels == ("pressure", *(f"electrodes_{j}" for j in range(k)))
                np.testing.assert_array_equal(got, np.column_stack([pressure, electrodes]).astype(np.float64))


@SETTINGS
@given(hdf5_trials(), st.sampled_from(["nan", "label array", "text", "huge", "truncated"]), st.data())
def test_hdf5_broken_is_one_line(trials, breakage, data):
    with tempfile.TemporaryDirectory() as tmp:
        mapping = _hdf5_lab(Path(tmp) / "lab", trials)
        path = mapping.parent / "session.h5"
        group = f"trial_{data.draw(st.integers(0, len(trials) - 1)):03d}"
        if breakage == "truncated":
            path.write_bytes(path.read_bytes()[: data.draw(st.integers(0, path.stat().st_size - 1))])
        else:
            with h5py.File(path, "a") as f:
                pressure = f[f"{group}/f1/pressure"]
                if breakage == "nan":
                    replaced = pressure[()].astype(np.float64)
                    replaced[data.draw(st.integers(0, replaced.size - 1))] = np.nan
                    del f[f"{group}/f1/pressure"]
                    f.create_dataset(f"{group}/f1/pressure", data=replaced)
                elif breakage == "label array":
                    f[group].attrs["material"] = np.array([b"mug"] * data.draw(st.integers(2, 50)))
                else:
                    del f[f"{group}/f1/pressure"]
                    if breakage == "text":
                        f.create_dataset(f"{group}/f1/pressure", data=np.array([b"x"] * 3))
                    else:
                        f.create_dataset(f"{group}/f1/pressure", shape=(10**13,), dtype="<f8", chunks=(4096,),
                                         compression="gzip")
        result = _convert("hdf5", mapping, Path(tmp) / "out")
        _refused(result, "session.h5")
        if breakage != "truncated":
            assert f"group /{group}" in result.stderr


# --------------------------------------------------------------------------- ROS bags


@st.composite
def bag_trials(draw):
    """[(class, [(pressure, taxels (3,))] per message)], and ROS 1 or 2."""
    trials = [[(draw(finite), draw(st.lists(finite, min_size=3, max_size=3)))
               for _ in range(draw(st.integers(1, 5)))] for _ in range(draw(st.integers(1, 3)))]
    return trials, draw(st.booleans()), draw(st.sampled_from(["pressure", "taxels"]))


def _bag_lab(lab: Path, trials: list, ros1: bool, field: str) -> Path:
    mapping = reading_lab(lab, trials, ros1=ros1)
    mapping.write_text(mapping.read_text().replace('fields = ["pressure"]', f'fields = ["{field}"]'))
    return mapping


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(bag_trials())
def test_bags_round_trip_exactly(drawn):
    trials, ros1, field = drawn
    with tempfile.TemporaryDirectory() as tmp:
        mapping = _bag_lab(Path(tmp) / "lab", trials, ros1, field)
        result = _convert("ros-bag", mapping, Path(tmp) / "out")
        assert result.exit_code == 0, result.output
        written = _written(Path(tmp) / "out")
        assert list(written) == [(f"t{i}", "pad") for i in range(len(trials))]
        for i, messages in enumerate(trials):
            got_class, channels, got = written[(f"t{i}", "pad")]
            expected = np.array([[p] if field == "pressure" else t for p, t in messages], dtype=np.float64)
            assert got_class == CLASSES.index[i % len(CLASSES)]
            assert channels == (("pressure",) if field == "pressure" else ("taxels_0", "taxels_1", "taxels_2"))
            np.testing.assert_array_equal(got, expected)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(bag_trials(), st.sampled_from(["nan", "start", "negative", "duplicate", "truncated"]), st.data())
def test_bags_broken_is_one_line(drawn, breakage, data):
    trials, ros1, field = drawn
    with tempfile.TemporaryDirectory() as tmp:
        i = data.draw(st.integers(0, len(trials) - 1))
        if breakage == "nan":
            m = data.draw(st.integers(0, len(trials[i]) - 1))
            trials[i][m] = (np.nan, [np.nan] * 3)
        mapping = _bag_lab(Path(tmp) / "lab", trials, ros1, field)
        labels = pd.read_csv(mapping.parent / "labels.csv", dtype=str, keep_default_na=False)
        where = f"labels.csv:{i + 2}"
        if breakage == "nan":
            where = f"bags/t{i}"
        elif breakage in ("start", "negative"):
            labels["start"] = ""
            labels.loc[i, "start"] = "abc" if breakage == "start" else str(-data.draw(st.floats(1e-9, 1e9)))
        elif breakage == "duplicate":
            labels = pd.concat([labels, labels.iloc[[i]]])
            where = f"labels.csv:{len(labels) + 1}"
        else:
            bag = mapping.parent / labels.loc[i, "bag"]
            target = bag if ros1 else next(p for p in bag.iterdir() if p.name != "metadata.yaml")
            target.write_bytes(target.read_bytes()[: data.draw(st.integers(0, target.stat().st_size - 1))])
            where = f"bags/t{i}"
        labels.to_csv(mapping.parent / "labels.csv", index=False)
        _refused(_convert("ros-bag", mapping, Path(tmp) / "out"), where)


# --------------------------------------------------------------------------- any file damaged


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.sampled_from(["ros-bag", "ros2-bag", "hdf5", "series"]), st.sampled_from(["bytes", "truncate", "flip"]),
       st.data())
def test_any_damaged_file_is_exit_0_or_one_line(kind, damage, data):
    """Whatever file of a lab is damaged (mapping, tables, recordings), never a traceback: it converts, or one line."""
    build = {"ros-bag": bag_lab, "ros2-bag": lambda lab: bag_lab(lab, ros1=False), "hdf5": hdf5_lab,
             "series": series_lab}[kind]
    with tempfile.TemporaryDirectory() as tmp:
        mapping = build(Path(tmp) / "lab")
        files = sorted(p for p in mapping.parent.rglob("*") if p.is_file())
        path = data.draw(st.sampled_from(files), label="file")
        raw = path.read_bytes()
        if damage == "bytes":
            path.write_bytes(data.draw(st.binary(max_size=200), label="bytes"))
        elif damage == "truncate":
            path.write_bytes(raw[: data.draw(st.integers(0, max(0, len(raw) - 1)), label="cut")])
        elif raw:
            at = data.draw(st.integers(0, len(raw) - 1), label="at")
            path.write_bytes(raw[:at] + bytes([raw[at] ^ data.draw(st.integers(1, 255), label="xor")]) + raw[at + 1:])
        result = _convert("ros-bag" if kind == "ros2-bag" else kind, mapping, Path(tmp) / "out")
        assert result.exit_code in (0, EXIT_TZSL_ERROR), (result.output, result.exception)
        assert result.exception is None or isinstance(result.exception, SystemExit), result.exception
        if result.exit_code:
            lines = result.stderr.strip().splitlines()
            assert len(lines) == 1 and lines[0].startswith("tzsl: error: "), result.stderr
