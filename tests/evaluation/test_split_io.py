"""Split CSV files: round trip, atomic writes, and every bad-input case."""

from __future__ import annotations

import os

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tzsl.evaluation import Split, random_object_splits, read_splits_csv, split_purpose, write_splits_csv
from tzsl.exceptions import DataFileError, SplitError

# 8 objects, 3 attributes, all vectors distinct except o6 == o7
TABLE = pd.DataFrame(
    [[1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 0], [1, 0, 1], [0, 1, 1], [1, 1, 1], [1, 1, 1]],
    index=[f"o{i}" for i in range(8)],
    columns=["a", "b", "c"],
)


def _write(tmp_path, text: str):
    path = tmp_path / "splits.csv"
    path.write_text(text, encoding="utf-8")
    return path


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(seed=st.integers(0, 10_000), n_test=st.integers(1, 4), n_splits=st.integers(1, 4), mtp=st.integers(0, 3))
def test_round_trip(tmp_path, seed, n_test, n_splits, mtp):
    splits = random_object_splits(TABLE, n_test=n_test, n_splits=n_splits, random_state=seed, min_train_positives=mtp)
    path = write_splits_csv(splits, tmp_path / "s.csv")
    back = read_splits_csv(path, TABLE, min_train_positives=mtp)
    assert back == splits
    assert [p.name for p in tmp_path.iterdir()] == ["s.csv"]  # no temp file left behind


def test_format_is_long_and_documented_columns(tmp_path):
    s = Split("mine", ("o0", "o1", "o2", "o3"), ("o4", "o5"), kind="random", seed=7)
    path = write_splits_csv([s], tmp_path / "s.csv")
    df = pd.read_csv(path)
    assert list(df.columns) == ["split", "object", "role", "kind", "seed", "min_train_positives",
                                "min_train_negatives", "purpose"]
    assert df["role"].tolist() == ["train"] * 4 + ["test"] * 2
    assert set(df["split"]) == {"mine"} and set(df["seed"]) == {7}


def test_purpose_column_says_which_splits_may_choose(tmp_path):
    """Each split's rows carry its test set's purpose; the column is derived, so reading ignores it."""
    splits = [Split(f"s{i}", tuple(o for o in TABLE.index if o not in test), test)
              for i, test in enumerate([("o0", "o1"), ("o1", "o3"), ("o4", "o5"), ("o1", "o5"), ("o3", "o4")])]
    path = write_splits_csv(splits, tmp_path / "s.csv")
    df = pd.read_csv(path)
    by_split = df.groupby("split")["purpose"].agg(set)
    assert {s.name: {split_purpose(s.test_objects)} for s in splits} == by_split.to_dict()
    assert set(df["purpose"]) == {"select", "confirm"}  # these five test sets fall in both purposes
    df.assign(purpose="select").to_csv(path, index=False)  # an edited purpose cell changes nothing
    assert read_splits_csv(path, TABLE, min_train_positives=0) == read_splits_csv(
        write_splits_csv(splits, tmp_path / "t.csv"), TABLE, min_train_positives=0)


def test_minimal_user_file_reads_and_reports_exclusion(tmp_path):
    # training objects o0, o1, o2 have no positive of "c": c is excluded, not an error
    path = _write(tmp_path, "split,object,role\nmine,o0,train\nmine,o1,train\nmine,o3,train\n"
                            "mine,o2,test\nmine,o4,test\n")
    (s,) = read_splits_csv(path, TABLE, min_train_positives=1)
    assert s.name == "mine" and s.kind == "file" and s.seed is None
    assert s.train_objects == ("o0", "o1", "o3") and s.test_objects == ("o2", "o4")
    assert s.excluded_attributes == (("c", "0 positive training object(s) < 1"),)
    assert s.kept_attributes == ("a", "b")


def test_unknown_object_names_object_file_and_line(tmp_path):
    path = _write(tmp_path, "split,object,role\nx,o0,train\nx,o1,train\nx,ghost,test\nx,o2,test\n")
    with pytest.raises(SplitError) as err:
        read_splits_csv(path, TABLE, min_train_positives=0)
    assert f"{path}:4" in str(err.value) and "unknown object 'ghost'" in str(err.value)


def test_object_in_train_and_test(tmp_path):
    path = _write(tmp_path, "split,object,role\nx,o0,train\nx,o1,test\nx,o0,test\n")
    with pytest.raises(SplitError, match=r":4: split 'x': object 'o0' is in both train and test \(also line 2\)"):
        read_splits_csv(path, TABLE, min_train_positives=0)


def test_duplicate_test_vectors(tmp_path):
    path = _write(tmp_path, "split,object,role\nx,o0,train\nx,o1,train\nx,o6,test\nx,o7,test\n")
    with pytest.raises(SplitError,
                       match=r"test objects \['o6', 'o7'\] \(lines \[4, 5\]\) have the same attribute vector"):
        read_splits_csv(path, TABLE, min_train_positives=0)


def test_duplicates_after_exclusion_are_caught(tmp_path):
    # o3 = (1,1,0) and o6 = (1,1,1) differ only in c, which no training object has
    path = _write(tmp_path, "split,object,role\nx,o0,train\nx,o1,train\nx,o3,test\nx,o6,test\n")
    with pytest.raises(SplitError, match=r"\['o3', 'o6'\].* over the split's 2 kept attributes"):
        read_splits_csv(path, TABLE, min_train_positives=1)


