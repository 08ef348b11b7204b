"""The fabric data of the GelSight fabric ZSL study (F18).

Public data (``<data home>/fabric/``, see ``fabric/PROVENANCE.md``):

* ``fabric_groups.csv`` - fabric_id (1..119), fabric_name (F0001..F0119), group (0..7):
  the 8 k-means clusters of the paper's Fig. 4 (0-indexed).
* ``a8.npy`` (8 groups x 8 binary attributes) and the alternatives ``a4.npy`` (8 x 4),
  ``a12.npy`` (8 x 12), ``three_value_a8.npy`` and ``three_value_a8v2.npy`` (8 x 8).
* ``depth224/F####_Depth_New_<HHMMSS>.png`` - 1300 16-bit depth images, 224 x 224.

Attribute names
---------------
The paper names 8 attributes (:data:`PAPER_ATTRIBUTE_NAMES`), but no file stores the
column order, and it cannot be established from the data: in ``a8`` columns 0 and 1 are
complementary (a Thin/Thick-like pair) but agree neither with the thickness column of
``class_mean.npy`` nor with the paper's remark that all training classes have Thick = 0
- no column of ``a8`` is 0 for all training groups {1, 2, 3, 4, 6}. (Only column 4 of
both ``three_value`` matrices is 0 on every training group and non-zero on test groups
5 and 7.) Columns are therefore named ``attr_0 .. attr_<L-1>``.

Duplicate attribute vectors
---------------------------
Groups 3, 4 and 5 share one ``a8`` vector (``a4`` additionally merges groups 2 and 7).
:func:`load_fabric` reports such groups in :attr:`FabricData.duplicate_groups` and with a
``UserWarning``; :func:`fabric_zsl_split` refuses a split whose test groups coincide.

User-supplied GelSight fabric press videos are read by
:func:`~tzsl.datasets.load_gelsight_fabric_videos` (:mod:`tzsl.datasets._fabric_videos`).
"""

from __future__ import annotations

import ast
import os
import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from tzsl.datasets._home import get_data_home
from tzsl.datasets._registry import fetch, missing_message, registered_files
from tzsl.exceptions import ConfigError, DataFileError, DataMissingError, SplitError

__all__ = [
    "FABRIC_ATTRIBUTE_SETS",
    "FABRIC_ZSL_CONFIGS",
    "PAPER_ATTRIBUTE_NAMES",
    "FabricData",
    "FabricSplit",
    "fabric_groups_csv_bytes",
    "fabric_zsl_split",
    "load_fabric",
    "read_depth_images",
    "read_fabric_groups",
]

#: The paper's 8 attribute names. Their correspondence to the columns of ``a8.npy`` is
#: NOT known (see the module docstring); they are not used as column names.
PAPER_ATTRIBUTE_NAMES: tuple[str, ...] = (
    "thin", "thick", "dense", "light", "stiff", "flexible", "not_stretchable", "stretchable",
)

#: Selectable group x attribute matrices: name -> (file, number of columns).
FABRIC_ATTRIBUTE_SETS: dict[str, tuple[str, int]] = {
    "a8": ("a8.npy", 8),
    "a4": ("a4.npy", 4),
    "a12": ("a12.npy", 12),
    "three_value_a8": ("three_value_a8.npy", 8),
    "three_value_a8v2": ("three_value_a8v2.npy", 8),
}

#: Zero-shot configurations of the study (0-indexed groups): config -> test groups.
#: Config 1 is the paper's ("classes 2, 3, 4, 5, 7 for training", 1-indexed).
FABRIC_ZSL_CONFIGS: dict[int, tuple[int, ...]] = {1: (0, 5, 7), 2: (0, 4, 7)}

N_GROUPS = 8
N_FABRICS = 119
DEPTH_SHAPE = (224, 224)
_GROUP_COLUMNS = ("fabric_id", "fabric_name", "group")
_DEPTH_RE = re.compile(r"^F(?P<id>\d{4})_Depth_New_(?P<stamp>\d{6})\.png$")
#: The registered depth images (a folder of the data home).
FABRIC_DEPTH_DIR = "fabric/depth224/"
#: The registered fabric x group table (built by a fetch from :data:`FABRIC_GROUPS_SOURCE`).
FABRIC_GROUPS_CSV = "fabric/fabric_groups.csv"


