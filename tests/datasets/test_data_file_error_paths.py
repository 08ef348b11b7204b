"""DataFileError takes any path-like (``str | os.PathLike[str]``) and names the file by its path.

``str()`` of a path-like that is not a :class:`~pathlib.Path` is its repr, not its path; the
error names the file with :func:`os.fspath`.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from tzsl.datasets import signal_from_arrays
from tzsl.datasets._phac2_hold_mat import parse_trial_id
from tzsl.exceptions import DataFileError


class LabPath(os.PathLike):
    """A path-like that is not a Path (as a lab's own storage class might be)."""

    def __init__(self, path: str) -> None:
        self.path = path

    def __fspath__(self) -> str:
        return self.path

    def __repr__(self) -> str:
        return f"LabPath({self.path!r})"


@pytest.mark.parametrize("path", ["rec/t1.npz", Path("rec/t1.npz"), LabPath("rec/t1.npz")])
def test_the_error_names_any_path_like_by_its_path(path):
    error = DataFileError(path, "truncated", line=3)
    assert error.path == os.fspath(path) and str(error) == f"{error.path}:3: truncated"


def test_signal_and_trial_id_errors_name_a_path_like(tmp_path):
    with pytest.raises(DataFileError, match=r"^rec/t1\.npz: archive holds no channel arrays$"):
        signal_from_arrays(LabPath("rec/t1.npz"), {})
    with pytest.raises(DataFileError, match=r"^rec/t1\.npz: channels have different lengths"):
        signal_from_arrays(LabPath("rec/t1.npz"), {"p": np.zeros(3), "q": np.zeros(4)})
    with pytest.raises(DataFileError, match=r"^rec/x\.mat: trial name 'x' does not follow"):
        parse_trial_id("x", LabPath("rec/x.mat"))
