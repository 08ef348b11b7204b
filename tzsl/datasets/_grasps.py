"""Grasp data of a multi-finger hand (Shadow hand, 5 BioTacs, 19 joint encoders): plain-file format.

Format (copy for ``data/README.md``)
------------------------------------
A grasp folder holds one table and one ``.npz`` file per grasp::

    my_grasps/
        grasps.csv          # one row per grasp
        <grasp_id>.npz      # the grasp's time series (any relative path named in grasps.csv)

``grasps.csv`` has (at least) the columns

* ``grasp_id`` - unique text id of the grasp (e.g. ``mug_003``);
* ``object``   - the object grasped (its row name in the class-attribute table, e.g. ``mug``);
  may be empty for unlabelled grasps that are only to be classified;
* ``file``     - path of the grasp's ``.npz`` file, relative to the folder.

Each ``.npz`` holds these arrays (no others are needed; extra arrays are ignored):

==================  ===============  ==========================================================
name                shape            content
==================  ===============  ==========================================================
``f{i}_tdc``        (n_i,)           BioTac ``i`` static temperature TDC, raw ADC counts
``f{i}_tac``        (n_i,)           BioTac ``i`` dynamic temperature TAC, raw ADC counts
``f{i}_pdc``        (n_i,)           BioTac ``i`` static pressure PDC, raw ADC counts
``f{i}_pac``        (n_i, 22)        BioTac ``i`` dynamic pressure PAC, 22 sub-samples per row
``f{i}_electrodes`` (n_i, 19)        BioTac ``i`` impedance of electrodes E1..E19, raw ADC counts
``joints``          (n_j, 19)        joint angles in radians, columns in :data:`JOINT_NAMES` order
==================  ===============  ==========================================================

for the five fingers ``i = 0..4`` in :data:`FINGER_NAMES` order (thumb, first, middle, ring,
little finger). Rows are time samples at a nominal 100 Hz from the moment the fingers start to
close; the first rows must be taken before any finger touches the object (they are the grasp's own
baseline for contact detection, see :mod:`tzsl.features`). Each finger's five arrays share one
length ``n_i``; ``joints`` may have its own length ``n_j``. Values must be finite. Any numeric
dtype is accepted; readers return float64.

The 19 joint columns follow the Shadow Dexterous Hand's names: per finger ``J0`` (the coupled
distal + middle flexion J1+J2), ``J3`` (proximal flexion) and ``J4`` (abduction) for the first,
middle, ring and little fingers, the five thumb joints ``THJ1..THJ5`` and the two wrist joints.
The DAP paper (section 5.2) states only that the hand has 19 joint encoders; this column layout
is ours.

The class-attribute matrix K of the paper's hand experiment (Table 4) ships with tzsl, see
:func:`load_hand_table4`.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from importlib import resources
from io import StringIO
from pathlib import Path

import numpy as np
import pandas as pd

from tzsl._io import atomic_write, ensure_folder, read_npz
from tzsl.datasets._paths import check_inside, resolve_inside
from tzsl.datasets._types import BiotacSignals
from tzsl.exceptions import DataFileError

#: Finger order of the BioTacs (``f0`` .. ``f4`` in the files).
FINGER_NAMES: tuple[str, ...] = ("thumb", "first", "middle", "ring", "little")

#: The 19 joint-angle columns of ``joints`` (radians), Shadow-hand joint names.
JOINT_NAMES: tuple[str, ...] = (
    "FFJ0", "FFJ3", "FFJ4",
    "MFJ0", "MFJ3", "MFJ4",
    "RFJ0", "RFJ3", "RFJ4",
    "LFJ0", "LFJ3", "LFJ4",
    "THJ1", "THJ2", "THJ3", "THJ4", "THJ5",
    "WRJ1", "WRJ2",
)  # fmt: skip

#: BioTac arrays per finger and the trailing shape of each (rows come first).
BIOTAC_ARRAYS: dict[str, tuple[int, ...]] = {
    "tdc": (),
    "tac": (),
    "pdc": (),
    "pac": (22,),
    "electrodes": (19,),
}

GRASP_TABLE = "grasps.csv"
GRASP_COLUMNS: tuple[str, ...] = ("grasp_id", "object", "file")
_TABLE4 = "hand_table4.csv"


@dataclass(frozen=True)
class Grasp:
    """One grasp of a 5-finger hand with a BioTac on every fingertip.

    Attributes
    ----------
    grasp_id : str
        Unique id of the grasp.
    object_name : str
        Object grasped ("" when unknown).
    source : str
        File the grasp was read from ("" for grasps made in memory); used in error messages.
    fingers : tuple of 5 BiotacSignals
        BioTac signals per finger in :data:`FINGER_NAMES` order, raw ADC counts, ``n_i`` rows.
    joints : ndarray of shape (n_j, 19)
        Joint angles in radians, columns in :data:`JOINT_NAMES` order.
    """

    grasp_id: str
    object_name: str
    source: str
    fingers: tuple[BiotacSignals, ...]
    joints: np.ndarray

    @property
    def n_fingers(self) -> int:
        return len(self.fingers)


@dataclass(frozen=True)
class HandTable:
    """The class-attribute matrix K of the hand experiment with its metadata.

    Attributes
    ----------
    K : DataFrame of shape (n_objects, n_attributes), int 0/1
        Indexed by object name; columns are attribute names.
    split : Series of str, indexed by object
        ``"train"`` or ``"test"``.
    subset : Series of str, indexed by object
        ``"homogeneous"``, ``"heterogeneous_shape"``, ``"heterogeneous_material"`` or ``""``.
    material_attributes, shape_attributes : tuple of str
        Columns of ``K`` sensed by the BioTacs and by the joint encoders.
    source : str
        Where the table comes from.
    """

    K: pd.DataFrame
    split: pd.Series
    subset: pd.Series
    material_attributes: tuple[str, ...]
    shape_attributes: tuple[str, ...]
    source: str

    @property
    def train_objects(self) -> list[str]:
        return list(self.split.index[self.split == "train"])

    @property
    def test_objects(self) -> list[str]:
        return list(self.split.index[self.split == "test"])


def load_hand_table4(path: str | Path | None = None) -> HandTable:
    """Read the hand experiment's class-attribute matrix (DAP paper, Table 4).

    Parameters
    ----------
    path : str or Path, optional
        A table in the same layout (comment lines starting with ``#``, two of them naming the
        ``material attributes`` and ``shape attributes``; columns ``object, split, subset`` then
        0/1 attribute columns). Default: the copy of Table 4 shipped with tzsl.

    Returns
    -------
    HandTable
    """
    if path is None:
        ref = resources.files("tzsl.datasets").joinpath(_TABLE4)
        text = ref.read_text(encoding="utf-8")
        where: str | Path = f"tzsl/datasets/{_TABLE4}"
    else:
        where = Path(path)
        try:
            text = where.read_text(encoding="utf-8")
        except OSError as exc:
            raise DataFileError(where, f"cannot read the class-attribute table ({exc.strerror})") from None
    kinds: dict[str, tuple[str, ...]] = {}
    comments = [line for line in text.splitlines() if line.startswith("#")]
    for line in comments:
        m = re.match(r"#\s*(material|shape) attributes[^:]*:\s*(.*)$", line)
        if m:
            kinds[m.group(1)] = tuple(m.group(2).split())
    if set(kinds) != {"material", "shape"}:
        raise DataFileError(where, "missing '# material attributes ...:' or '# shape attributes ...:' line")
    body = "\n".join(line for line in text.splitlines() if line and not line.startswith("#"))
    table = pd.read_csv(StringIO(body), dtype={"object": str, "split": str, "subset": str}, keep_default_na=False)
    missing = [c for c in ("object", "split", "subset") if c not in table.columns]
    if missing:
        raise DataFileError(where, f"missing column(s) {missing}")
    attributes = [c for c in table.columns if c not in ("object", "split", "subset")]
    if sorted(attributes) != sorted(kinds["material"] + kinds["shape"]):
        raise DataFileError(
            where, f"attribute columns {attributes} differ from the material + shape lists {kinds}"
        )
    if table["object"].duplicated().any():
        dup = table.loc[table["object"].duplicated(), "object"].tolist()
        raise DataFileError(where, f"duplicate object row(s) {dup}")
    bad_split = sorted(set(table["split"]) - {"train", "test"})
    if bad_split:
        raise DataFileError(where, f"split must be 'train' or 'test', found {bad_split}")
    values = table[attributes]
    if not values.isin([0, 1]).all().all():
        raise DataFileError(where, "attribute entries must be 0 or 1")
    table = table.set_index("object")
    return HandTable(
        K=table[attributes].astype(int).rename_axis("object_name"),
        split=table["split"].rename_axis("object_name"),
        subset=table["subset"].rename_axis("object_name"),
        material_attributes=kinds["material"],
        shape_attributes=kinds["shape"],
        source=str(where),
    )


def _file_name(grasp_id: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]", "_", grasp_id) + ".npz"


def grasp_arrays(grasp: Grasp) -> dict[str, np.ndarray]:
    """The arrays of ``grasp`` under their file names (``f0_pdc``, ..., ``joints``)."""
    arrays: dict[str, np.ndarray] = {}
    for i, finger in enumerate(grasp.fingers):
        for name in BIOTAC_ARRAYS:
            arrays[f"f{i}_{name}"] = np.asarray(getattr(finger, name))
    arrays["joints"] = np.asarray(grasp.joints)
    return arrays


def write_grasps(
    folder: str | Path,
    grasps: Iterable[Grasp],
    *,
    extra: pd.DataFrame | None = None,
    compress: bool = False,
) -> Path:
    """Write ``grasps`` to ``folder`` in the grasp format; returns the path of ``grasps.csv``.

    Every grasp is validated first (as :func:`read_grasps` would), so a folder written here
    always reads back. Files are written atomically; existing files of the same names are
    replaced (overwrite checks are the caller's job).

    Parameters
    ----------
    folder : str or Path
        Destination folder (created if needed).
    grasps : iterable of Grasp
    extra : DataFrame, optional
        Additional columns for ``grasps.csv``, one row per grasp in the same order (readers
        ignore them), e.g. the simulator's ground truth.
    compress : bool, default False
        Use ``numpy.savez_compressed``.
    """
    folder = Path(folder)
    grasps = list(grasps)
    if extra is not None:
        if len(extra) != len(grasps):
            raise ValueError(f"extra has {len(extra)} rows for {len(grasps)} grasps")
        clash = [c for c in extra.columns if c in GRASP_COLUMNS]
        if clash:
            raise ValueError(f"extra columns {clash} clash with the grasp table's own columns")
    rows = []
    seen: dict[str, str] = {}
    for grasp in grasps:
        _validate(grasp_arrays(grasp), grasp.source or None, grasp.grasp_id)
        name = _file_name(grasp.grasp_id)
        if name in seen:
            raise DataFileError(
                folder / name,
                f"grasp ids {seen[name]!r} and {grasp.grasp_id!r} map to the same file name",
                trial=grasp.grasp_id,
            )
        seen[name] = grasp.grasp_id
        rows.append((grasp.grasp_id, grasp.object_name, name))
    ensure_folder(folder, "grasp folder")
    save = np.savez_compressed if compress else np.savez
    for grasp, (_, _, name) in zip(grasps, rows, strict=True):
        arrays = grasp_arrays(grasp)

        def _write(tmp: Path, arrays: dict[str, np.ndarray] = arrays) -> None:
            with open(tmp, "wb") as fh:
                save(fh, **arrays)  # type: ignore[arg-type]  # the keys (f0_pdc, ..., joints) never hit allow_pickle

        atomic_write(folder / name, _write)
    table = pd.DataFrame(rows, columns=list(GRASP_COLUMNS))
    if extra is not None:
        table = pd.concat([table, extra.reset_index(drop=True)], axis=1)
    return atomic_write(folder / GRASP_TABLE, lambda tmp: table.to_csv(tmp, index=False))


def _validate(arrays: dict[str, np.ndarray], path: str | Path | None, grasp_id: str) -> None:
    """Raise DataFileError naming ``path`` and ``grasp_id`` unless ``arrays`` is a valid grasp."""

    def fail(problem: str) -> None:
        raise DataFileError(path, problem, trial=grasp_id)

    expected = [f"f{i}_{name}" for i in range(len(FINGER_NAMES)) for name in BIOTAC_ARRAYS] + ["joints"]
    missing = [name for name in expected if name not in arrays]
    if missing:
        fail(f"missing array(s) {missing}; a grasp needs {len(FINGER_NAMES)} fingers x {list(BIOTAC_ARRAYS)} "
             "+ 'joints'")
    for i in range(len(FINGER_NAMES)):
        n_rows = None
        for name, tail in BIOTAC_ARRAYS.items():
            key = f"f{i}_{name}"
            a = arrays[key]
            if not np.issubdtype(a.dtype, np.number) or np.issubdtype(a.dtype, np.complexfloating):
                fail(f"array {key} has non-numeric dtype {a.dtype}")
            if a.ndim != 1 + len(tail) or a.shape[1:] != tail:
                fail(f"array {key} has shape {a.shape}; expected (n_rows{''.join(f', {t}' for t in tail)})")
            if n_rows is None:
                n_rows = a.shape[0]
            elif a.shape[0] != n_rows:
                fail(f"finger {i} ({FINGER_NAMES[i]}) arrays differ in length: {key} has {a.shape[0]} rows, "
                     f"f{i}_tdc {n_rows}")
            if a.shape[0] == 0:
                fail(f"array {key} has no rows")
            if not np.isfinite(a).all():
                fail(f"array {key} holds NaN or infinite values")
    joints = arrays["joints"]
    if not np.issubdtype(joints.dtype, np.number) or np.issubdtype(joints.dtype, np.complexfloating):
        fail(f"array joints has non-numeric dtype {joints.dtype}")
    if joints.ndim != 2 or joints.shape[1] != len(JOINT_NAMES) or joints.shape[0] == 0:
        fail(f"array joints has shape {joints.shape}; expected (n_rows, {len(JOINT_NAMES)}) with n_rows >= 1")
    if not np.isfinite(joints).all():
        fail("array joints holds NaN or infinite values")


def grasp_from_arrays(
    arrays: dict[str, np.ndarray], grasp_id: str, object_name: str = "", source: str = ""
) -> Grasp:
    """Build a validated :class:`Grasp` from arrays named as in the file format (float64 copies)."""
    _validate(arrays, source or None, grasp_id)
    fingers = tuple(
        BiotacSignals(**{name: np.asarray(arrays[f"f{i}_{name}"], dtype=np.float64) for name in BIOTAC_ARRAYS})
        for i in range(len(FINGER_NAMES))
    )
    return Grasp(
        grasp_id=grasp_id,
        object_name=object_name,
        source=source,
        fingers=fingers,
        joints=np.asarray(arrays["joints"], dtype=np.float64),
    )


def read_grasp_table(folder: str | Path) -> pd.DataFrame:
    """Read and check ``grasps.csv`` of a grasp folder (columns :data:`GRASP_COLUMNS`, as str)."""
    folder = Path(folder)
    path = folder / GRASP_TABLE
    outside = check_inside(folder, GRASP_TABLE)
    if outside is not None:
        raise DataFileError(path, outside)
    if not path.is_file():
        raise DataFileError(path, f"grasp table not found (a grasp folder needs {GRASP_TABLE})")
    try:
        table = pd.read_csv(path, dtype=str, keep_default_na=False)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        raise DataFileError(path, f"cannot parse the grasp table: {exc}") from None
    missing = [c for c in GRASP_COLUMNS if c not in table.columns]
    if missing:
        raise DataFileError(path, f"missing column(s) {missing}; expected {list(GRASP_COLUMNS)}")
    if table.empty:
        raise DataFileError(path, "the grasp table has no rows")
    blank = table["grasp_id"].str.strip() == ""
    if blank.any():
        raise DataFileError(path, f"empty grasp_id on row(s) {list(np.flatnonzero(blank) + 2)}")
    dup = table["grasp_id"].duplicated()
    if dup.any():
        raise DataFileError(path, f"duplicate grasp_id(s) {sorted(set(table.loc[dup, 'grasp_id']))}")
    return table


def read_grasps(folder: str | Path, grasp_ids: Sequence[str] | None = None) -> list[Grasp]:
    """Read a grasp folder (format: see the module docstring).

    Parameters
    ----------
    folder : str or Path
        Folder holding ``grasps.csv`` and the ``.npz`` files.
    grasp_ids : sequence of str, optional
        Read only these grasps (in this order). Default: all, in table order.

    Returns
    -------
    list of Grasp
        Arrays as float64.

    Raises
    ------
    DataFileError
        Missing table or file, unreadable file, missing finger or signal, wrong shape,
        NaN/inf values - naming the file and the grasp.
    """
    folder = Path(folder)
    table = read_grasp_table(folder)
    table = table.assign(_line=np.arange(2, len(table) + 2))  # header = line 1 (blank lines not counted)
    if grasp_ids is not None:
        indexed = table.set_index("grasp_id", drop=False)
        unknown = [g for g in grasp_ids if g not in indexed.index]
        if unknown:
            raise DataFileError(folder / GRASP_TABLE, f"unknown grasp id(s) {unknown}")
        table = indexed.loc[list(grasp_ids)].reset_index(drop=True)
    grasps = []
    for grasp_id, object_name, file, line in table[[*GRASP_COLUMNS, "_line"]].itertuples(index=False):
        path, reason = resolve_inside(folder, file, "file")
        if path is None:
            raise DataFileError(folder / GRASP_TABLE, f"grasp {grasp_id!r}: {reason}", line=int(line))
        shown = folder / file
        if not path.is_file():
            raise DataFileError(shown, "grasp file not found (named in grasps.csv)", trial=grasp_id)
        try:
            arrays = read_npz(path, name=shown)
        except DataFileError as exc:
            raise DataFileError(shown, exc.problem, trial=grasp_id) from None
        grasps.append(grasp_from_arrays(arrays, grasp_id, object_name, str(shown)))
    return grasps


def grasp_table(grasps: Sequence[Grasp]) -> pd.DataFrame:
    """Table of ``grasps``: columns ``grasp_id``, ``object_name``, ``source``; one row per grasp."""
    return pd.DataFrame(
        {
            "grasp_id": [g.grasp_id for g in grasps],
            "object_name": [g.object_name for g in grasps],
            "source": [g.source for g in grasps],
        }
    )