# ---------------------------------------------------------------------------------
# tables
# ---------------------------------------------------------------------------------
#: Registered source of ``fabric_groups.csv``: the group lists of the fabric paper's code.
FABRIC_GROUPS_SOURCE = "fabric/sources/Data2.py"


def fabric_groups_csv_bytes(source: str, origin: str = FABRIC_GROUPS_SOURCE) -> bytes:
    """``fabric_groups.csv`` built from the text of the paper code's ``Data2.py``.

    The group membership is the literal list ``self.large_classify = [[...], ...]`` (one list of
    1-based fabric ids per group). The file is Python 2; only that literal is parsed
    (:func:`ast.literal_eval`), nothing is executed.

    Parameters
    ----------
    source : str
        Text of ``Data2.py``.
    origin : str
        Name of the source in error messages.

    Returns
    -------
    bytes
        CSV with columns fabric_id, fabric_name (``F0001``...), group (0-based), one row per
        fabric in id order, ``\n`` line ends.

    Raises
    ------
    DataFileError
        No group literal, or groups that do not hold every fabric 1..N exactly once.
    """
    at = source.find("large_classify")
    start = source.find("[", at) if at >= 0 else -1
    depth, end = 0, -1
    for end in range(max(start, 0), len(source) if start >= 0 else 0):
        depth += {"[": 1, "]": -1}.get(source[end], 0)
        if depth == 0:
            break
    try:
        groups = ast.literal_eval(source[start:end + 1]) if start >= 0 and depth == 0 else None
    except (ValueError, SyntaxError):
        groups = None
    if not (isinstance(groups, list) and all(isinstance(g, list) for g in groups)):
        raise DataFileError(origin, "no 'large_classify = [[...], ...]' list of fabric ids per group")
    member = {int(f): g for g, ids in enumerate(groups) for f in ids}
    n = sum(len(g) for g in groups)
    if len(member) != n or sorted(member) != list(range(1, n + 1)):
        raise DataFileError(origin, f"large_classify does not hold the fabric ids 1..{n} exactly once")
    rows = "".join(f"{i},F{i:04d},{member[i]}\n" for i in range(1, n + 1))
    return (",".join(_GROUP_COLUMNS) + "\n" + rows).encode()


def read_fabric_groups(path: str | os.PathLike, *, n_groups: int | None = N_GROUPS) -> pd.DataFrame:
    """Read and validate a ``fabric_groups.csv``.

    Parameters
    ----------
    path : str or path-like
        CSV with columns fabric_id (int), fabric_name (str), group (int).
    n_groups : int or None
        Groups must lie in ``0 .. n_groups - 1`` (None: any non-negative int).

    Returns
    -------
    DataFrame
        Columns fabric_id (int64), fabric_name (str), group (int64), sorted by
        fabric_id, default index.

    Raises
    ------
    DataMissingError, DataFileError
        Missing file, missing columns, non-integer ids/groups, duplicate ids or names,
        groups out of range.
    """
    path = Path(path)
    if not path.is_file():
        raise DataMissingError(path, "fabric group table not found")
    try:
        table = pd.read_csv(path, dtype={"fabric_name": str})
    except Exception as exc:  # noqa: BLE001 - pandas raises several parser errors
        raise DataFileError(path, f"cannot read CSV ({type(exc).__name__}: {exc})") from None
    missing = [c for c in _GROUP_COLUMNS if c not in table.columns]
    if missing:
        raise DataFileError(path, f"missing column(s) {missing}; expected {list(_GROUP_COLUMNS)}")
    table = table[list(_GROUP_COLUMNS)].copy()
    for col in ("fabric_id", "group"):
        values = pd.to_numeric(table[col], errors="coerce")
        if values.isna().any() or (values % 1 != 0).any():
            bad = table.loc[values.isna() | (values % 1 != 0), col].tolist()[:5]
            raise DataFileError(path, f"column {col!r} must hold integers; got {bad}")
        table[col] = values.astype(np.int64)
    if table["fabric_name"].isna().any():
        raise DataFileError(path, "empty fabric_name")
    for col in ("fabric_id", "fabric_name"):
        dup = table.loc[table[col].duplicated(), col].tolist()
        if dup:
            raise DataFileError(path, f"duplicate {col} values {dup[:5]}")
    high = n_groups if n_groups is not None else np.inf
    bad = table.loc[(table["group"] < 0) | (table["group"] >= high), "group"].unique().tolist()
    if bad:
        raise DataFileError(path, f"group values {bad} outside 0..{(n_groups or 0) - 1}")
    return table.sort_values("fabric_id", ignore_index=True)


