"""``physiclear``'s class-attribute table and object split, read from the release's ``utils/constants.py``.

PhysiCLeAR (clear-nus/octopi at commit :data:`PHYSICLEAR_COMMIT`) annotates its objects in
``utils/constants.py``: three ranks per object, each 0, 1 or 2 (``HARDNESS_RANK`` with ``HARDNESS_MAP``
0 soft, 1 moderately hard, 2 hard; ``ROUGHNESS_RANK`` with ``ROUGHNESS_MAP`` 0 smooth, 1 slightly rough,
2 rough; ``TEXTURE_RANK`` with ``TEXTURE_MAP`` 0 no bumps, 1 small bumps, 2 big bumps: the paper's
*bumpiness*), a material word per object (``MATERIALS``) and the object split of the paper
(``TRAIN_OBJECTS``, ``VAL_OBJECTS``, ``TEST_OBJECTS``). The file is Python; it is read as a syntax tree
(:func:`read_octopi_constants`, literals only, never run), so every value keeps its line.

The shipped table ``physiclear_attributes.csv`` (:data:`ATTRIBUTE_TABLE`) has one line per object and
property: ``object,property,value,source`` with ``property`` one of ``hardness``, ``roughness``,
``bumpiness`` (value the rank) or ``material`` (value the word), and ``source`` =
``utils/constants.py, <VARIABLE>, line <n>`` (the line of the object's key). ``object`` is the video
stem of the release's ``dataset/<object>_<k>.mov`` (the constants' key without ``physiclear_``). An
object is in the table when it has a video and all three ranks; the others stay out
(:func:`physiclear_records` says which).

Encodings of the ranks (:func:`read_physiclear_attributes`, ``encoding``):

``"levels"``
    one 0/1 attribute per property and level (``hardness_soft``, ``hardness_moderately_hard``,
    ``hardness_hard``, ...): 9 attributes, exactly one per property is 1.
``"thresholds"``
    ordinal thresholds: ``<property>_above_<level>`` is 1 when the rank is above that level
    (``hardness_above_soft`` = rank >= 1, ``hardness_above_moderately_hard`` = rank 2): 6 attributes.

Materials are one-hot (``material_<word>``), for the materials of at least ``min_material_objects``
(3) objects: an attribute with fewer positive objects can never keep the 3 positive training objects
the study's split rule asks of an attribute (``[splits] min_train_positives``), so it would be left out
of every split anyway.
"""

from __future__ import annotations

import ast
import csv
import io
import os
import re
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np
import pandas as pd

from tzsl.datasets._catalog import read_class_table
from tzsl.exceptions import ConfigError, DataFileError, first_line

__all__ = ["ATTRIBUTE_TABLE", "CONSTANTS_FILE", "ENCODINGS", "MIN_MATERIAL_OBJECTS", "PHYSICLEAR",
           "PHYSICLEAR_COMMIT", "PROPERTIES", "SPLIT_FILE", "SPLIT_VARIABLES", "OctopiConstants",
           "PhysiclearTable", "physiclear_distinct_objects", "physiclear_kept_attributes", "physiclear_records",
           "physiclear_split_file", "physiclear_split_roles", "physiclear_splits_from_constants",
           "physiclear_split_text", "read_octopi_constants", "read_physiclear_attributes",
           "write_physiclear_attributes"]