def test_empty_test_set_and_other_problems_listed_together(tmp_path):
    path = _write(
        tmp_path,
        "split,object,role\nx,o0,train\nx,o1,train\ny,o0,train\ny,o2,validation\ny,o3,test\ny,o3,test\nz,,test\n",
    )
    with pytest.raises(SplitError) as err:
        read_splits_csv(path, TABLE, min_train_positives=0)
    msg = str(err.value)
    assert "4 problem(s)" in msg
    assert "split 'x': empty test set" in msg
    assert ":5: split 'y': role 'validation'" in msg
    assert ":7: split 'y': object 'o3' listed twice (also line 6)" in msg
    assert ":8: empty split, object or role cell" in msg


@pytest.mark.parametrize(
    "text, exc, match",
    [
        ("split,object\nx,o0\n", DataFileError, r"\.csv:1: header .* lacks column\(s\) \['role'\]"),
        ("split,object,role\n", DataFileError, "no rows"),
        ("split,object,role,kind,seed\nx,o0,train,random,1\nx,o1,test,random,2\n", SplitError, "kind/seed differ"),
        ("split,object,role,kind,seed\nx,o0,train,random,one\nx,o1,test,random,one\n", SplitError,
         "seed 'one' is not an integer"),
    ],
)
def test_malformed_files(tmp_path, text, exc, match):
    with pytest.raises(exc, match=match):
        read_splits_csv(_write(tmp_path, text), TABLE, min_train_positives=0)


def test_missing_file_and_bad_table(tmp_path):
    with pytest.raises(DataFileError, match="split file not found"):
        read_splits_csv(tmp_path / "nope.csv", TABLE)
    path = _write(tmp_path, "split,object,role\nx,o0,train\nx,o1,test\n")
    with pytest.raises(SplitError, match="0/1"):
        read_splits_csv(path, TABLE.replace(1, 2))


def test_write_is_atomic(tmp_path, monkeypatch):
    dest = tmp_path / "s.csv"
    dest.write_text("old content\n")
    splits = random_object_splits(TABLE, n_test=2, n_splits=2, random_state=0, min_train_positives=0)

    def boom(src, dst):
        raise OSError("disk full")

    monkeypatch.setattr(os, "replace", boom)
    with pytest.raises(OSError, match="disk full"):
        write_splits_csv(splits, dest)
    assert dest.read_text() == "old content\n"
    assert [p.name for p in tmp_path.iterdir()] == ["s.csv"]  # temp file removed


def test_write_rejects_bad_names_and_folder(tmp_path):
    s = Split("x", ("o0",), ("o1",))
    with pytest.raises(SplitError, match=r"duplicate split name\(s\) \['x'\]"):
        write_splits_csv([s, s], tmp_path / "s.csv")
    with pytest.raises(DataFileError, match="does not exist"):
        write_splits_csv([s], tmp_path / "missing" / "s.csv")
    assert not np.any([p.suffix == ".tmp" for p in tmp_path.iterdir()])


def test_recorded_rule_wins_over_the_readers_default(tmp_path):
    # a split made with the challenging rule (3 positives) read by a caller whose default is
    # the random-split rule (2) keeps its own rule and so its kept attributes
    splits = random_object_splits(TABLE, n_test=2, n_splits=3, random_state=1, min_train_positives=3)
    back = read_splits_csv(write_splits_csv(splits, tmp_path / "s.csv"), TABLE, min_train_positives=0)
    assert back == splits
    assert [s.kept_attributes for s in back] == [s.kept_attributes for s in splits]
    assert {s.min_train_positives for s in back} == {3}
    # without the rule columns the reader's argument applies
    df = pd.read_csv(tmp_path / "s.csv").drop(columns=["min_train_positives", "min_train_negatives"])
    df.to_csv(tmp_path / "bare.csv", index=False)
    bare = read_splits_csv(tmp_path / "bare.csv", TABLE, min_train_positives=0)
    assert {s.min_train_positives for s in bare} == {0}
    assert all(s.excluded_attributes == () for s in bare)


def test_dropped_objects_round_trip(tmp_path):
    s = Split("c", ("o0", "o1", "o2", "o3", "o4", "o5"), ("o6",), attributes=("a", "b", "c"),
              dropped_objects=(("o7", "same attribute vector as test object 'o6'"),), kind="challenging",
              min_train_positives=1, min_train_negatives=1)
    path = write_splits_csv([s], tmp_path / "s.csv")
    assert pd.read_csv(path)["role"].tolist()[-1] == "dropped"
    assert read_splits_csv(path, TABLE) == [s]


@pytest.mark.parametrize("cell, message", [("x", "min_train_positives 'x' is not a non-negative integer"),
                                           ("-1", "min_train_positives '-1' is not a non-negative integer")])
def test_bad_rule_cell(tmp_path, cell, message):
    path = _write(tmp_path, f"split,object,role,min_train_positives\nx,o0,train,{cell}\nx,o1,test,{cell}\n")
    with pytest.raises(SplitError, match=message):
        read_splits_csv(path, TABLE)


def test_rule_differs_between_rows(tmp_path):
    path = _write(tmp_path, "split,object,role,min_train_positives\nx,o0,train,1\nx,o1,test,2\n")
    with pytest.raises(SplitError, match="min_train_positives differs between its rows"):
        read_splits_csv(path, TABLE)
