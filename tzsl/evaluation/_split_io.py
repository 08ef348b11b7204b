"""Split files: write and read object splits as a plain long-format CSV.

Format (UTF-8, comma-separated, one header line)::

    split,object,role,kind,seed,min_train_positives,min_train_negatives
    random-1,car_sponge_101,train,random,0,2,1
    random-1,acrylic_211,test,random,0,2,1
    challenging-3,foam_112,dropped,challenging,,3,1
    ...

* ``split`` - split name; rows of one split need not be contiguous.
* ``object`` - object name, as in the index of the object-attribute table.
* ``role`` - ``train``, ``test`` or ``dropped`` (an object the split kind would have tested
  but left out because it repeats another test object's attribute vector; it is in neither
  set, see :attr:`Split.dropped_objects`).
* ``kind``, ``seed`` - optional provenance columns (constant within a split; ``seed`` may
  be empty). Without them a split reads as ``kind="file"``, ``seed=None``.
* ``min_train_positives``, ``min_train_negatives`` - optional: the exclusion rule of the
  split (constant within a split). When present it is the rule the split is read back
  with, so a challenging split (>= 3 positive training objects) keeps exactly the
  attributes it was made with even when the reader's default rule is the random-split one.
  Without them (user-written files, files of tzsl < 0.2) the reader's arguments apply.
* ``purpose`` - written, never read: ``select`` or ``confirm``, the purpose the split's test set
  belongs to (:func:`~tzsl.evaluation.split_purpose`, a function of the test objects alone), so a
  reader of the file sees which splits may choose a method and which may only report one.

Excluded attributes are not stored: reading recomputes them from the attribute table with
the split's rule, so a user-written file gets the same checks as a generated one, and a
written split reads back equal to the one written (:func:`read_splits_csv` of
:func:`write_splits_csv` is the identity on splits made by this package).
"""

from __future__ import annotations

import csv
import io
import os
from pathlib import Path

import numpy as np
import pandas as pd

from tzsl._io import atomic_write
from tzsl.evaluation._splits import (
    Split,
    attribute_exclusions,
    check_attribute_table,
    check_min_counts,
    duplicate_attribute_groups,
    kept_mask,
    split_purpose,
)
from tzsl.exceptions import DataFileError, SplitError, problems_error

__all__ = ["read_splits_csv", "write_splits_csv"]

REQUIRED_COLUMNS = ("split", "object", "role")
OPTIONAL_COLUMNS = ("kind", "seed", "min_train_positives", "min_train_negatives")
#: Written for the reader of the file, ignored when read back (derived from the test objects).
DERIVED_COLUMNS = ("purpose",)
ROLES = ("train", "test", "dropped")
RULE_COLUMNS = ("min_train_positives", "min_train_negatives")


def write_splits_csv(splits: list[Split], path: str | os.PathLike) -> Path:
    """Write splits to ``path`` in the long format of this module, atomically.

    The file is written to a temporary file in the same folder and moved into place
    (:func:`tzsl._io.atomic_write`), so a reader never sees a half-written file. Each
    split's exclusion rule and dropped objects are written too, so it reads back equal.

    Parameters
    ----------
    splits : list of Split
        Names must be unique and non-empty.
    path : str or PathLike
        Destination ``.csv``; its folder must exist.

    Returns
    -------
    Path
        ``path``.
    """
    path = Path(path)
    names = [s.name for s in splits]
    if any(not n or n != n.strip() for n in names):
        raise SplitError(f"split names must be non-empty without surrounding spaces: {names}")
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise SplitError(f"duplicate split name(s) {dup}; cannot write {path}")
    if not path.parent.is_dir():
        raise DataFileError(path, f"folder {path.parent} does not exist")
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(REQUIRED_COLUMNS + OPTIONAL_COLUMNS + DERIVED_COLUMNS)
    for s in splits:
        seed = "" if s.seed is None else str(s.seed)
        rule = tuple("" if v is None else str(int(v)) for v in (s.min_train_positives, s.min_train_negatives))
        dropped = tuple(o for o, _ in s.dropped_objects)
        purpose = split_purpose(s.test_objects)
        for role, objs in (("train", s.train_objects), ("test", s.test_objects), ("dropped", dropped)):
            writer.writerows((s.name, o, role, s.kind, seed, *rule, purpose) for o in objs)
    text = buffer.getvalue()

    def write(p: Path) -> None:
        p.write_text(text, encoding="utf-8")

    atomic_write(path, write)
    return path