def _load_matrix(path: Path, n_cols: int) -> np.ndarray:
    try:
        with warnings.catch_warnings():
            # The files were saved by Python 2; numpy warns about the old header.
            warnings.simplefilter("ignore", UserWarning)
            mat = np.load(path, allow_pickle=False)
    except Exception as exc:  # noqa: BLE001 - numpy raises ValueError, OSError, EOFError... on a bad file
        raise DataFileError(path, f"cannot read .npy ({type(exc).__name__}: {exc})") from None
    if mat.shape != (N_GROUPS, n_cols):
        raise DataFileError(path, f"attribute matrix has shape {mat.shape}; expected ({N_GROUPS}, {n_cols})")
    if not np.isin(mat, (0, 1)).all():
        raise DataFileError(path, "attribute matrix must be binary (0/1)")
    return mat.astype(np.int64)


def duplicate_rows(matrix: np.ndarray) -> list[tuple[int, ...]]:
    """Sets of row indices with identical vectors (only sets of size >= 2)."""
    _, inverse, counts = np.unique(matrix, axis=0, return_inverse=True, return_counts=True)
    inverse = inverse.ravel()
    return [tuple(int(i) for i in np.flatnonzero(inverse == k)) for k in np.flatnonzero(counts > 1)]


# ---------------------------------------------------------------------------------
# images
# ---------------------------------------------------------------------------------
def read_depth_images(paths, dtype=np.uint16, *, shape: tuple[int, int] = DEPTH_SHAPE) -> np.ndarray:
    """Read 16-bit depth PNGs into one array.

    Parameters
    ----------
    paths : sequence of str or path-like
        PNG files.
    dtype : numpy dtype, default=uint16
        ``uint16`` keeps the raw depth values; a float dtype converts them unchanged
        (no scaling).
    shape : (int, int)
        Required image shape (H, W).

    Returns
    -------
    ndarray of shape (n, H, W)

    Raises
    ------
    DataMissingError
        A file does not exist.
    DataFileError
        Unreadable file, wrong shape, or not a single-channel 16-bit image.
    """
    import imageio.v3 as iio  # noqa: PLC0415 - imageio is slow to import; only image readers need it

    paths = [Path(p) for p in paths]
    out = np.empty((len(paths), *shape), dtype=dtype)
    for i, p in enumerate(paths):  # one decoder call per file; no vectorised PNG reader exists
        if not p.is_file():
            raise DataMissingError(p, "depth image not found")
        try:
            img = iio.imread(p)
        except Exception as exc:  # noqa: BLE001 - imageio's plugins raise many types on a bad file
            raise DataFileError(p, f"cannot read image ({type(exc).__name__}: {exc})") from None
        if img.shape != tuple(shape):
            raise DataFileError(p, f"depth image has shape {img.shape}; expected {tuple(shape)}")
        if img.dtype != np.uint16:
            raise DataFileError(p, f"depth image has dtype {img.dtype}; expected 16-bit grayscale (uint16)")
        out[i] = img
    return out


