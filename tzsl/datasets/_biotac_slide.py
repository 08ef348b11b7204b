"""``biotac-slide``: dexrob/BioTac_slide_20_50, 20 materials x 50 BioTac slides, as a plain-file dataset.

The release (https://github.com/dexrob/BioTac_slide_20_50, at commit :data:`BIOTAC_SLIDE_COMMIT`)
holds, per material ``mat<m>`` and slide ``<n>``, a raw CSV ``raw_data/mat<m>/mat<m>_<n>_bio.csv``:
a header ``timestamp`` + the 44 BioTac fields (:data:`BIOTAC_SLIDE_CHANNELS`), then one line per
100 Hz sample, each ending with a comma (an empty 46th field). The registry lists those 1000 files
under ``biotac-slide/raw_data/`` (the repository's own layout below the dataset's folder) with their
sha256 and their ``raw.githubusercontent.com`` link at that commit; nothing else of the release is read.

:func:`convert_biotac_slide` reads every registered CSV from the data home (each verified against
its sha256 by :func:`~tzsl.datasets.fetch`) and writes a plain-file folder with
:func:`~tzsl.datasets.write_plain_dataset`: one trial per slide (``mat<m>_<n>``), object and class =
the material, one sensor ``biotac`` whose signal file holds the 44 channels as published, and a
``dataset.toml`` whose ``[signals]`` gives the features (per-channel mean, standard deviation,
minimum and maximum; no baseline: every slide starts in contact).

The classes and their attributes are the package's ``biotac_slide_attributes.csv``
(:data:`ATTRIBUTE_TABLE`), one line per material and attribute, read from the table of the
release's ``Material_properties.docx`` (sha256 :data:`MATERIAL_DOCUMENT_SHA256` at that commit):
``material,class,attribute,value,source,cell``, where ``cell`` is the document's cell as written
and ``source`` names its row and column. A class is the material's *Name* lower-cased with
underscores. Every value must follow from its cell by the attribute's rule
(:data:`ATTRIBUTE_RULES`: the cells that make it 1 and those that make it 0); a cell neither rule
covers has no justified value and is refused, as is a line whose source names another column.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np
import pandas as pd

from tzsl.datasets._catalog import RegisteredSignals, read_class_table
from tzsl.datasets._plain_write import write_plain_dataset
from tzsl.datasets._registry import registered_files
from tzsl.datasets._signal_files import check_signal_values
from tzsl.exceptions import DataFileError, DataMissingError, first_line

__all__ = [
    "ATTRIBUTE_RULES",
    "ATTRIBUTE_TABLE",
    "BIOTAC_SLIDE",
    "BIOTAC_SLIDE_CHANNELS",
    "BIOTAC_SLIDE_COMMIT",
    "BIOTAC_SLIDE_DIR",
    "BIOTAC_SLIDE_SETTINGS",
    "MATERIAL_DOCUMENT_SHA256",
    "MaterialTable",
    "convert_biotac_slide",
    "read_biotac_slide_attributes",
    "read_biotac_slide_csv",
]

#: The dataset's name (built-in dataset and registry folder).
BIOTAC_SLIDE = "biotac-slide"
#: Registry prefix of the raw CSV files.
BIOTAC_SLIDE_DIR = f"{BIOTAC_SLIDE}/raw_data/"
#: The commit of https://github.com/dexrob/BioTac_slide_20_50 the registry pins.
BIOTAC_SLIDE_COMMIT = "c19638b040791b7b32f2fcf12eee315ca901f80a"
#: The 44 data fields of a ``_bio.csv`` header, in file order (after ``timestamp``).
BIOTAC_SLIDE_CHANNELS: tuple[str, ...] = ("tdc", "tac", "pdc", *(f"pac{i}" for i in range(1, 23)),
                                          *(f"ele{i}" for i in range(1, 20)))
_HEADER = ("timestamp", *BIOTAC_SLIDE_CHANNELS)
#: The sensor name of the written dataset (one BioTac).
SENSOR = "biotac"
#: ``dataset.toml`` of the written folder (the features: per-channel statistics over the slide).
BIOTAC_SLIDE_SETTINGS: dict = {
    "name": BIOTAC_SLIDE,
    "classes": {"allow_identical_rows": True},
    "signals": {"channels": list(BIOTAC_SLIDE_CHANNELS), "baseline_rows": 0,
                "statistics": ["mean", "std", "min", "max"]},
}
#: The class-attribute table shipped in this package.
ATTRIBUTE_TABLE = "biotac_slide_attributes.csv"
#: The release's material property document the table was read from.
MATERIAL_DOCUMENT = "Material_properties.docx"
#: Its sha256 at :data:`BIOTAC_SLIDE_COMMIT`.
MATERIAL_DOCUMENT_SHA256 = "d0ec76dee34c0b7c162d1e60211880880d6660c9a89143160b4afb5a7328cc88"
#: Attribute -> (the document's column it is read from, cells meaning 1, cells meaning 0); cells
#: compared lower-cased. A cell in neither set gives no justified value.
ATTRIBUTE_RULES: dict[str, tuple[str, frozenset[str], frozenset[str]]] = {
    "thick": ("Thickness", frozenset({"thick"}), frozenset({"thin"})),
    "rough": ("Roughness", frozenset({"rough", "rough but soft"}), frozenset({"smooth", "middle rough"})),
    "not_smooth": ("Roughness", frozenset({"rough", "rough but soft", "middle rough"}), frozenset({"smooth"})),
}
_TABLE_COLUMNS = ("material", "class", "attribute", "value", "source", "cell")
_SLIDE_FILE = re.compile(r"mat(\d+)/mat(\d+)_(\d+)_bio\.csv")


def read_biotac_slide_csv(path: str | os.PathLike) -> np.ndarray:
    """One raw ``_bio.csv`` file of the release: the 44 channels of every sample.

    Parameters
    ----------
    path : path-like
        A ``mat<m>_<n>_bio.csv`` file: the header ``timestamp,tdc,tac,pdc,pac1,...,pac22,ele1,...,ele19``,
        then one line per sample (45 fields, or 46 with an empty last one: the release ends every
        line with a comma).

    Returns
    -------
    ndarray of float64, shape (n_samples, 44)
        Columns in :data:`BIOTAC_SLIDE_CHANNELS` order, as published (the timestamps are checked, not kept).

    Raises
    ------
    DataFileError
        One line naming the file (and the line when known): another header, a line with more fields,
        a value after the last channel, a cell that is not a number, an empty or missing value,
        fewer than 2 samples, timestamps that do not increase.
    """
    path = Path(path)
    try:
        with open(path, encoding="utf-8") as fh:
            header = fh.readline().rstrip("\r\n")
    except (OSError, UnicodeDecodeError) as exc:
        raise DataFileError(path, f"cannot read it as text ({type(exc).__name__}: {first_line(exc)})") from None
    if tuple(header.split(",")) != _HEADER:
        raise DataFileError(path, "header is not timestamp,tdc,tac,pdc,pac1..pac22,ele1..ele19 "
                            f"(the release's _bio.csv header); got {header[:80]!r}", line=1)
    try:
        frame = pd.read_csv(path, header=None, skiprows=1, names=[*_HEADER, "_end"], dtype={"_end": str},
                            skip_blank_lines=False)
    except pd.errors.ParserError as exc:
        match = re.search(r"Expected \d+ fields in line (\d+), saw (\d+)", str(exc))
        if match is None:
            raise DataFileError(path, f"not a readable CSV file ({first_line(exc)})") from None
        raise DataFileError(path, f"a line has {match.group(2)} fields; the header has 45 (46 with the trailing "
                            "comma)", line=int(match.group(1))) from None
    except pd.errors.EmptyDataError:
        frame = pd.DataFrame()
    if frame.empty:
        raise DataFileError(path, "has a header line but no samples", line=1)
    extra = np.flatnonzero(frame["_end"].notna().to_numpy())
    if extra.size:
        raise DataFileError(path, f"a value ({frame['_end'].iat[int(extra[0])]!r}) follows the last channel (ele19)",
                            line=int(extra[0]) + 2)
    for column in _HEADER:
        if not pd.api.types.is_numeric_dtype(frame[column]):
            numbers = pd.to_numeric(frame[column], errors="coerce")
            bad = np.flatnonzero((numbers.isna() & frame[column].notna()).to_numpy())
            raise DataFileError(path, f"{column} holds {frame[column].iat[int(bad[0])]!r}, not a number",
                                line=int(bad[0]) + 2)
    values = frame[list(_HEADER)].to_numpy(dtype=np.float64)
    problems = check_signal_values(str(path), _HEADER, values, csv_file=True, min_rows=2)
    if problems:
        raise DataFileError(path, problems[0].message, line=problems[0].line)
    backwards = np.flatnonzero(np.diff(values[:, 0]) <= 0)
    if backwards.size:
        raise DataFileError(path, "timestamp does not increase (the samples are not one recording in order)",
                            line=int(backwards[0]) + 3)
    return values[:, 1:]


@dataclass(frozen=True)
class MaterialTable:
    """The class-attribute table of ``biotac-slide``.

    Attributes
    ----------
    classes : DataFrame (20, n_attributes) of int64 0/1
        Indexed by class, in material order (``mat1`` first).
    materials : dict
        Material (``"mat1"``) -> its class (``"carpet_net"``).
    records : DataFrame
        The table as read: one row per material and attribute with its ``source`` and ``cell``.
    """

    classes: pd.DataFrame
    materials: dict[str, str]
    records: pd.DataFrame


def read_biotac_slide_attributes(path: str | os.PathLike | None = None) -> MaterialTable:
    """Read and check the class-attribute table (default: the one shipped, :data:`ATTRIBUTE_TABLE`).

    Parameters
    ----------
    path : path-like, optional
        A table in the same format (module docstring).

    Returns
    -------
    MaterialTable

    Raises
    ------
    DataFileError
        One line naming the file and line: missing columns, a value other than 0/1, an empty source
        or cell, a source that does not name the material's row and the rule's column, a value that
        does not follow from its cell, a cell no rule covers, an attribute without a rule, a material
        named twice for one attribute or with two classes, a material lacking an attribute.
    """
    if path is None:
        with resources.as_file(resources.files("tzsl.datasets").joinpath(ATTRIBUTE_TABLE)) as shipped:
            return read_biotac_slide_attributes(shipped)
    path = Path(path)
    table = read_class_table(path, _TABLE_COLUMNS)
    materials: dict[str, str] = {}
    seen: set[tuple[str, str]] = set()
    for i, row in enumerate(table.itertuples(index=False), start=2):
        material, cls, attribute, value, source, cell = (str(v).strip() for v in row)
        if attribute not in ATTRIBUTE_RULES:
            raise DataFileError(path, f"attribute {attribute!r} has no rule (known: {', '.join(ATTRIBUTE_RULES)})",
                                line=i)
        column, ones, zeros = ATTRIBUTE_RULES[attribute]
        expected = f"{MATERIAL_DOCUMENT} table, row {material}, column {column}"
        if not cell or source != expected:
            raise DataFileError(path, f"{material} {attribute}: source must be {expected!r} and cell the "
                                f"document's cell; got source {source!r}, cell {cell!r}", line=i)
        justified = 1 if cell.lower() in ones else 0 if cell.lower() in zeros else None
        if justified is None:
            raise DataFileError(path, f"{material} {attribute}: cell {cell!r} of column {column} justifies no "
                                "value (the rule knows " + ", ".join(sorted(ones | zeros)) + ")", line=i)
        if value != str(justified):
            raise DataFileError(path, f"{material} {attribute}: value {value!r} does not follow from cell "
                                f"{cell!r} (the rule gives {justified})", line=i)
        if materials.setdefault(material, cls) != cls or (material, attribute) in seen:
            raise DataFileError(path, f"{material} is given twice for {attribute!r} or with two classes", line=i)
        seen.add((material, attribute))
    wide = table.pivot(index="material", columns="attribute", values="value")
    lacking = wide.isna().any(axis=1)
    if lacking.any():
        raise DataFileError(path, f"{wide.index[lacking][0]} lacks attribute(s) "
                            f"{list(wide.columns[wide.loc[wide.index[lacking][0]].isna()])}")
    order = sorted(materials, key=lambda m: int(m.removeprefix("mat")))
    attributes = list(dict.fromkeys(table["attribute"]))
    classes = wide.loc[order, attributes].astype(np.int64)
    classes.index = pd.Index([materials[m] for m in order], name="class")
    classes.columns.name = None
    return MaterialTable(classes, {m: materials[m] for m in order}, table)


def slide_files() -> list[tuple[str, int, str]]:
    """The registered slides: (material, slide, registered path), in material then slide order."""
    slides = []
    for relpath in registered_files(BIOTAC_SLIDE_DIR):
        match = _SLIDE_FILE.fullmatch(relpath.removeprefix(BIOTAC_SLIDE_DIR))
        if match is None or match.group(1) != match.group(2):
            raise DataFileError(None, f"registry entry {relpath!r} is not named "
                                f"{BIOTAC_SLIDE_DIR}mat<m>/mat<m>_<n>_bio.csv")
        slides.append((f"mat{match.group(1)}", int(match.group(3)), relpath))
    return sorted(slides, key=lambda s: (int(s[0].removeprefix("mat")), s[1]))


def convert_biotac_slide(out: str | os.PathLike, data_dir: str | os.PathLike | None = None, *, force: bool = False,
                         signal_format: str = "npz", table: MaterialTable | None = None) -> Path:
    """Write ``biotac-slide`` as a plain-file dataset folder (module docstring).

    Parameters
    ----------
    out : path-like
        The folder to write (as :func:`~tzsl.datasets.write_plain_dataset`: absent or empty unless ``force``).
    data_dir : path-like, optional
        Data home holding the registered CSVs (``tzsl data fetch biotac-slide``).
    force : bool, default False
        Replace an existing dataset folder.
    signal_format : {"npz", "csv"}, default "npz"
    table : MaterialTable, optional
        The class-attribute table (default: the shipped one).

    Returns
    -------
    Path
        ``out``.

    Raises
    ------
    DataMissingError
        No slide registered, or a registered file missing from the data home (the message names the
        command that fetches it).
    ChecksumError
        A file whose sha256 differs from the registry's (one line naming it).
    DataFileError
        A file that is not a readable ``_bio.csv`` (one line naming it), or a material without a row
        in the class table.
    """
    table = table or read_biotac_slide_attributes()
    slides = slide_files()
    if not slides:
        raise DataMissingError(None, f"no {BIOTAC_SLIDE} file is registered (registry prefix {BIOTAC_SLIDE_DIR})")
    unknown = sorted({m for m, _, _ in slides} - set(table.materials), key=lambda m: int(m.removeprefix("mat")))
    if unknown:
        raise DataFileError(None, f"{BIOTAC_SLIDE}: material(s) {unknown} have slides but no row in the class table")
    trials = pd.DataFrame({
        "trial_id": [f"{m}_{n}" for m, n, _ in slides],
        "class": [table.materials[m] for m, _, _ in slides],
        "object": [table.materials[m] for m, _, _ in slides],
        "trial_index": [n for _, n, _ in slides],
    })
    signals = RegisteredSignals([relpath for _, _, relpath in slides], data_dir, read_biotac_slide_csv)
    return write_plain_dataset(out, table.classes, trials, sensors=[SENSOR], signals=signals,
                               channels=BIOTAC_SLIDE_CHANNELS, settings=BIOTAC_SLIDE_SETTINGS,
                               signal_format=signal_format, force=force)
