"""``bts3``: the BioTacSP Stability Set (yayaneath/biotac-sp-images), 41 objects, as a plain-file dataset.

The release (https://github.com/yayaneath/biotac-sp-images at commit :data:`BTS3_COMMIT`) holds two
CSV files, one per hand orientation: ``biotac-palmdown-grasps.csv`` and ``biotac-palmside-grasps.csv``.
Each line is one grasp of a Shadow hand with three BioTac SP fingertips (index ``ff``, middle ``mf``,
thumb ``th``): ``object`` (one of 41 object names), ``slipped`` (0 stable, 1 the object slid) and the
24 electrode values of each fingertip (``ff_biotac_1`` ... ``th_biotac_24``), one reading per grasp.
The registry lists both files under ``bts3/`` with their sha256 and their ``raw.githubusercontent.com``
link at that commit (``tzsl data fetch bts3``). :func:`load_bts3` reads both (each verified by
:func:`~tzsl.datasets.fetch`) into one table of grasps and an array of shape (n_grasps, 3, 24).

:func:`convert_bts3` writes them as a plain-file folder with :func:`~tzsl.datasets.write_plain_dataset`:
one trial per grasp (``palm_down_<line>``, ``palm_side_<line>``; ``trial_index`` counts an object's
grasps, palm down first), object and class = the ``object`` column, three sensors
(``ff``, ``mf``, ``th``) whose features are the 24 electrode values as published (``electrode_1`` ...
``electrode_24``: the release holds one reading per grasp, not a signal to summarise).

The classes and their attributes are the package's ``bts3_attributes.csv`` (:data:`ATTRIBUTE_TABLE`),
one line per object and attribute: ``object,class,attribute,value,source,evidence``. The release
describes its objects only by their names and the photo ``objects.jpg`` (sha256
:data:`OBJECTS_PHOTO_SHA256` at that commit: 41 labelled panels, one per object, in 7 rows of 6,
:data:`BTS3_PANELS`); its README cites an IROS 2018 workshop paper (``arXiv:1809.05551``) whose text
was not available to read. So every value is read from the object's panel (``source`` = ``objects.jpg,
row <r>, column <c>``, ``evidence`` = what the panel shows) or from its name (``source`` = ``object name
'<object>'``, ``evidence`` = the word that says it). The rule of judgement: an attribute
(:data:`BTS3_ATTRIBUTES`, each with its definition) is 1 when the panel or name shows it, 0 when the
panel shows an object without it; an attribute that some object's panel and name cannot decide is
left out of the table altogether (so: no plastic or glass material, which the photo cannot tell
apart, no weight, size, hardness beyond ``soft``, or fill level). A class is the object's name.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np
import pandas as pd

from tzsl.datasets._biotac_slide import MaterialTable
from tzsl.datasets._catalog import read_class_table
from tzsl.datasets._plain_write import write_plain_dataset
from tzsl.datasets._registry import fetch
from tzsl.exceptions import DataFileError, first_line

__all__ = ["ATTRIBUTE_TABLE", "BTS3", "BTS3_ATTRIBUTES", "BTS3_COMMIT", "BTS3_FILES", "BTS3_FINGERS", "BTS3_PANELS",
           "BTS3_SETTINGS", "OBJECTS_PHOTO", "OBJECTS_PHOTO_SHA256", "Bts3Grasps", "convert_bts3", "load_bts3",
           "read_bts3_attributes", "read_bts3_csv"]

#: The dataset's registry folder.
BTS3 = "bts3"
#: The commit of https://github.com/yayaneath/biotac-sp-images the registry pins.
BTS3_COMMIT = "bdd90cc376e673d8ac2f7c879af47c99ecc56783"
#: Hand orientation -> its registered file.
BTS3_FILES: dict[str, str] = {"palm_down": f"{BTS3}/biotac-palmdown-grasps.csv",
                              "palm_side": f"{BTS3}/biotac-palmside-grasps.csv"}
#: The fingertips, in the files' column order (index, middle, thumb).
BTS3_FINGERS: tuple[str, ...] = ("ff", "mf", "th")
#: Electrode values per fingertip.
N_ELECTRODES = 24
#: The feature names of every fingertip (its 24 electrode values as published).
ELECTRODES: tuple[str, ...] = tuple(f"electrode_{i}" for i in range(1, N_ELECTRODES + 1))
#: ``dataset.toml`` of the written folder (classes may share a row: 41 objects, 22 distinct rows).
BTS3_SETTINGS: dict = {"name": BTS3, "classes": {"allow_identical_rows": True}}
#: The class-attribute table shipped in this package.
ATTRIBUTE_TABLE = "bts3_attributes.csv"
#: The release's photo of its objects, and its sha256 at :data:`BTS3_COMMIT`.
OBJECTS_PHOTO = "objects.jpg"
OBJECTS_PHOTO_SHA256 = "6d7e134f34e1483ddc77bf30b0cd2227979bcd376a721ea0cd00195315b43609"
#: Object -> its labelled panel (row, column) in :data:`OBJECTS_PHOTO`, row by row as the photo shows them.
BTS3_PANELS: dict[str, tuple[int, int]] = {name: (r, c) for r, row in enumerate((
    ("metal_pen_case", "train", "minion", "olaf", "budha", "elephant"),
    ("spray", "puleva", "shower_gel", "cookies_plastic", "granini", "pringles"),
    ("seresto", "twisted", "detergent", "red_can", "toilet_paper", "salt"),
    ("aquarius", "rollon", "green_gel", "green_glass", "coke", "lanjaron"),
    ("pink_ball", "apple", "rugby", "tennis", "football", "lindor"),
    ("metal_box", "eggs", "colgate", "juice", "cardboard_pen_case", "pen_box"),
    ("wardrobe", "milk", "yellow_sponge", "wood_box", "cone")), start=1) for c, name in enumerate(row, start=1)}
#: Attribute -> its definition (what makes it 1; an object that shows none of it is 0).
BTS3_ATTRIBUTES: dict[str, str] = {
    "metal": "the body the fingers touch is metal: a drinks or aerosol can, a tin, metal mesh",
    "paperboard_box": "a box or carton folded from printed paperboard",
    "fabric": "covered in textile: plush (stuffed fabric) or felt",
    "soft": "gives under a light press as a whole: plush, sponge, a tissue roll (a shell of plastic, metal, "
            "paperboard, wood, styrofoam or moulded pulp is 0)",
    "rough": "a visibly textured surface: mesh, plush, felt, sponge pores, styrofoam beads, moulded pulp, tissue "
             "(printed, glossy or painted surfaces are 0)",
    "ball_shaped": "a sphere or an ovoid",
    "cylindrical": "a round cross-section with straight or slightly tapered sides (cans, tins, tubs, rolls, "
                   "bottles with a neck or cap)",
    "box_shaped": "flat faces meeting at straight edges (boxes, cartons, blocks)",
    "figure": "a toy or figurine shaped like a character, an animal or a vehicle",
    "open_top": "open at the top, its inside visible in the photo",
    "container": "made to hold contents: a bottle, can, tin, tub, box, carton, case, cup or vase",
    "transparent": "a clear body, the background seen through it",
}
_TABLE_COLUMNS = ("object", "class", "attribute", "value", "source", "evidence")
_HEADER = ("object", "slipped", *(f"{f}_biotac_{i}" for f in BTS3_FINGERS for i in range(1, N_ELECTRODES + 1)))


@dataclass(frozen=True)
class Bts3Grasps:
    """Grasps of the BioTacSP Stability Set.

    Attributes
    ----------
    trials : DataFrame with n_grasps rows
        ``grasp_id`` (``<orientation>_<line>``), ``object``, ``slipped`` (0/1), ``orientation``
        (``palm_down`` / ``palm_side``), ``source`` (the file) and ``line`` (its line, header = 1).
    X : ndarray of float64, shape (n_grasps, 3, 24)
        The electrode values of every fingertip (:data:`BTS3_FINGERS`), as published.
    """

    trials: pd.DataFrame
    X: np.ndarray


def read_bts3_csv(path: str | os.PathLike, orientation: str) -> Bts3Grasps:
    """One CSV file of the release.

    Parameters
    ----------
    path : path-like
        ``biotac-palmdown-grasps.csv`` or ``biotac-palmside-grasps.csv`` (or a file in their layout:
        the header ``object,slipped,ff_biotac_1,...,th_biotac_24``, one grasp per line).
    orientation : str
        Recorded in ``trials["orientation"]`` and in the grasp ids.

    Returns
    -------
    Bts3Grasps

    Raises
    ------
    DataFileError
        One line naming the file (and the line when known): another header, a line with another
        number of fields, an empty object name, ``slipped`` other than 0 or 1, an electrode value
        that is not a finite number, no grasp at all.
    """
    path = Path(path)
    try:
        frame = pd.read_csv(path, dtype={"object": str}, keep_default_na=False,
                            na_values={c: [""] for c in _HEADER[1:]})
    except pd.errors.EmptyDataError:
        raise DataFileError(path, "file is empty; expected the header object,slipped,ff_biotac_1,...", line=1) from None
    except pd.errors.ParserError as exc:
        raise DataFileError(path, f"not a readable CSV file in the release's layout ({first_line(exc)})") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise DataFileError(path, f"cannot read it as text ({type(exc).__name__}: {first_line(exc)})") from None
    if tuple(frame.columns) != _HEADER or not frame.index.equals(pd.RangeIndex(len(frame))):
        raise DataFileError(path, "header is not object,slipped,ff_biotac_1..24,mf_biotac_1..24,th_biotac_1..24 "
                            "(the release's layout), or the lines have more fields than it", line=1)
    if frame.empty:
        raise DataFileError(path, "has a header line but no grasps", line=1)
    names = frame["object"].str.strip()
    empty = np.flatnonzero((names == "").to_numpy())
    if empty.size:
        raise DataFileError(path, "object name is empty", line=int(empty[0]) + 2)
    for column in _HEADER[1:]:
        values = pd.to_numeric(frame[column], errors="coerce")
        bad = np.flatnonzero((~np.isfinite(values.to_numpy(dtype=np.float64))))
        if bad.size:
            raise DataFileError(path, f"{column} holds {frame[column].iat[int(bad[0])]!r}, not a number",
                                line=int(bad[0]) + 2)
        frame[column] = values
    slipped = frame["slipped"].to_numpy(dtype=np.float64)
    wrong = np.flatnonzero(~np.isin(slipped, (0.0, 1.0)))
    if wrong.size:
        raise DataFileError(path, f"slipped is {frame['slipped'].iat[int(wrong[0])]!r}; 0 (stable) or 1 (slid)",
                            line=int(wrong[0]) + 2)
    lines = np.arange(2, len(frame) + 2)
    trials = pd.DataFrame({"grasp_id": [f"{orientation}_{n}" for n in lines], "object": names.to_numpy(),
                           "slipped": slipped.astype(np.int64), "orientation": orientation, "source": str(path),
                           "line": lines})
    X = frame[list(_HEADER[2:])].to_numpy(dtype=np.float64).reshape(len(frame), len(BTS3_FINGERS), N_ELECTRODES)
    return Bts3Grasps(trials, X)


def load_bts3(data_dir: str | os.PathLike | None = None) -> Bts3Grasps:
    """Both files of the release from the data home (each verified against its sha256), palm down first.

    Raises
    ------
    DataMissingError
        A file is not in the data home (the message names ``tzsl data fetch bts3``).
    ChecksumError
        A file whose sha256 differs from the registry's.
    DataFileError
        A file that is not in the release's layout (:func:`read_bts3_csv`).
    """
    parts = [read_bts3_csv(fetch(relpath, data_dir), orientation) for orientation, relpath in BTS3_FILES.items()]
    return Bts3Grasps(pd.concat([p.trials for p in parts], ignore_index=True), np.concatenate([p.X for p in parts]))


def read_bts3_attributes(path: str | os.PathLike | None = None) -> MaterialTable:
    """Read and check the class-attribute table (default: the one shipped, :data:`ATTRIBUTE_TABLE`).

    Parameters
    ----------
    path : path-like, optional
        A table in the same format (module docstring).

    Returns
    -------
    MaterialTable
        ``classes``: DataFrame (41, n_attributes) of 0/1 indexed by class, in the photo's panel order;
        ``materials``: object -> its class; ``records``: the table as read.

    Raises
    ------
    DataFileError
        One line naming the file and line: other columns, an object that has no panel in the photo,
        a class other than the object's name, an attribute without a definition, a value other than
        0/1, a source that names neither the object's panel nor its name, an empty evidence, an
        object given twice for one attribute, an object lacking an attribute or missing altogether.
    """
    if path is None:
        with resources.as_file(resources.files("tzsl.datasets").joinpath(ATTRIBUTE_TABLE)) as shipped:
            return read_bts3_attributes(shipped)
    path = Path(path)
    table = read_class_table(path, _TABLE_COLUMNS)
    seen: set[tuple[str, str]] = set()
    for i, row in enumerate(table.itertuples(index=False), start=2):
        obj, cls, attribute, value, source, evidence = (str(v).strip() for v in row)
        if obj not in BTS3_PANELS or cls != obj:
            raise DataFileError(path, f"object {obj!r} (class {cls!r}) has no panel in {OBJECTS_PHOTO}, or its "
                                "class is not its name", line=i)
        if attribute not in BTS3_ATTRIBUTES:
            raise DataFileError(path, f"attribute {attribute!r} has no definition (known: "
                                f"{', '.join(BTS3_ATTRIBUTES)})", line=i)
        if value not in ("0", "1"):
            raise DataFileError(path, f"{obj} {attribute}: value {value!r} is not 0 or 1", line=i)
        r, c = BTS3_PANELS[obj]
        sources = (f"{OBJECTS_PHOTO}, row {r}, column {c}", f"object name '{obj}'")
        if source not in sources or not evidence:
            raise DataFileError(path, f"{obj} {attribute}: source must be {sources[0]!r} or {sources[1]!r} with "
                                f"its evidence; got source {source!r}, evidence {evidence!r}", line=i)
        if (obj, attribute) in seen:
            raise DataFileError(path, f"{obj} is given twice for {attribute!r}", line=i)
        seen.add((obj, attribute))
    missing = [o for o in BTS3_PANELS if o not in set(table["object"].str.strip())]
    if missing:
        raise DataFileError(path, f"object(s) {missing} of {OBJECTS_PHOTO} have no line")
    wide = table.assign(object=table["object"].str.strip(), attribute=table["attribute"].str.strip()).pivot(
        index="object", columns="attribute", values="value")
    lacking = wide.isna().any(axis=1)
    if lacking.any():
        first = wide.index[lacking][0]
        raise DataFileError(path, f"{first} lacks attribute(s) {list(wide.columns[wide.loc[first].isna()])}")
    attributes = [a for a in BTS3_ATTRIBUTES if a in wide.columns]
    classes = wide.loc[list(BTS3_PANELS), attributes].astype(np.int64)
    classes.index = pd.Index(list(BTS3_PANELS), name="class")
    classes.columns.name = None
    return MaterialTable(classes, {o: o for o in BTS3_PANELS}, table)


def convert_bts3(out: str | os.PathLike, data_dir: str | os.PathLike | None = None, *, force: bool = False,
                 table: MaterialTable | None = None) -> Path:
    """Write ``bts3`` as a plain-file dataset folder (module docstring).

    Parameters
    ----------
    out : path-like
        The folder to write (as :func:`~tzsl.datasets.write_plain_dataset`: absent or empty unless ``force``).
    data_dir : path-like, optional
        Data home holding the registered CSVs (``tzsl data fetch bts3``).
    force : bool, default False
        Replace an existing dataset folder.
    table : MaterialTable, optional
        The class-attribute table (default: the shipped one).

    Returns
    -------
    Path
        ``out``.

    Raises
    ------
    DataMissingError
        A registered file missing from the data home (the message names the command that fetches it).
    ChecksumError
        A file whose sha256 differs from the registry's (one line naming it).
    DataFileError
        A file that is not in the release's layout, or a grasp of an object the class table lacks
        (one line naming the file and line).
    """
    table = table or read_bts3_attributes()
    grasps = load_bts3(data_dir)
    trials = grasps.trials
    unknown = np.flatnonzero(~trials["object"].isin(list(table.materials)).to_numpy())
    if unknown.size:
        first = trials.iloc[int(unknown[0])]
        raise DataFileError(first["source"], f"object {first['object']!r} has no row in the class table "
                            f"({ATTRIBUTE_TABLE})", line=int(first["line"]))
    frame = pd.DataFrame({"trial_id": trials["grasp_id"], "class": trials["object"].map(table.materials),
                          "object": trials["object"],
                          "trial_index": trials.groupby("object", sort=False).cumcount().to_numpy() + 1})
    return write_plain_dataset(out, table.classes, frame, sensors=list(BTS3_FINGERS), X=grasps.X,
                               feature_names=ELECTRODES, settings=BTS3_SETTINGS, force=force)
