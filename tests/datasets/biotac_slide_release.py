"""A small ``biotac-slide`` release made by the tests: the raw layout of dexrob/BioTac_slide_20_50
(``raw_data/mat<m>/mat<m>_<n>_bio.csv``: a ``timestamp`` + 44-channel header, integer samples, every
line ending with a comma) for a few materials x slides of a few samples, and a registry of its files
with their sha256 and the URLs of a local server. Never the real data."""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
import pooch

from tests.datasets.fetch_server import registry_of
from tzsl.datasets import (
    BIOTAC_SLIDE_CHANNELS,
    CatalogDataset,
    builtin_data_files,
    dataset_names,
    get_dataset,
    read_biotac_slide_attributes,
    registered_files,
)

#: Materials of the small release: their rows of the shipped table cover its 5 distinct rows, and every
#: attribute has at least 3 positive and 3 negative materials (the study's attribute filter keeps all three).
MATERIALS = ("mat1", "mat2", "mat3", "mat7", "mat15", "mat16", "mat17", "mat20")


def slide_csv(row: np.ndarray, n_rows: int, rng: np.random.Generator) -> bytes:
    """One ``_bio.csv`` whose channels depend on the material's (thick, rough, not_smooth) row."""
    thick, rough, not_smooth = row
    base = np.concatenate([[3, 100, 50 + 40 * thick], np.full(22, 1200.0), np.full(19, 20 + 15 * not_smooth)])
    spread = np.concatenate([[1, 1, 5], np.full(22, 20 + 60 * rough), np.full(19, 4)])
    values = np.rint(base + spread * rng.standard_normal((n_rows, 44))).astype(int)
    lines = ["timestamp," + ",".join(BIOTAC_SLIDE_CHANNELS)]
    lines += [f"{1581073084.690542596 + 0.01 * i:.9f}," + ",".join(map(str, v)) + "," for i, v in enumerate(values)]
    return ("\n".join(lines) + "\n").encode()


def write_release(root: Path, materials: tuple[str, ...] = MATERIALS, slides: int = 3, n_rows: int = 30,
                  seed: int = 0) -> dict[str, bytes]:
    """Write the release under ``root`` laid out like the data home (``root/biotac-slide/raw_data/...``);
    returns registered path -> content."""
    table = read_biotac_slide_attributes()
    rng = np.random.default_rng(seed)
    files = {}
    for material in materials:
        row = table.classes.loc[table.materials[material]].to_numpy()
        for n in range(1, slides + 1):
            relpath = f"biotac-slide/raw_data/{material}/{material}_{n}_bio.csv"
            files[relpath] = slide_csv(row, n_rows, rng)
            (root / relpath).parent.mkdir(parents=True, exist_ok=True)
            (root / relpath).write_bytes(files[relpath])
    return files


def release_registry(path: Path, files: dict[str, bytes], base: str) -> pooch.Pooch:
    """A registry of ``files`` (sha256 of each) with URLs under ``base``, loaded as tzsl loads its own."""
    return registry_of(path, [f"{name} sha256:{hashlib.sha256(content).hexdigest()} {base}/{name}"
                              for name, content in files.items()])


#: The registry folders of the shared data (``../shared/data``): the papers' datasets.
SHARED_DATASETS = ("phac2", "fabric", "gelsight_press")


def catalog_files() -> set[str]:
    """The registered files outside the shared data's datasets: the catalog's public datasets, fetched by
    name or on first use (every built-in catalog dataset's files are among them)."""
    files = {relpath for relpath in registered_files() if relpath.split("/", 1)[0] not in SHARED_DATASETS}
    assert {relpath for name in dataset_names() if isinstance(get_dataset(name), CatalogDataset)
            for relpath in builtin_data_files(name)} <= files
    return files