def read_splits_csv(
    path: str | os.PathLike,
    object_attributes: pd.DataFrame,
    *,
    min_train_positives: int = 3,
    min_train_negatives: int = 1,
) -> list[Split]:
    """Read and validate a split file against an object-attribute table.

    Every problem found is reported at once, each with its file and line.

    Parameters
    ----------
    path : str or PathLike
        A CSV in the long format of this module.
    object_attributes : DataFrame of shape (n_objects, n_attributes)
        0/1 table indexed by object name.
    min_train_positives, min_train_negatives : int, default 3 and 1
        Attributes with fewer positive / negative training objects in a split are left out
        of that split and reported in :attr:`Split.excluded_attributes` (not an error).
        Only for splits whose rows do not record a rule: the rule columns of the file win,
        so a split is read back with the rule it was made with.

    Returns
    -------
    list of Split
        In order of first appearance in the file; objects within a split in attribute-table
        order; ``kind``, ``seed`` and the rule from the optional columns (else ``"file"``,
        None and the arguments).

    Raises
    ------
    DataFileError
        Missing or unreadable file, missing columns, no rows.
    SplitError
        Content problems, all listed: unknown object, unknown role, empty cell, an object
        twice in a split, an object in two roles, inconsistent kind/seed/rule, a split
        with no test or no train object, test objects with equal attribute vectors (over the
        split's kept attributes).
    """
    A = check_attribute_table(object_attributes)
    check_min_counts(min_train_positives, min_train_negatives)
    objects = tuple(map(str, object_attributes.index))
    attributes = tuple(map(str, object_attributes.columns))
    position = {o: i for i, o in enumerate(objects)}
    path = Path(path)
    if not path.is_file():
        raise DataFileError(path, "split file not found")

    problems: list[str] = []
    # split -> {"rows": {object: (role, line)}, "kind": {...}, "seed": {...}, "line": first line}
    found: dict[str, dict] = {}
    try:
        with open(path, newline="", encoding="utf-8") as fh:
            reader = csv.DictReader(fh)
            header = [h.strip() for h in (reader.fieldnames or [])]
            missing = [c for c in REQUIRED_COLUMNS if c not in header]
            if missing:
                raise DataFileError(
                    path, f"header {header} lacks column(s) {missing}; expected "
                    f"{list(REQUIRED_COLUMNS)} (+ optional {list(OPTIONAL_COLUMNS)})", line=1
                )
            reader.fieldnames = header
            for row in reader:
                line = reader.line_num
                if not any((v or "").strip() for k, v in row.items() if k is not None):
                    continue  # blank line
                where = f"{path}:{line}"
                name, obj, role = ((row.get(c) or "").strip() for c in REQUIRED_COLUMNS)
                if not name or not obj or not role:
                    problems.append(f"{where}: empty split, object or role cell")
                    continue
                entry = found.setdefault(name, {"rows": {}, **{c: set() for c in OPTIONAL_COLUMNS}})
                for column in OPTIONAL_COLUMNS:
                    entry[column].add((row.get(column) or "").strip())
                if obj not in position:
                    problems.append(f"{where}: split {name!r}: unknown object {obj!r} (not in the attribute table)")
                    continue
                if role not in ROLES:
                    problems.append(f"{where}: split {name!r}: role {role!r} of object {obj!r} is not one of {ROLES}")
                    continue
                if obj in entry["rows"]:
                    prev_role, prev_line = entry["rows"][obj]
                    if prev_role != role:
                        first, second = sorted((prev_role, role), key=ROLES.index)
                        problems.append(
                            f"{where}: split {name!r}: object {obj!r} is in both {first} and {second} "
                            f"(also line {prev_line})"
                        )
                    else:
                        problems.append(f"{where}: split {name!r}: object {obj!r} listed twice (also line {prev_line})")
                    continue
                entry["rows"][obj] = (role, line)
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise DataFileError(path, f"cannot read split file: {exc}") from None
    if not found and not problems:
        raise DataFileError(path, "split file has no rows")

    splits = []
    for name, entry in found.items():
        rows = entry["rows"]
        masks = {role: np.zeros(len(objects), dtype=bool) for role in ROLES}
        for obj, (role, _) in rows.items():
            masks[role][position[obj]] = True
        train, test, dropped = masks["train"], masks["test"], masks["dropped"]
        if not test.any():
            problems.append(f"{path}: split {name!r}: empty test set")
        if not train.any():
            problems.append(f"{path}: split {name!r}: empty training set")
        kinds, seeds = entry["kind"] - {""}, entry["seed"] - {""}
        if len(kinds) > 1 or len(seeds) > 1 or (seeds and "" in entry["seed"]):
            problems.append(
                f"{path}: split {name!r}: kind/seed differ between its rows ({sorted(kinds)}, {sorted(seeds)})"
            )
            continue
        seed = None
        if seeds:
            try:
                seed = int(next(iter(seeds)))
            except ValueError:
                problems.append(f"{path}: split {name!r}: seed {next(iter(seeds))!r} is not an integer")
                continue
        rule = _split_rule(entry, (min_train_positives, min_train_negatives))
        if isinstance(rule, str):
            problems.append(f"{path}: split {name!r}: {rule}")
            continue
        excluded = attribute_exclusions(A[train], attributes, *rule)
        kept = kept_mask(attributes, excluded)
        test_idx = np.flatnonzero(test)
        for group in duplicate_attribute_groups(A[test_idx][:, kept]):
            names = [objects[test_idx[g]] for g in group]
            lines = [rows[o][1] for o in names]
            problems.append(
                f"{path}: split {name!r}: test objects {names} (lines {lines}) have the same attribute "
                f"vector over the split's {int(kept.sum())} kept attributes; ZSL cannot tell them apart"
            )
        splits.append(
            Split(
                name=name,
                train_objects=tuple(o for o, t in zip(objects, train, strict=True) if t),
                test_objects=tuple(o for o, t in zip(objects, test, strict=True) if t),
                attributes=attributes,
                excluded_attributes=excluded,
                dropped_objects=_dropped_reasons(A, objects, kept, test, dropped),
                kind=next(iter(kinds)) if kinds else "file",
                seed=seed,
                min_train_positives=rule[0],
                min_train_negatives=rule[1],
            )
        )
    error = problems_error(problems, path, error=SplitError)
    if error is not None:
        raise error
    return splits