#: The dataset's registry folder.
PHYSICLEAR = "physiclear"
#: The commit of https://github.com/clear-nus/octopi the registry pins.
PHYSICLEAR_COMMIT = "b7f0b0b56a5be950a10c46aa40277dfd51050eab"
#: The release's annotation file (registered path).
CONSTANTS_FILE = f"{PHYSICLEAR}/utils/constants.py"
#: The class-attribute table and the object split shipped in this package.
ATTRIBUTE_TABLE = "physiclear_attributes.csv"
SPLIT_FILE = "physiclear_splits.csv"
#: Property -> (its variable in constants.py, its level names by rank as the ``*_MAP`` variable names them).
PROPERTIES: dict[str, tuple[str, tuple[str, ...]]] = {
    "hardness": ("HARDNESS_RANK", ("soft", "moderately_hard", "hard")),
    "roughness": ("ROUGHNESS_RANK", ("smooth", "slightly_rough", "rough")),
    "bumpiness": ("TEXTURE_RANK", ("no_bumps", "small_bumps", "big_bumps")),
}
MATERIALS_VARIABLE = "MATERIALS"
#: The paper's object split: role -> its variable in constants.py.
SPLIT_VARIABLES: dict[str, str] = {"train": "TRAIN_OBJECTS", "validation": "VAL_OBJECTS", "test": "TEST_OBJECTS"}
ENCODINGS = ("levels", "thresholds")
MIN_MATERIAL_OBJECTS = 3
#: The study's default rule: an attribute is kept in a split with at least this many positive training objects.
MIN_TRAIN_POSITIVES = 3
#: The prefix of every object key in constants.py.
KEY_PREFIX = "physiclear_"
_SOURCE_FILE = "utils/constants.py"
_COLUMNS = ("object", "property", "value", "source")
_SOURCE = re.compile(r"utils/constants\.py, ([A-Z_]+), line ([1-9][0-9]*)")


@dataclass(frozen=True)
class OctopiConstants:
    """The literals of ``utils/constants.py`` the table and split are read from.

    Attributes
    ----------
    dicts : dict
        Variable (``HARDNESS_RANK``, ``MATERIALS``, ...) -> {key: (value, line of the key)}.
    lists : dict
        Variable (``TRAIN_OBJECTS``, ...) -> [(object key, its line)].
    """

    dicts: dict[str, dict[str, tuple[object, int]]]
    lists: dict[str, list[tuple[str, int]]]


def read_octopi_constants(path: str | os.PathLike) -> OctopiConstants:
    """Read the rank, material and split literals of the release's ``utils/constants.py`` (never run).

    Raises
    ------
    DataFileError
        One line naming the file: not Python, a variable missing or not a literal dict / list of strings.
    """
    path = Path(path)
    try:
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    except (OSError, UnicodeDecodeError, SyntaxError, ValueError) as exc:
        raise DataFileError(path, f"cannot read it as Python source ({type(exc).__name__}: {first_line(exc)})") \
            from None
    wanted_dicts = {v for v, _ in PROPERTIES.values()} | {MATERIALS_VARIABLE}
    dicts: dict[str, dict[str, tuple[object, int]]] = {}
    lists: dict[str, list[tuple[str, int]]] = {}
    for node in tree.body:
        if not (isinstance(node, ast.Assign) and len(node.targets) == 1 and isinstance(node.targets[0], ast.Name)):
            continue
        name = node.targets[0].id
        if name in wanted_dicts:
            if not isinstance(node.value, ast.Dict):
                raise DataFileError(path, f"{name} is not a literal dict", line=node.lineno)
            entries: dict[str, tuple[object, int]] = {}
            for key, value in zip(node.value.keys, node.value.values, strict=True):
                if not (isinstance(key, ast.Constant) and isinstance(key.value, str)
                        and isinstance(value, ast.Constant)):
                    raise DataFileError(path, f"{name} holds an entry that is not a literal", line=value.lineno)
                entries[key.value] = (value.value, key.lineno)  # a key given twice: the last wins, as in Python
            dicts[name] = entries
        elif name in SPLIT_VARIABLES.values():
            if not isinstance(node.value, ast.List) or not all(
                    isinstance(e, ast.Constant) and isinstance(e.value, str) for e in node.value.elts):
                raise DataFileError(path, f"{name} is not a literal list of strings", line=node.lineno)
            lists[name] = [(str(e.value), e.lineno) for e in node.value.elts if isinstance(e, ast.Constant)]
    missing = sorted((wanted_dicts - set(dicts)) | (set(SPLIT_VARIABLES.values()) - set(lists)))
    if missing:
        raise DataFileError(path, f"no literal assignment of {', '.join(missing)}")
    return OctopiConstants(dicts, lists)


