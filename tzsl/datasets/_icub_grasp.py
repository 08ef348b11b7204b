"""``icub-grasp``: the iCub Grasp Dataset (clear-nus/icub_grasp_dataset), 9 objects x 20 grasps, as plain files.

The release (https://github.com/clear-nus/icub_grasp_dataset at commit :data:`ICUB_GRASP_COMMIT`) holds
one text file per grasp of the iCub humanoid's hand, ``iCubGraspDataset/<object>_<n>.txt``. Its
``README.txt`` describes the layout: a first line ``-10000`` (to be ignored), then one block of 7
lines per time slice: the 9 encoder values of the hand's joints 7-15, ``max(255 - tactile reading)``
of each of the five fingers, and the 12 tactile readings of the thumb, index, middle, ring and
little finger (one line each). The README describes nine objects grasped 20 times each and a
baseline "no object"; it says the extra "full-coke" object's data "should not be considered
reliable". The registry lists the files ``<object>_1.txt`` ... ``<object>_20.txt`` of the nine
objects (:data:`ICUB_GRASP_OBJECTS`) under ``icub-grasp/iCubGraspDataset/`` with their sha256 and
their ``raw.githubusercontent.com`` link at that commit (``tzsl data fetch icub-grasp``); the
``none_*`` and ``full_coke_*`` files, and the 21st ``empty_coke`` file, are not fetched.

:func:`convert_icub_grasp` writes the grasps as a plain-file folder with
:func:`~tzsl.datasets.write_plain_dataset`: one trial per grasp (``<object>_<n>``), object and
class = the object's file name, one sensor ``hand`` whose signal file holds the 74 values of every
time slice as published (:data:`ICUB_GRASP_CHANNELS`), and a ``dataset.toml`` whose ``[signals]``
gives the features (per-channel mean, standard deviation, minimum and maximum over the grasp).

The classes and their attributes are the package's ``icub_grasp_attributes.csv``
(:data:`ATTRIBUTE_TABLE`): ``object,class,attribute,value,source,evidence``, one line per object and
attribute. The release describes its objects only in the README's list (:data:`ICUB_GRASP_OBJECTS`
gives each file name's phrase: "plastic bottle (full)", ..., "a hardcover book"), so the source of
every value is that phrase (``README.txt: '<phrase>'``) and its evidence starts with the quoted
words of the phrase that decide it. An attribute (:data:`ICUB_GRASP_ATTRIBUTES`, each with its
definition) that some object's phrase cannot decide is left out: plastic (the lotion bottle's
material is not stated), the fill level (not stated for the lotion), softness beyond the toys.
"""

from __future__ import annotations

import os
from importlib import resources
from pathlib import Path

import numpy as np
import pandas as pd

from tzsl.datasets._biotac_slide import MaterialTable
from tzsl.datasets._catalog import RegisteredSignals, read_class_table
from tzsl.datasets._plain_write import write_plain_dataset
from tzsl.datasets._registry import registered_files
from tzsl.exceptions import DataFileError, DataMissingError

__all__ = ["ATTRIBUTE_TABLE", "ICUB_GRASP", "ICUB_GRASP_ATTRIBUTES", "ICUB_GRASP_CHANNELS", "ICUB_GRASP_COMMIT",
           "ICUB_GRASP_DIR", "ICUB_GRASP_OBJECTS", "ICUB_GRASP_SETTINGS", "N_GRASPS", "convert_icub_grasp",
           "grasp_files", "read_icub_grasp_attributes", "read_icub_grasp_trial"]

