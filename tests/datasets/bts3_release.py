"""A small ``bts3`` release made by the tests: the two grasp CSVs of yayaneath/biotac-sp-images in their
layout (header ``object,slipped,ff_biotac_1..24,mf_biotac_1..24,th_biotac_1..24``, one grasp per line, CRLF)
for a few of the 41 objects, with electrode values that depend on the object's row of the shipped class
table. Never the real data."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from tzsl.datasets import read_bts3_attributes
from tzsl.datasets._bts3 import BTS3_FILES, BTS3_FINGERS

#: The CSV header of the release.
HEADER = "object,slipped," + ",".join(f"{f}_biotac_{i}" for f in BTS3_FINGERS for i in range(1, 25))
#: Objects of the small release: 10 distinct rows of the shipped table, every attribute the study keeps
#: having positive and negative objects among them.
OBJECTS = ("coke", "milk", "minion", "football", "tennis", "apple", "train", "yellow_sponge", "red_can",
           "cardboard_pen_case")


def grasp_line(name: str, slipped: int, values: np.ndarray) -> str:
    """One line of a release CSV: object, slipped, then the 72 electrode values."""
    return f"{name},{slipped}," + ",".join(str(int(v)) for v in values)


def release_csv(objects: tuple[str, ...], grasps: int, rng: np.random.Generator) -> bytes:
    """One release CSV: ``grasps`` grasps of every object, electrodes shifted by the object's attribute row."""
    classes = read_bts3_attributes().classes
    lines = [HEADER]
    for name in objects:
        row = classes.loc[name].to_numpy(dtype=float)
        base = 2500 + 400 * np.resize(row, 72) + 40 * np.arange(72) % 300
        for _ in range(grasps):
            lines.append(grasp_line(name, int(rng.integers(2)), np.rint(base + 30 * rng.standard_normal(72))))
    return ("\r\n".join(lines) + "\r\n").encode()


def write_release(root: Path, objects: tuple[str, ...] = OBJECTS, grasps: int = 2, seed: int = 0) -> dict[str, bytes]:
    """Write both files under ``root`` laid out like the data home (``root/bts3/...``); returns registered
    path -> content."""
    rng = np.random.default_rng(seed)
    files = {}
    for relpath in BTS3_FILES.values():
        files[relpath] = release_csv(objects, grasps, rng)
        (root / relpath).parent.mkdir(parents=True, exist_ok=True)
        (root / relpath).write_bytes(files[relpath])
    return files