def physiclear_records(constants: OctopiConstants, objects: list[str]) -> tuple[pd.DataFrame, list[str]]:
    """The table's lines for the objects with videos (``objects``: video stems) and all three ranks.

    Returns
    -------
    records : DataFrame
        ``object,property,value,source``, objects in the order given, properties in
        :data:`PROPERTIES` order then ``material``.
    left_out : list of str
        The objects (of ``objects``) without all three ranks or without a material.
    """
    rows, left_out = [], []
    for obj in objects:
        key = KEY_PREFIX + obj
        entries = [(p, *constants.dicts[v].get(key, (None, 0)), v) for p, (v, _) in PROPERTIES.items()]
        entries.append(("material", *constants.dicts[MATERIALS_VARIABLE].get(key, (None, 0)), MATERIALS_VARIABLE))
        if any(value is None for _, value, _, _ in entries):
            left_out.append(obj)
            continue
        rows += [(obj, p, str(value), f"{_SOURCE_FILE}, {v}, line {line}") for p, value, line, v in entries]
    return pd.DataFrame(rows, columns=list(_COLUMNS)), left_out


def write_physiclear_attributes(constants: OctopiConstants, objects: list[str], out: str | os.PathLike) -> Path:
    """Write the table (:func:`physiclear_records`) to ``out`` as CSV (how the shipped one was made)."""
    records, _ = physiclear_records(constants, objects)
    out = Path(out)
    records.to_csv(out, index=False, lineterminator="\n")
    return out


@dataclass(frozen=True)
class PhysiclearTable:
    """The class-attribute table of ``physiclear``.

    Attributes
    ----------
    classes : DataFrame (n_objects, n_attributes) of int64 0/1
        Indexed by class (= object), in the table's order.
    ranks : DataFrame (n_objects, 3) of int64
        The ranks 0-2 of ``hardness``, ``roughness``, ``bumpiness``.
    materials : Series (n_objects,) of str
        The material word of every object.
    records : DataFrame
        The table as read.
    """

    classes: pd.DataFrame
    ranks: pd.DataFrame
    materials: pd.Series
    records: pd.DataFrame