def _split_rule(entry: dict, default: tuple[int, int]) -> tuple[int, int] | str:
    """The split's (min_train_positives, min_train_negatives): recorded, else ``default``.

    Returns a problem description (str) when the rows disagree or a value is not a
    non-negative integer.
    """
    rule = []
    for column, fallback in zip(RULE_COLUMNS, default, strict=True):
        values = entry[column]
        if len(values) > 1:
            return f"{column} differs between its rows ({sorted(values)})"
        (value,) = values
        if value == "":
            rule.append(int(fallback))
            continue
        try:
            number = int(value)
        except ValueError:
            number = -1
        if number < 0:
            return f"{column} {value!r} is not a non-negative integer"
        rule.append(number)
    return rule[0], rule[1]


def _dropped_reasons(
    A: np.ndarray, objects: tuple[str, ...], kept: np.ndarray, test: np.ndarray, dropped: np.ndarray
) -> tuple[tuple[str, str], ...]:
    """``(object, reason)`` of dropped objects, the reason worded as :func:`challenging_splits` does."""
    out = []
    test_idx = np.flatnonzero(test)
    for i in np.flatnonzero(dropped):
        same = test_idx[(A[test_idx][:, kept] == A[i, kept]).all(axis=1)]
        reason = (f"same attribute vector as test object {objects[same[0]]!r}" if same.size
                  else "dropped in the split file")
        out.append((objects[i], reason))
    return tuple(out)