# ---------------------------------------------------------------------------------
# the data set
# ---------------------------------------------------------------------------------
@dataclass(frozen=True)
class FabricData:
    """The fabric table, one group x attribute matrix and the depth-image table.

    Attributes
    ----------
    fabrics : DataFrame
        One row per fabric: fabric_id, fabric_name, group (0..7).
    attributes : DataFrame of shape (8, L), int64 0/1
        Group x attribute matrix; index ``group`` 0..7, columns ``attr_0 .. attr_<L-1>``
        (the column order of the source files is unknown; see the module docstring).
    attribute_set : str
        Which matrix (key of :data:`FABRIC_ATTRIBUTE_SETS`).
    images : DataFrame
        One row per depth PNG, ordered by fabric_id then capture time: image_id
        (0..n-1), fabric_id, fabric_name, group, capture_index (0-based, timestamp
        order within the fabric), stamp (``HHMMSS`` from the file name), path.
    duplicate_groups : list of tuple of int
        Groups sharing one attribute vector in this matrix.
    root : Path
        The ``fabric`` folder read.
    """

    fabrics: pd.DataFrame
    attributes: pd.DataFrame
    attribute_set: str
    images: pd.DataFrame
    duplicate_groups: list[tuple[int, ...]] = field(default_factory=list)
    root: Path | None = None

    def read_images(self, rows=None, dtype=np.uint16) -> np.ndarray:
        """Decode depth images (lazily: nothing is read before this call).

        Parameters
        ----------
        rows : array-like of int or bool, or None
            Positions in :attr:`images` (or a boolean mask); None = all.
        dtype : numpy dtype, default=uint16
            Output dtype (float dtypes hold the raw values, unscaled).

        Returns
        -------
        ndarray of shape (n, 224, 224)
        """
        table = self.images if rows is None else self.images.iloc[np.asarray(rows)]
        return read_depth_images(table["path"].tolist(), dtype=dtype)

    def image_labels(self) -> np.ndarray:
        """Group of every image, shape (n_images,), int64."""
        return self.images["group"].to_numpy(dtype=np.int64)


def _image_table(fabrics: pd.DataFrame, home: Path) -> pd.DataFrame:
    relpaths = registered_files(FABRIC_DEPTH_DIR)
    if not relpaths:
        raise DataFileError(None, f"the dataset registry lists no {FABRIC_DEPTH_DIR} files")
    missing = [r for r in relpaths if not (home / r).is_file()]
    if missing:
        raise DataMissingError(
            home / missing[0],
            f"{len(missing)} of {len(relpaths)} fabric depth images are missing (first: "
            f"{missing[0]}). " + missing_message(missing[0], home),
        )
    rows = []
    for rel in relpaths:
        m = _DEPTH_RE.match(rel[len(FABRIC_DEPTH_DIR):])
        if m is None:
            raise DataFileError(home / rel, "depth image name does not match F####_Depth_New_HHMMSS.png")
        rows.append((int(m["id"]), m["stamp"], str(fetch(rel, home))))
    images = pd.DataFrame(rows, columns=["fabric_id", "stamp", "path"])
    known = set(fabrics["fabric_id"])
    unknown = sorted(set(images["fabric_id"]) - known)
    if unknown:
        raise DataFileError(home / FABRIC_DEPTH_DIR, f"depth images of fabrics {unknown[:5]} not in fabric_groups.csv")
    without = sorted(known - set(images["fabric_id"]))
    if without:
        raise DataMissingError(home / FABRIC_DEPTH_DIR, f"no depth image for fabric ids {without[:10]}")
    images = images.merge(fabrics, on="fabric_id", how="left", validate="many_to_one")
    images = images.sort_values(["fabric_id", "stamp", "path"], ignore_index=True)
    images["capture_index"] = images.groupby("fabric_id").cumcount().astype(np.int64)
    images.insert(0, "image_id", np.arange(len(images), dtype=np.int64))
    return images[["image_id", "fabric_id", "fabric_name", "group", "capture_index", "stamp", "path"]]


