"""Split files: write and read object splits as a plain long-format CSV.

Format (UTF-8, comma-separated, one header line)::

    split,object,role,kind,seed
    random-1,car_sponge_101,train,random,0
    random-1,acrylic_211,test,random,0
    ...

* ``split`` - split name; rows of one split need not be contiguous.
* ``object`` - object name, as in the index of the object-attribute table.
* ``role`` - ``train`` or ``test``.
* ``kind``, ``seed`` - optional provenance columns (constant within a split; ``seed`` may
  be empty). Without them a split reads as ``kind="file"``, ``seed=None``.

Objects a split does not list are simply not used by it. Excluded attributes are not
stored: reading recomputes them from the attribute table with the paper's rule, so a
user-written file gets the same checks as a generated one. Dropped objects of challenging
splits (:attr:`Split.dropped_objects`) are not stored either (they are in neither set).
"""

from __future__ import annotations

import csv
import os
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

from tzsl.evaluation._splits import (
    Split,
    check_min_counts,
    kept_mask,
    attribute_exclusions,
    check_attribute_table,
    duplicate_attribute_groups,
)
from tzsl.exceptions import DataFileError, SplitError

__all__ = ["read_splits_csv", "write_splits_csv"]

REQUIRED_COLUMNS = ("split", "object", "role")
OPTIONAL_COLUMNS = ("kind", "seed")
ROLES = ("train", "test")


def write_splits_csv(splits: list[Split], path: str | os.PathLike) -> Path:
    """Write splits to ``path`` in the long format of this module, atomically.

    The file is written to a temporary file in the same folder and moved into place with
    :func:`os.replace`, so a reader never sees a half-written file.

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
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w", newline="", encoding="utf-8") as fh:
            writer = csv.writer(fh, lineterminator="\n")
            writer.writerow(REQUIRED_COLUMNS + OPTIONAL_COLUMNS)
            for s in splits:
                seed = "" if s.seed is None else str(s.seed)
                for role, objs in (("train", s.train_objects), ("test", s.test_objects)):
                    writer.writerows((s.name, o, role, s.kind, seed) for o in objs)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
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

    Returns
    -------
    list of Split
        In order of first appearance in the file; objects within a split in attribute-table
        order; ``kind`` and ``seed`` from the optional columns (else ``"file"`` / None).

    Raises
    ------
    DataFileError
        Missing or unreadable file, missing columns, no rows.
    SplitError
        Content problems, all listed: unknown object, unknown role, empty cell, an object
        twice in a split, an object in both train and test, inconsistent kind/seed, a split
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
                    path, f"line 1: header {header} lacks column(s) {missing}; expected "
                    f"{list(REQUIRED_COLUMNS)} (+ optional {list(OPTIONAL_COLUMNS)})"
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
                entry = found.setdefault(name, {"rows": {}, "kind": set(), "seed": set()})
                entry["kind"].add((row.get("kind") or "").strip())
                entry["seed"].add((row.get("seed") or "").strip())
                if obj not in position:
                    problems.append(f"{where}: split {name!r}: unknown object {obj!r} (not in the attribute table)")
                    continue
                if role not in ROLES:
                    problems.append(f"{where}: split {name!r}: role {role!r} of object {obj!r} is not one of {ROLES}")
                    continue
                if obj in entry["rows"]:
                    prev_role, prev_line = entry["rows"][obj]
                    if prev_role != role:
                        problems.append(
                            f"{where}: split {name!r}: object {obj!r} is in both train and test "
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
        test = np.zeros(len(objects), dtype=bool)
        train = np.zeros(len(objects), dtype=bool)
        for obj, (role, _) in rows.items():
            (test if role == "test" else train)[position[obj]] = True
        if not test.any():
            problems.append(f"{path}: split {name!r}: empty test set")
        if not train.any():
            problems.append(f"{path}: split {name!r}: empty training set")
        kinds, seeds = entry["kind"] - {""}, entry["seed"] - {""}
        if len(kinds) > 1 or len(seeds) > 1 or (seeds and "" in entry["seed"]):
            problems.append(f"{path}: split {name!r}: kind/seed differ between its rows ({sorted(kinds)}, {sorted(seeds)})")
            continue
        seed = None
        if seeds:
            try:
                seed = int(next(iter(seeds)))
            except ValueError:
                problems.append(f"{path}: split {name!r}: seed {next(iter(seeds))!r} is not an integer")
                continue
        excluded = attribute_exclusions(A[train], attributes, min_train_positives, min_train_negatives)
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
                train_objects=tuple(o for o, t in zip(objects, train) if t),
                test_objects=tuple(o for o, t in zip(objects, test) if t),
                attributes=attributes,
                excluded_attributes=excluded,
                kind=next(iter(kinds)) if kinds else "file",
                seed=seed,
            )
        )
    if problems:
        raise SplitError(f"invalid split file {path} ({len(problems)} problem(s)):\n  " + "\n  ".join(problems))
    return splits
