"""Attribute filtering: adjectives present in >= 3 objects (19 of 24 on PHAC-2)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from tzsl.exceptions import ConfigError, DataFileError
from tzsl.features import filter_attributes

#: DAP paper section 4.1, the 19 adjectives used.
PAPER_19 = {
    "absorbent", "bumpy", "compressible", "cool", "fuzzy", "hard", "hairy", "metallic", "porous",
    "rough", "scratchy", "slippery", "smooth", "soft", "solid", "springy", "squishy", "textured",
    "thick",
}


def _table():
    return pd.DataFrame(
        {
            "three": [1, 1, 1, 0, 0],
            "two": [0, 1, 0, 1, 0],
            "five": [1, 1, 1, 1, 1],
            "none": [0, 0, 0, 0, 0],
        },
        index=pd.Index([f"obj_{i}" for i in range(5)], name="object_name"),
    )


def test_threshold_and_order():
    kept, dropped = filter_attributes(_table())
    assert list(kept.columns) == ["three", "five"]
    assert dropped == ["two", "none"]
    assert list(kept.index) == list(_table().index)
    assert kept.dtypes.eq(np.int64).all()
    kept, dropped = filter_attributes(_table(), min_objects=2)
    assert list(kept.columns) == ["three", "two", "five"] and dropped == ["none"]
    with pytest.raises(ConfigError, match="min_objects=6 drops every attribute"):  # an error, not an empty table
        filter_attributes(_table(), min_objects=6)


def test_bool_and_float_tables():
    kept, _ = filter_attributes(_table().astype(bool))
    assert list(kept.columns) == ["three", "five"]
    kept, _ = filter_attributes(_table().astype(float))
    assert kept.to_numpy().dtype == np.int64


@pytest.mark.parametrize(
    "value, shown", [(2, "2"), (np.nan, "nan"), (-1, "-1"), (0.5, "0.5")]
)
def test_non_binary_entries_name_object_and_attribute(value, shown):
    table = _table().astype(float)
    table.loc["obj_3", "two"] = value
    with pytest.raises(DataFileError, match=rf"attribute 'two' of object 'obj_3' is {shown}"):
        filter_attributes(table)


def test_text_and_structural_errors():
    table = _table().astype(object)
    table.loc["obj_1", "five"] = "yes"
    with pytest.raises(DataFileError, match="attribute 'five' of object 'obj_1' is 'yes'"):
        filter_attributes(table)
    table.loc["obj_1", "five"] = 1  # object column of ints is fine
    assert list(filter_attributes(table)[0].columns) == ["three", "five"]
    dup = pd.concat([_table(), _table().iloc[:1]])
    with pytest.raises(DataFileError, match="lists object 'obj_0' twice"):
        filter_attributes(dup)
    with pytest.raises(DataFileError, match="no attribute columns"):
        filter_attributes(_table().iloc[:, :0])
    with pytest.raises(DataFileError, match="must be a DataFrame"):
        filter_attributes(_table().to_numpy())
    sourced = _table().astype(float)
    sourced.attrs["source"] = "/data/labels.csv"
    sourced.iloc[0, 0] = 3
    with pytest.raises(DataFileError, match="/data/labels.csv"):
        filter_attributes(sourced)


@pytest.mark.parametrize("bad", [0, -1, 2.0, True, "3"])
def test_bad_min_objects(bad):
    with pytest.raises(ConfigError, match="min_objects"):
        filter_attributes(_table(), min_objects=bad)


@pytest.mark.realdata
def test_phac2_keeps_19_of_24(phac2_labels):
    assert phac2_labels.shape == (60, 24)
    kept, dropped = filter_attributes(phac2_labels, min_objects=3)
    assert kept.shape == (60, 19)
    assert set(kept.columns) == PAPER_19
    assert dropped == ["crinkly", "nice", "sticky", "thin", "unpleasant"]
    # PROVENANCE.md section 0: bumpy and metallic have exactly 3 objects and are kept
    assert kept["bumpy"].sum() == 3 and kept["metallic"].sum() == 3
    assert phac2_labels[dropped].sum().max() == 2