#: The dataset's name (built-in dataset and registry folder).
ICUB_GRASP = "icub-grasp"
#: Registry prefix of the grasp files.
ICUB_GRASP_DIR = f"{ICUB_GRASP}/iCubGraspDataset/"
#: The commit of https://github.com/clear-nus/icub_grasp_dataset the registry pins.
ICUB_GRASP_COMMIT = "87dceecaa2f8056025f2ad42b55cb5f46fb77229"
#: Grasps per object the README states ("grasped 20 times"): files ``_1`` to ``_20``.
N_GRASPS = 20
#: Object (file name) -> the README's phrase for it, in the README's order.
ICUB_GRASP_OBJECTS: dict[str, str] = {
    "full_vitamin_water": "plastic bottle (full)",
    "med_vitamin_water": "plastic bottle (half-full)",
    "empty_vitamin_water": "plastic bottle (empty)",
    "med_coke": "soda can (half-full)",
    "empty_coke": "soda can (empty)",
    "blue_bear": "teddy bear",
    "monkey_toy": "monkey soft-toy",
    "lotion": "a bottle of lotion",
    "book": "a hardcover book",
}
#: Attribute -> its definition (what makes it 1; every other object is 0).
ICUB_GRASP_ATTRIBUTES: dict[str, str] = {
    "container": "made to hold contents: a bottle or a can",
    "bottle": "a bottle",
    "can": "a drinks can",
    "stuffed_toy": "a soft toy: a teddy bear or a soft-toy",
    "book": "a book",
    "has_contents": "a container holding contents: full, half-full, or 'a bottle of' something (empty: 0)",
}
_FINGERS = ("thumb", "index", "middle", "ring", "little")
#: The 74 values of a time slice, in file order: encoders of joints 7-15, the per-finger maximum of
#: ``255 - reading`` (``max_1`` ... ``max_5``, the README's five fingers), 12 readings per finger.
ICUB_GRASP_CHANNELS: tuple[str, ...] = (*(f"joint_{j}" for j in range(7, 16)), *(f"max_{i}" for i in range(1, 6)),
                                        *(f"{f}_{k}" for f in _FINGERS for k in range(1, 13)))
#: Values on each line of a time slice's block of 7 lines.
_BLOCK = (9, 5, 12, 12, 12, 12, 12)
#: The sensor name of the written dataset (the hand: encoders and fingertips).
SENSOR = "hand"
#: ``dataset.toml`` of the written folder (classes may share a row; features: per-channel statistics).
ICUB_GRASP_SETTINGS: dict = {
    "name": ICUB_GRASP,
    "classes": {"allow_identical_rows": True},
    "signals": {"channels": list(ICUB_GRASP_CHANNELS), "baseline_rows": 0,
                "statistics": ["mean", "std", "min", "max"]},
}
#: The class-attribute table shipped in this package.
ATTRIBUTE_TABLE = "icub_grasp_attributes.csv"
_TABLE_COLUMNS = ("object", "class", "attribute", "value", "source", "evidence")


