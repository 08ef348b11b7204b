"""Zero-shot validity of a class split: synthetic cases and the real fabric table."""

from __future__ import annotations

import warnings

import pandas as pd
import pytest

from tzsl.datasets import fabric_zsl_split, load_fabric
from tzsl.evaluation import seen_test_classes, zero_shot_variant
from tzsl.exceptions import SplitError

TABLE = pd.DataFrame(
    [[1, 0, 1], [0, 1, 1], [0, 1, 1], [1, 1, 0], [0, 0, 1]],
    index=["a", "b", "c", "d", "e"], columns=["x", "y", "z"],
)


def test_seen_test_classes():
    assert seen_test_classes(TABLE, ["a", "b", "d"], ["c", "e"]) == {"c": ("b",)}
    assert seen_test_classes(TABLE, ["a", "d"], ["b", "e"]) == {}
    with pytest.raises(SplitError, match="both training and test"):
        seen_test_classes(TABLE, ["a"], ["a"])
    with pytest.raises(SplitError, match=r"test class\(es\) \['ghost'\]"):
        seen_test_classes(TABLE, ["a"], ["ghost"])


def test_drop_and_merge_on_a_small_table():
    drop = zero_shot_variant(TABLE, ["a", "b", "d"], ["c", "e"])
    assert drop.strategy == "drop" and drop.test_classes == ("e",) and drop.dropped_classes == ("c",)
    assert drop.train_classes == ("a", "b", "d") and "c" not in drop.class_map
    merge = zero_shot_variant(TABLE, ["a", "b", "d"], ["c", "e"], strategy="merge")
    assert merge.train_classes == ("a", "d") and merge.test_classes == ("b+c", "e")
    assert merge.class_map["b"] == merge.class_map["c"] == "b+c"
    assert seen_test_classes(TABLE, ["a", "d"], ["b", "e"]) == {}
    same = zero_shot_variant(TABLE, ["a", "d"], ["b", "e"])
    assert same.strategy == "none" and same.test_classes == ("b", "e")


@pytest.fixture(scope="module")
def fabric_a8(data_dir):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # the loader warns about groups 3, 4, 5
        return load_fabric(data_dir, images=False).attributes


@pytest.mark.realdata
@pytest.mark.parametrize("config, offending", [(1, 5), (2, 4)])
def test_fabric_paper_split_is_not_zero_shot(fabric_a8, config, offending):
    split = fabric_zsl_split(config)
    seen = seen_test_classes(fabric_a8, split.train_groups, split.test_groups)
    assert list(seen) == [offending]
    assert set(seen[offending]) == {3, 4, 5} - {offending}


@pytest.mark.realdata
def test_fabric_variants_are_zero_shot(fabric_a8):
    split = fabric_zsl_split(1)
    drop = zero_shot_variant(fabric_a8, split.train_groups, split.test_groups)
    print(drop.note)
    assert drop.test_classes == (0, 7) and drop.train_classes == (1, 2, 3, 4, 6)
    assert drop.excluded_attributes == ()
    assert seen_test_classes(fabric_a8, drop.train_classes, drop.test_classes) == {}
    merge = zero_shot_variant(fabric_a8, split.train_groups, split.test_groups, strategy="merge")
    print(merge.note)
    assert merge.test_classes == (0, "3+4+5", 7) and merge.train_classes == (1, 2, 6)
    assert merge.excluded_attributes == ("attr_3",)  # held only by groups 3, 4, 5
    # the merged class's row is seen by no training class
    merged_row = fabric_a8.loc[[5]].rename(index={5: "3+4+5"})
    table = pd.concat([fabric_a8, merged_row])
    assert seen_test_classes(table, merge.train_classes, merge.test_classes) == {}