def read_physiclear_attributes(path: str | os.PathLike | None = None, *, encoding: str = "levels",
                               min_material_objects: int = MIN_MATERIAL_OBJECTS) -> PhysiclearTable:
    """Read and check the class-attribute table, its ranks encoded as ``encoding`` (module docstring).

    Parameters
    ----------
    path : path-like, optional
        A table in the format of the module docstring (default: the shipped one).
    encoding : {"levels", "thresholds"}
        One attribute per level, or the ordinal thresholds ``<property>_above_<level>``.
    min_material_objects : int, default 3
        Materials of fewer objects get no attribute (0: every material).

    Returns
    -------
    PhysiclearTable

    Raises
    ------
    ConfigError
        An unknown encoding.
    DataFileError
        One line naming the file and line: other columns, an unknown property, a rank other than
        0/1/2, an empty material, a source other than ``utils/constants.py, <the property's variable>,
        line <n>``, an object given twice for a property or lacking one.
    """
    if encoding not in ENCODINGS:
        raise ConfigError(f"encoding must be one of {', '.join(ENCODINGS)}; got {encoding!r}")
    if path is None:
        with resources.as_file(resources.files("tzsl.datasets").joinpath(ATTRIBUTE_TABLE)) as shipped:
            return read_physiclear_attributes(shipped, encoding=encoding, min_material_objects=min_material_objects)
    path = Path(path)
    table = read_class_table(path, _COLUMNS)
    table = table.apply(lambda column: column.str.strip())
    variables = {p: v for p, (v, _) in PROPERTIES.items()} | {"material": MATERIALS_VARIABLE}
    seen: set[tuple[str, str]] = set()
    for i, (obj, prop, value, source) in enumerate(table.itertuples(index=False), start=2):
        if not obj:
            raise DataFileError(path, "object is empty", line=i)
        if prop not in variables:
            raise DataFileError(path, f"property {prop!r} is not one of {', '.join(variables)}", line=i)
        if prop == "material" and not re.fullmatch(r"[a-z]+", value):
            raise DataFileError(path, f"{obj} material {value!r} is not a lower-case word", line=i)
        if prop != "material" and value not in ("0", "1", "2"):
            raise DataFileError(path, f"{obj} {prop}: rank {value!r} is not 0, 1 or 2", line=i)
        match = _SOURCE.fullmatch(source)
        if match is None or match.group(1) != variables[prop]:
            raise DataFileError(path, f"{obj} {prop}: source must be '{_SOURCE_FILE}, {variables[prop]}, line <n>'; "
                                f"got {source!r}", line=i)
        if (obj, prop) in seen:
            raise DataFileError(path, f"{obj} is given twice for {prop!r}", line=i)
        seen.add((obj, prop))
    if table.empty:
        raise DataFileError(path, "has a header line but no object", line=1)
    wide = table.pivot(index="object", columns="property", values="value")
    objects = list(dict.fromkeys(table["object"]))
    wide = wide.reindex(index=objects, columns=list(variables))
    lacking = wide.isna().any(axis=1)
    if lacking.any():
        first = wide.index[lacking][0]
        raise DataFileError(path, f"{first} lacks {list(wide.columns[wide.loc[first].isna()])}")
    ranks = wide[list(PROPERTIES)].astype(np.int64)
    ranks.index.name, ranks.columns.name = "class", None
    materials = wide["material"].rename(None)
    return PhysiclearTable(encode_ranks(ranks, encoding).join(encode_materials(materials, min_material_objects)),
                           ranks, materials, table)


def encode_ranks(ranks: pd.DataFrame, encoding: str) -> pd.DataFrame:
    """The ranks (n_objects, 3) of :data:`PROPERTIES` as 0/1 attributes (module docstring)."""
    columns: dict[str, np.ndarray] = {}
    for prop, (_, levels) in PROPERTIES.items():
        rank = ranks[prop].to_numpy()
        if encoding == "levels":
            columns |= {f"{prop}_{name}": (rank == k) for k, name in enumerate(levels)}
        else:
            columns |= {f"{prop}_above_{name}": (rank > k) for k, name in enumerate(levels[:-1])}
    return pd.DataFrame({c: v.astype(np.int64) for c, v in columns.items()}, index=ranks.index)


def encode_materials(materials: pd.Series, min_objects: int) -> pd.DataFrame:
    """``material_<word>`` 0/1 for the materials of at least ``min_objects`` objects, most frequent first."""
    counts = materials.value_counts(sort=False)
    kept = sorted((m for m, n in counts.items() if n >= min_objects), key=lambda m: (-counts[m], m))
    return pd.DataFrame({f"material_{m}": (materials == m).to_numpy().astype(np.int64) for m in kept},
                        index=materials.index)


def physiclear_splits_from_constants(constants: OctopiConstants, classes: pd.DataFrame) -> str:
    """The paper's split as a split file (:mod:`tzsl.evaluation` format) over the objects of ``classes``.

    Two splits: ``physiclear-validation`` (train: ``TRAIN_OBJECTS``, test: ``VAL_OBJECTS``), for choosing,
    and ``physiclear-test`` (train: ``TRAIN_OBJECTS`` and ``VAL_OBJECTS``, test: ``TEST_OBJECTS``), for
    reporting, as the paper trains, validates and tests (:func:`physiclear_split_text`).
    """
    roles = {name: [o.removeprefix(KEY_PREFIX) for o, _ in constants.lists[v]] for name, v in SPLIT_VARIABLES.items()}
    return physiclear_split_text(roles, classes)