def read_icub_grasp_trial(path: str | os.PathLike) -> np.ndarray:
    """One grasp file of the release: the 74 values of every time slice.

    Parameters
    ----------
    path : path-like
        ``<object>_<n>.txt``: a first line ``-10000``, then blocks of 7 whitespace-separated lines
        holding 9, 5, 12, 12, 12, 12 and 12 numbers (module docstring); LF or CRLF line ends.

    Returns
    -------
    ndarray of float64, shape (n_slices, 74)
        One row per time slice, columns :data:`ICUB_GRASP_CHANNELS` (encoder values and raw
        tactile readings, as published).

    Raises
    ------
    DataFileError
        One line naming the file and line: not text, another first line, a block cut short, a line
        with another number of values, a value that is not a finite number, fewer than 2 slices.
    """
    path = Path(path)
    try:
        text = path.read_bytes().decode("ascii")
    except OSError as exc:
        raise DataFileError(path, f"cannot read it ({type(exc).__name__})") from None
    except UnicodeDecodeError as exc:
        raise DataFileError(path, f"not a text file of numbers (byte {exc.start} is not ASCII)") from None
    lines = text.splitlines()
    while lines and not lines[-1].strip():
        lines.pop()
    if not lines or lines[0].strip() != "-10000":
        raise DataFileError(path, "first line is not -10000 (the release's grasp file layout)", line=1)
    body = lines[1:]
    if len(body) % len(_BLOCK):
        start = 2 + len(body) - len(body) % len(_BLOCK)
        raise DataFileError(path, f"the time slice starting here has {len(body) % len(_BLOCK)} of its "
                            f"{len(_BLOCK)} lines", line=start)
    n_slices = len(body) // len(_BLOCK)
    if n_slices < 2:
        raise DataFileError(path, f"holds {n_slices} time slice(s); at least 2 needed", line=1)
    values = np.empty((n_slices, len(ICUB_GRASP_CHANNELS)), dtype=np.float64)
    for i, line in enumerate(body):
        slice_, k = divmod(i, len(_BLOCK))
        fields = line.split()
        if len(fields) != _BLOCK[k]:
            raise DataFileError(path, f"line {k + 1} of a time slice holds {len(fields)} values; "
                                f"expected {_BLOCK[k]}", line=i + 2)
        try:
            numbers = [float(f) for f in fields]
        except ValueError:
            bad = next(f for f in fields if not _is_number(f))
            raise DataFileError(path, f"{bad!r} is not a number", line=i + 2) from None
        if not np.isfinite(numbers).all():
            raise DataFileError(path, "holds a value that is not finite", line=i + 2)
        start = sum(_BLOCK[:k])
        values[slice_, start:start + _BLOCK[k]] = numbers
    return values


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def read_icub_grasp_attributes(path: str | os.PathLike | None = None) -> MaterialTable:
    """Read and check the class-attribute table (default: the one shipped, :data:`ATTRIBUTE_TABLE`).

    Parameters
    ----------
    path : path-like, optional
        A table in the same format (module docstring).

    Returns
    -------
    MaterialTable
        ``classes``: DataFrame (9, n_attributes) of int64 0/1 indexed by class, in the README's
        order; ``materials``: object -> its class (its name); ``records``: the table as read.

    Raises
    ------
    DataFileError
        One line naming the file and line: other columns, an object the README does not describe,
        a class other than the object's name, an attribute without a definition, a value other
        than 0/1, a source other than the object's README phrase, an evidence that does not start
        with quoted words of that phrase, an object given twice for one attribute, an object lacking
        an attribute or missing altogether.
    """
    if path is None:
        with resources.as_file(resources.files("tzsl.datasets").joinpath(ATTRIBUTE_TABLE)) as shipped:
            return read_icub_grasp_attributes(shipped)
    path = Path(path)
    table = read_class_table(path, _TABLE_COLUMNS)
    table = table.apply(lambda column: column.str.strip())
    seen: set[tuple[str, str]] = set()
    for i, (obj, cls, attribute, value, source, evidence) in enumerate(table.itertuples(index=False), start=2):
        if obj not in ICUB_GRASP_OBJECTS or cls != obj:
            raise DataFileError(path, f"object {obj!r} (class {cls!r}) is not one the README describes, or its "
                                "class is not its name", line=i)
        if attribute not in ICUB_GRASP_ATTRIBUTES:
            raise DataFileError(path, f"attribute {attribute!r} has no definition (known: "
                                f"{', '.join(ICUB_GRASP_ATTRIBUTES)})", line=i)
        if value not in ("0", "1"):
            raise DataFileError(path, f"{obj} {attribute}: value {value!r} is not 0 or 1", line=i)
        phrase = ICUB_GRASP_OBJECTS[obj]
        expected = f"README.txt: '{phrase}'"
        quoted = evidence.split("'")
        if source != expected or len(quoted) < 3 or quoted[0] or not quoted[1] or quoted[1] not in phrase:
            raise DataFileError(path, f"{obj} {attribute}: source must be {expected!r} and the evidence must "
                                f"start with quoted words of it; got source {source!r}, evidence {evidence!r}",
                                line=i)
        if (obj, attribute) in seen:
            raise DataFileError(path, f"{obj} is given twice for {attribute!r}", line=i)
        seen.add((obj, attribute))
    missing = [o for o in ICUB_GRASP_OBJECTS if o not in set(table["object"])]
    if missing:
        raise DataFileError(path, f"object(s) {missing} of the README have no line")
    wide = table.pivot(index="object", columns="attribute", values="value")
    lacking = wide.isna().any(axis=1)
    if lacking.any():
        first = wide.index[lacking][0]
        raise DataFileError(path, f"{first} lacks attribute(s) {list(wide.columns[wide.loc[first].isna()])}")
    attributes = [a for a in ICUB_GRASP_ATTRIBUTES if a in wide.columns]
    classes = wide.loc[list(ICUB_GRASP_OBJECTS), attributes].astype(np.int64)
    classes.index = pd.Index(list(ICUB_GRASP_OBJECTS), name="class")
    classes.columns.name = None
    return MaterialTable(classes, {o: o for o in ICUB_GRASP_OBJECTS}, table)


