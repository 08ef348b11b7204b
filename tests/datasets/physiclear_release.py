"""A small ``physiclear`` release made by the tests: tiny GelSight-like ``.mov`` videos (48 x 64 pixels, 24
frames at 10 fps, MPEG-4 as the release's) of a few of the 74 objects, a press whose stripes depend on the
object's ranks, and a ``utils/constants.py`` in the release's layout for them. Never the real data."""

from __future__ import annotations

import tempfile
from pathlib import Path

import imageio.v3 as iio
import numpy as np

from tzsl.datasets import read_physiclear_attributes
from tzsl.datasets._physiclear_table import (
    MATERIALS_VARIABLE,
    PROPERTIES,
    SPLIT_VARIABLES,
    physiclear_split_roles,
)

#: Objects of the small release: distinct rank rows, train / validation / test objects of the paper's split.
OBJECTS = ("aluminium_foil", "baseball", "blanket", "bubble_wrap", "egg", "rug", "sponge_soft", "potato",
           "scissor_blade", "steel_wool", "denim", "lemon", "eraser", "orange")
#: Frames, height, width of a video.
SHAPE = (24, 48, 64)


def press_video(ranks: np.ndarray, seed: int, *, contact: bool = True) -> bytes:
    """One ``.mov``: a grey sensor image, then (frames 6-17) stripes whose frequency, angle and depth follow
    ``ranks`` (hardness, roughness, bumpiness), plus noise; the first frame before contact."""
    rng = np.random.default_rng(seed)
    T, H, W = SHAPE
    yy, xx = np.mgrid[:H, :W]
    frames = np.full((T, H, W, 3), 90.0)
    angle = 0.6 * ranks[1]
    stripes = np.sin((0.3 + 0.25 * ranks[0]) * (xx * np.cos(angle) + yy * np.sin(angle)))
    blob = np.exp(-((yy - H / 2) ** 2 + (xx - W / 2) ** 2) / 300.0)
    for t in range(6, 18) if contact else ():
        press = (20 + 15 * ranks[2]) * stripes * blob * min(1.0, (t - 5) / 3) + 3 * (t - 6) * (xx > W / 2)
        frames[t] += press[..., None]
    frames += rng.normal(0, 1.0, frames.shape)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "v.mov"
        iio.imwrite(path, np.clip(frames, 0, 255).astype(np.uint8), plugin="FFMPEG", fps=10, codec="mpeg4",
                    macro_block_size=16)
        return path.read_bytes()


def constants_source(objects: tuple[str, ...]) -> str:
    """A ``utils/constants.py`` in the release's layout with the shipped table's ranks, materials and split
    of ``objects``."""
    table = read_physiclear_attributes()
    split = {o: role for role, objs in physiclear_split_roles().items() for o in objs}
    lines = []
    for role, variable in SPLIT_VARIABLES.items():
        lines += [f"{variable} = ["] + [f"    'physiclear_{o}'," for o in objects if split[o] == role] + ["]", ""]
    for prop, (variable, _) in PROPERTIES.items():
        lines += [f"{variable} = {{"] + [f"    'physiclear_{o}': {table.ranks.loc[o, prop]}," for o in objects]
        lines += ["}", ""]
    lines += [f"{MATERIALS_VARIABLE} = {{"] + [f"    'physiclear_{o}': \"{table.materials[o]}\"," for o in objects]
    return "\n".join(lines + ["}", ""])


def write_release(root: Path, objects: tuple[str, ...] = OBJECTS, takes: int = 2) -> dict[str, bytes]:
    """Write the release under ``root`` laid out like the data home (``root/physiclear/...``); returns
    registered path -> content."""
    ranks = read_physiclear_attributes().ranks
    files = {f"physiclear/dataset/{obj}_{k}.mov": press_video(ranks.loc[obj].to_numpy(float), 100 * i + k)
             for i, obj in enumerate(objects) for k in range(takes)}
    files["physiclear/utils/constants.py"] = constants_source(objects).encode()
    for relpath, content in files.items():
        (root / relpath).parent.mkdir(parents=True, exist_ok=True)
        (root / relpath).write_bytes(content)
    return files
