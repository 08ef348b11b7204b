"""The standard splits v1: packaged files, their hashes, the recipe they were drawn by, and how they are named."""

from __future__ import annotations

import shutil
from itertools import combinations

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from tzsl.cli import cli
from tzsl.datasets import (
    load_fabric,
    read_biotac_slide_attributes,
    read_bts3_attributes,
    read_icub_grasp_attributes,
    read_physiclear_attributes,
)
from tzsl.evaluation import PURPOSES, random_object_splits, read_splits_csv, split_purpose, write_splits_csv
from tzsl.exceptions import DataFileError
from tzsl.features import DEFAULT_MIN_OBJECTS, fabric_group_table, filter_attributes
from tzsl.studies.benchmark import splits as standard
from tzsl.studies.benchmark.catalog import BENCHMARK_DATASETS

PACKAGED_TABLES = {"biotac-slide": lambda: read_biotac_slide_attributes().classes,
                   "bts3": lambda: read_bts3_attributes().classes,
                   "icub-grasp": lambda: read_icub_grasp_attributes().classes,
                   "physiclear": lambda: read_physiclear_attributes().classes}


def _study_table(table: pd.DataFrame) -> pd.DataFrame:
    """The table a study of a catalog dataset reads: its class table with the default attribute filter."""
    return filter_attributes(table, DEFAULT_MIN_OBJECTS)[0]


def test_every_benchmark_dataset_has_a_split_file_whose_hash_is_the_index():
    index = standard.standard_index()
    assert sorted(index) == sorted(d.name for d in BENCHMARK_DATASETS)
    for name, entry in index.items():
        frame = pd.read_csv(standard.standard_split_file(name))
        for purpose in PURPOSES:
            names = frame.loc[frame["split"].str.startswith(f"{purpose}-"), "split"].unique()
            assert len(names) == entry[f"n_{purpose}"] <= standard.N_SPLITS
        tests = frame[frame["role"] == "test"].groupby("split")["object"].apply(frozenset)
        assert tests.map(len).eq(entry["n_test"]).all()
        assert tests.nunique() == len(tests), f"{name}: two splits share a test set"
        for split, objects in tests.items():  # each split in its purpose's half of every test set
            assert split.startswith(f"{split_purpose(objects)}-")
            assert (frame.loc[frame["split"] == split, "purpose"] == split_purpose(objects)).all()


@pytest.mark.parametrize("name", sorted(PACKAGED_TABLES))
def test_the_recipe_draws_the_shipped_files_again(name, tmp_path):
    table = _study_table(PACKAGED_TABLES[name]())
    index = standard.write_standard_splits({name: table}, tmp_path)
    assert (tmp_path / f"{name}.csv").read_bytes() == standard.standard_split_file(name).read_bytes()
    assert index[name] == standard.standard_index()[name]


def test_the_recipe_draws_the_real_data_files_again(data_dir, tmp_path):
    """PHAC-2 through the study's own table; the fabric groups through the table the fabric-depth features use
    (:func:`tzsl.features.fabric_group_table`), without computing 1300 image descriptors."""
    tables = {"phac2-penn": BENCHMARK_DATASETS[0].object_attributes(data_dir),
              "fabric-depth": _study_table(fabric_group_table(load_fabric(data_dir, images=False)))}
    assert set(tables) | set(PACKAGED_TABLES) == {d.name for d in BENCHMARK_DATASETS}
    for name, table in tables.items():
        standard.write_standard_splits({name: table}, tmp_path)
        assert (tmp_path / f"{name}.csv").read_bytes() == standard.standard_split_file(name).read_bytes(), name


def test_the_splits_read_back_against_the_study_table_with_one_purpose_each():
    table = _study_table(read_bts3_attributes().classes)
    every = standard.read_standard_splits("bts3", table)
    confirm = standard.read_standard_splits("bts3", table, "confirm")
    assert 0 < len(confirm) < len(every)
    assert {split_purpose(s.test_objects) for s in confirm} == {"confirm"}


def test_n_test_is_one_in_six_within_bounds_and_distinct_rows():
    def table(n_objects, n_distinct):
        rows = np.eye(n_distinct, dtype=int)[np.arange(n_objects) % n_distinct]
        return pd.DataFrame(rows, index=[f"o{i}" for i in range(n_objects)])

    assert standard.n_test_of(table(60, 60)) == 10  # the DAP paper's 10 of 60
    assert standard.n_test_of(table(120, 120)) == standard.MAX_TEST
    assert standard.n_test_of(table(8, 8)) == standard.MIN_TEST
    assert standard.n_test_of(table(41, 4)) == 4  # never more than the distinct rows


def test_an_edited_split_file_is_refused_in_one_line(tmp_path, monkeypatch):
    folder = tmp_path / "v1"
    shutil.copytree(standard.standard_split_file("bts3").parent, folder)
    with open(folder / "bts3.csv", "a", encoding="utf-8") as fh:
        fh.write("confirm-01,apple,test,random,0,3,1,confirm\n")
    monkeypatch.setattr(standard, "_folder", lambda version: folder)
    with pytest.raises(DataFileError, match=r"bts3\.csv.*sha256 .* is not the v1 index"):
        standard.standard_split_file("bts3")


def test_distinct_draws_every_valid_test_set_once_then_stop():
    rows = np.array([[1, 0, 1], [0, 1, 1], [1, 1, 0], [0, 0, 1], [1, 0, 0], [0, 1, 0]])
    table = pd.DataFrame(rows, index=[f"o{i}" for i in range(6)], columns=["a", "b", "c"])
    drawn = random_object_splits(table, n_test=2, n_splits=50, random_state=0, min_train_positives=1,
                                 distinct=True)
    sets = [frozenset(s.test_objects) for s in drawn]
    assert len(sets) == len(set(sets)) == len(list(combinations(range(6), 2)))
    first = random_object_splits(table, n_test=2, n_splits=3, random_state=0, min_train_positives=1, distinct=True)
    assert [s.test_objects for s in first] == [s.test_objects for s in drawn[:3]]


def test_tzsl_splits_standard_writes_the_shipped_confirmation_splits(data_dir, tmp_path):
    out = tmp_path / "confirm.csv"
    result = CliRunner().invoke(cli, ["splits", "--standard", "v1", "--dataset", "phac2-penn", "--purpose",
                                      "confirm", "--out", str(out), "--data-dir", str(data_dir)])
    assert result.exit_code == 0, result.output
    def rows(frame):
        return sorted(map(tuple, frame[["split", "object", "role"]].to_numpy()))

    shipped = pd.read_csv(standard.standard_split_file("phac2-penn"))
    assert rows(pd.read_csv(out)) == rows(shipped[shipped["split"].str.startswith("confirm-")])
    result = CliRunner().invoke(cli, ["splits", "--standard", "v2", "--dataset", "phac2-penn", "--out",
                                      str(tmp_path / "x.csv"), "--data-dir", str(data_dir)])
    assert result.exit_code == 3 and "unknown standard split version 'v2'" in result.output


def test_a_written_and_read_standard_split_is_the_same_split(tmp_path):
    table = _study_table(read_biotac_slide_attributes().classes)
    splits = standard.read_standard_splits("biotac-slide", table)
    again = read_splits_csv(write_splits_csv(splits, tmp_path / "s.csv"), table)
    assert again == splits