def load_fabric(
    data_dir: str | os.PathLike | None = None, attributes: str = "a8", *, images: bool = True
) -> FabricData:
    """Load the fabric groups, one group x attribute matrix and the depth-image table.

    Files are checked against the dataset registry's sha256 (depth PNGs: existence
    only; their hashes are not published). Images are not decoded here; use
    :meth:`FabricData.read_images`.

    Parameters
    ----------
    data_dir : str or path-like or None
        Data home (see :func:`tzsl.datasets.get_data_home`); files under ``fabric/``.
    attributes : str, default="a8"
        A key of :data:`FABRIC_ATTRIBUTE_SETS`.
    images : bool, default=True
        Build the image table (False: an empty one, for attribute-only use).

    Returns
    -------
    FabricData

    Raises
    ------
    ConfigError
        Unknown ``attributes``.
    DataMissingError, ChecksumError, DataFileError
        Missing or corrupt files, wrong shapes, fabrics without images.

    Warns
    -----
    UserWarning
        Some groups share one attribute vector (listed; also in ``duplicate_groups``).
    """
    if attributes not in FABRIC_ATTRIBUTE_SETS:
        raise ConfigError(f"attributes must be one of {sorted(FABRIC_ATTRIBUTE_SETS)}; got {attributes!r}")
    home = get_data_home(data_dir)
    fabrics = read_fabric_groups(fetch(FABRIC_GROUPS_CSV, home))
    groups_path = home / FABRIC_GROUPS_CSV
    if len(fabrics) != N_FABRICS:
        raise DataFileError(groups_path, f"{len(fabrics)} fabrics; expected {N_FABRICS}")
    absent = sorted(set(range(N_GROUPS)) - set(fabrics["group"]))
    if absent:
        raise DataFileError(groups_path, f"groups {absent} have no fabric")
    fname, n_cols = FABRIC_ATTRIBUTE_SETS[attributes]
    mat = _load_matrix(fetch(f"fabric/{fname}", home), n_cols)
    table = pd.DataFrame(
        mat, index=pd.RangeIndex(N_GROUPS, name="group"), columns=[f"attr_{j}" for j in range(n_cols)]
    )
    dups = duplicate_rows(mat)
    if dups:
        warnings.warn(
            f"fabric attribute matrix {attributes!r}: groups "
            + "; ".join(", ".join(map(str, d)) for d in dups)
            + " share one attribute vector (they cannot be told apart by attributes)",
            UserWarning,
            stacklevel=3,  # past load_fabric and its profile wrapper
        )
    image_table = (
        _image_table(fabrics, home)
        if images
        else pd.DataFrame(columns=["image_id", "fabric_id", "fabric_name", "group", "capture_index", "stamp", "path"])
    )
    return FabricData(
        fabrics=fabrics,
        attributes=table,
        attribute_set=attributes,
        images=image_table,
        duplicate_groups=dups,
        root=home / "fabric",
    )


# ---------------------------------------------------------------------------------
# zero-shot split
# ---------------------------------------------------------------------------------
@dataclass(frozen=True)
class FabricSplit:
    """A zero-shot split of the 8 fabric groups.

    Attributes
    ----------
    config : int
        1 (test groups 0, 5, 7: the paper's) or 2 (test 0, 4, 7).
    train_groups, test_groups : tuple of int
        0-indexed groups, sorted.
    """

    config: int
    train_groups: tuple[int, ...]
    test_groups: tuple[int, ...]

    def is_test(self, groups) -> np.ndarray:
        """Boolean mask, True where ``groups`` (array of group ids) is a test group."""
        return np.isin(np.asarray(groups), self.test_groups)

    def is_train(self, groups) -> np.ndarray:
        """Boolean mask, True where ``groups`` is a training group."""
        return np.isin(np.asarray(groups), self.train_groups)


def fabric_zsl_split(config: int = 1, attribute_matrix=None) -> FabricSplit:
    """The study's zero-shot split of the fabric groups.

    Parameters
    ----------
    config : {1, 2}
        1: train groups (1, 2, 3, 4, 6), test (0, 5, 7) - the paper's "classes 2, 3, 4,
        5, 7 for training" (1-indexed). 2: test (0, 4, 7), train (1, 2, 3, 5, 6).
    attribute_matrix : array-like or DataFrame of shape (8, L), optional
        Group x attribute matrix (e.g. ``FabricData.attributes``); when given, the test
        groups' vectors must be pairwise different.

    Returns
    -------
    FabricSplit

    Raises
    ------
    ConfigError
        Unknown ``config``.
    SplitError
        Two test groups share an attribute vector, or the matrix does not have 8 rows.
    """
    if isinstance(config, bool) or config not in FABRIC_ZSL_CONFIGS:
        raise ConfigError(f"fabric zero-shot config must be one of {sorted(FABRIC_ZSL_CONFIGS)}; got {config!r}")
    test = tuple(sorted(FABRIC_ZSL_CONFIGS[config]))
    train = tuple(g for g in range(N_GROUPS) if g not in test)
    if attribute_matrix is not None:
        mat = np.asarray(attribute_matrix)
        if mat.ndim != 2 or mat.shape[0] != N_GROUPS:
            raise SplitError(f"attribute matrix must have shape (8, L); got {mat.shape}")
        for dup in duplicate_rows(mat[list(test)]):
            same = [test[i] for i in dup]
            raise SplitError(
                f"fabric config {config}: test groups {same} share one attribute vector "
                f"{mat[same[0]].tolist()}; zero-shot classification cannot separate them"
            )
    return FabricSplit(config=int(config), train_groups=train, test_groups=test)
