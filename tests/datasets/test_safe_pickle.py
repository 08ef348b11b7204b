"""The restricted unpickler admits numpy data and containers only."""

from __future__ import annotations

import collections
import fractions
import os
import pickle

import numpy as np
import pytest

from tzsl.datasets import safe_load_pickle
from tzsl.exceptions import DataFileError


class _Evil:
    def __init__(self, marker):
        self.marker = marker

    def __reduce__(self):
        return (os.system, (f"touch {self.marker}",))


@pytest.mark.parametrize("protocol", [2, 4, 5])
def test_numpy_and_containers_round_trip(tmp_path, protocol):
    obj = collections.defaultdict(dict)
    obj["train"] = {
        "features": np.arange(12.0).reshape(3, 4),
        "names": np.array([b"a_101_01", b"b_102_02"]),
        "ids": np.array([1, 2], dtype=np.int64),
    }
    obj["meta"] = [1, 2.5, ("x", np.float64(3.0), np.int32(4)), {"s": {1, 2}}]
    path = tmp_path / "ok.pkl"
    path.write_bytes(pickle.dumps(obj, protocol=protocol))
    back = safe_load_pickle(path)
    assert isinstance(back, collections.defaultdict)
    np.testing.assert_array_equal(back["train"]["features"], obj["train"]["features"])
    np.testing.assert_array_equal(back["train"]["names"], obj["train"]["names"])
    assert back["meta"][2][1] == 3.0 and back["meta"][3]["s"] == {1, 2}


def test_os_system_is_rejected_and_not_run(tmp_path):
    marker = tmp_path / "pwned"
    path = tmp_path / "evil.pkl"
    path.write_bytes(pickle.dumps(_Evil(marker), protocol=2))
    with pytest.raises(DataFileError) as err:
        safe_load_pickle(path)
    assert not marker.exists()
    msg = str(err.value)
    assert str(path) in msg and "system" in msg and "forbidden global" in msg


@pytest.mark.parametrize(
    "payload, name",
    [
        (b"cbuiltins\neval\n(S'1+1'\ntR.", "builtins.eval"),
        (b"c__builtin__\ngetattr\n(S'x'\nS'y'\ntR.", "__builtin__.getattr"),
        (b"cnumpy\nload\n(S'x'\ntR.", "numpy.load"),
    ],
)
def test_dangerous_builtins_and_numpy_functions_are_rejected(tmp_path, payload, name):
    path = tmp_path / "bad.pkl"
    path.write_bytes(payload)
    with pytest.raises(DataFileError, match=name.replace(".", r"\.")):
        safe_load_pickle(path)


def test_custom_class_is_rejected(tmp_path):
    path = tmp_path / "frac.pkl"
    path.write_bytes(pickle.dumps({"x": fractions.Fraction(1, 3)}, protocol=2))
    with pytest.raises(DataFileError, match="fractions.Fraction"):
        safe_load_pickle(path)


def test_truncated_pickle_is_a_clear_error(tmp_path):
    full = pickle.dumps({"features": np.ones((50, 47))}, protocol=2)
    path = tmp_path / "cut.pkl"
    path.write_bytes(full[: len(full) // 2])
    with pytest.raises(DataFileError) as err:
        safe_load_pickle(path)
    assert str(path) in str(err.value)
    assert "truncated" in str(err.value) or "corrupt" in str(err.value)


@pytest.mark.parametrize("content", [b"", b"not a pickle at all", b"\x80\x02\xff\xff"])
def test_empty_and_garbage_files(tmp_path, content):
    path = tmp_path / "junk.pkl"
    path.write_bytes(content)
    with pytest.raises(DataFileError, match="junk.pkl"):
        safe_load_pickle(path)


def test_missing_file(tmp_path):
    with pytest.raises(DataFileError, match="cannot read"):
        safe_load_pickle(tmp_path / "nope.pkl")


@pytest.mark.realdata
def test_real_python2_pickles_load(data_dir):
    path = next((data_dir / "phac2/penn_bolt_ml_data/static_adjective_phase_set").glob("*.pkl"))
    data = safe_load_pickle(path)
    assert set(data) == {"train", "test"}
    assert data["train"]["features"].shape[1] == 47
    forces = safe_load_pickle(data_dir / "gelsight_press/foam_brick_1_forces.pkl")
    assert forces.dtype == np.float64 and forces.ndim == 1