def physiclear_split_text(roles: dict[str, list[str]], classes: pd.DataFrame) -> str:
    """The two splits of :func:`physiclear_splits_from_constants` from the objects of each role, over ``classes``.

    Parameters
    ----------
    roles : dict
        ``train``, ``validation``, ``test`` -> objects, in the paper's order.
    classes : DataFrame (n_objects, n_attributes)
        The class-attribute rows; objects of ``roles`` it lacks are left out.

    Returns
    -------
    str
        The CSV text (``split,object,role``). A test object whose row of ``classes`` repeats an earlier test
        object's is left out of the split: zero-shot learning cannot tell two classes with one attribute row
        apart (in the shipped table: ``denim``, whose row is ``nylon_shirt``'s; a plain-file folder's
        ``splits.csv`` has no ``dropped`` role, so the object is in neither set). The rows are compared over the
        attributes the study's default rule keeps in the split (at least :data:`MIN_TRAIN_POSITIVES` positive
        and one negative training object: ``[splits] min_train_positives``, ``min_train_negatives``).
    """
    roles = {name: [o for o in objs if o in classes.index] for name, objs in roles.items()}
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(("split", "object", "role"))
    for split, train, test in (("physiclear-validation", roles["train"], roles["validation"]),
                               ("physiclear-test", roles["train"] + roles["validation"], roles["test"])):
        writer.writerows((split, o, "train") for o in train)
        writer.writerows((split, o, "test") for o in physiclear_distinct_objects(classes, train, test))
    return buffer.getvalue()


def physiclear_kept_attributes(classes: pd.DataFrame, train: list[str]) -> list[str]:
    """The attributes the study's default rule keeps when ``train`` are the training objects: at least
    :data:`MIN_TRAIN_POSITIVES` positive and one negative training object.

    Parameters
    ----------
    classes : DataFrame (n_objects, n_attributes) of 0/1
        The class-attribute rows, indexed by object.
    train : list of str
        Training objects (rows of ``classes``).

    Returns
    -------
    list of str
        The kept columns, in the table's order.
    """
    positives = classes.loc[train].sum()
    return classes.columns[(positives >= MIN_TRAIN_POSITIVES) & (positives < len(train))].tolist()


def physiclear_distinct_objects(classes: pd.DataFrame, train: list[str], test: list[str]) -> list[str]:
    """``test`` without every object whose row over :func:`physiclear_kept_attributes` of ``train`` repeats an
    earlier test object's (zero-shot learning cannot tell two classes with one attribute row apart), in order."""
    kept = physiclear_kept_attributes(classes, train)
    rows: set[tuple[int, ...]] = set()
    out = []
    for o in test:
        row = tuple(int(v) for v in classes.loc[o, kept])
        if row not in rows:
            out.append(o)
        rows.add(row)
    return out


def physiclear_split_roles(path: str | os.PathLike | None = None) -> dict[str, list[str]]:
    """The objects of each role (``train``, ``validation``, ``test``) of a split file of :func:`physiclear_split_text`
    (default: the shipped one)."""
    path = Path(path) if path is not None else physiclear_split_file()
    frame = pd.read_csv(path, dtype=str, keep_default_na=False)
    validation, test = frame[frame["split"] == "physiclear-validation"], frame[frame["split"] == "physiclear-test"]
    train = validation.loc[validation["role"] == "train", "object"].tolist()
    return {"train": train,  # the validation objects: the test split's training objects that are not the paper's
            "validation": [o for o in test.loc[test["role"] == "train", "object"] if o not in set(train)],
            "test": test.loc[test["role"] == "test", "object"].tolist()}


def physiclear_split_file() -> Path:
    """The shipped split file (:data:`SPLIT_FILE`, :func:`physiclear_splits_from_constants` of the pinned release)."""
    return Path(str(resources.files("tzsl.datasets").joinpath(SPLIT_FILE)))