def grasp_files() -> list[tuple[str, int, str]]:
    """The registered grasps: (object, grasp number, registered path), in the README's object order.

    Raises
    ------
    DataFileError
        A registry entry under :data:`ICUB_GRASP_DIR` not named ``<object>_<n>.txt`` for an object
        of :data:`ICUB_GRASP_OBJECTS` and ``n`` in 1..20.
    """
    grasps = []
    for relpath in registered_files(ICUB_GRASP_DIR):
        stem, _, n = relpath.removeprefix(ICUB_GRASP_DIR).removesuffix(".txt").rpartition("_")
        if stem not in ICUB_GRASP_OBJECTS or not n.isdigit() or not 1 <= int(n) <= N_GRASPS:
            raise DataFileError(None, f"registry entry {relpath!r} is not named {ICUB_GRASP_DIR}<object>_<n>.txt "
                                f"(object one of {', '.join(ICUB_GRASP_OBJECTS)}; n 1..{N_GRASPS})")
        grasps.append((stem, int(n), relpath))
    order = list(ICUB_GRASP_OBJECTS)
    return sorted(grasps, key=lambda g: (order.index(g[0]), g[1]))


def convert_icub_grasp(out: str | os.PathLike, data_dir: str | os.PathLike | None = None, *, force: bool = False,
                       signal_format: str = "npz", table: MaterialTable | None = None) -> Path:
    """Write ``icub-grasp`` as a plain-file dataset folder (module docstring).

    Parameters
    ----------
    out : path-like
        The folder to write (as :func:`~tzsl.datasets.write_plain_dataset`: absent or empty unless ``force``).
    data_dir : path-like, optional
        Data home holding the registered grasp files (``tzsl data fetch icub-grasp``).
    force : bool, default False
        Replace an existing dataset folder.
    signal_format : {"npz", "csv"}, default "npz"
    table : MaterialTable, optional
        The class-attribute table (default: the shipped one).

    Returns
    -------
    Path
        ``out``: 180 trials (9 classes x 20 grasps), one sensor ``hand`` of 74 channels.

    Raises
    ------
    DataMissingError
        No grasp registered, or a registered file missing from the data home (the message names the
        command that fetches it).
    ChecksumError
        A file whose sha256 differs from the registry's (one line naming it).
    DataFileError
        A grasp file not in the release's layout (one line naming the file and line).
    """
    table = table or read_icub_grasp_attributes()
    grasps = grasp_files()
    if not grasps:
        raise DataMissingError(None, f"no {ICUB_GRASP} file is registered (registry prefix {ICUB_GRASP_DIR})")
    trials = pd.DataFrame({
        "trial_id": [f"{o}_{n}" for o, n, _ in grasps],
        "class": [table.materials[o] for o, _, _ in grasps],
        "object": [o for o, _, _ in grasps],
        "trial_index": [n for _, n, _ in grasps],
    })
    signals = RegisteredSignals([relpath for _, _, relpath in grasps], data_dir, read_icub_grasp_trial)
    return write_plain_dataset(out, table.classes, trials, sensors=[SENSOR], signals=signals,
                               channels=ICUB_GRASP_CHANNELS, settings=ICUB_GRASP_SETTINGS,
                               signal_format=signal_format, force=force)
