"""Repeated group partitions of the fabric study: validity rules, census, interval and chance columns."""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from tzsl.exceptions import ConfigError
from tzsl.models.protocol import MIN_CV_CLASSES
from tzsl.studies.config import validate
from tzsl.studies.fabric.partitions import (
    PARTITION_COLUMNS,
    group_partitions,
    partition_census,
    run_partitions,
)
from tzsl.studies.fabric.samples import FabricSamples

# the structure of a8 (8 groups x 8 attributes; groups 3, 4, 5 share a row), typed as a test fixture
A8_STRUCTURE = np.array(
    [[1, 0, 1, 0, 1, 0, 0, 0], [1, 0, 1, 0, 0, 1, 0, 1], [0, 1, 0, 0, 0, 0, 1, 0], [0, 1, 0, 1, 0, 1, 0, 0],
     [0, 1, 0, 1, 0, 1, 0, 0], [0, 1, 0, 1, 0, 1, 0, 0], [0, 1, 0, 0, 1, 0, 0, 0], [0, 1, 1, 0, 1, 0, 0, 0]],
    dtype=float,
)


def _random_attributes(n_groups=8, n_attributes=12, seed=0):
    return np.random.default_rng(seed).integers(0, 2, size=(n_groups, n_attributes)).astype(float)


def _is_valid(A, test, both_signs):
    train = [g for g in range(A.shape[0]) if g not in test]
    A_tr = A[train]
    varies = A_tr.max(0) > A_tr.min(0)
    if both_signs and not varies.all():
        return False
    if any(tuple(A[g]) == tuple(A[h]) for g in test for h in train):
        return False
    if len({tuple(A[g, varies]) for g in test}) < len(test):
        return False
    return len({tuple(r) for r in A_tr}) >= MIN_CV_CLASSES


@pytest.mark.parametrize("both_signs", [True, False])
@pytest.mark.parametrize("A", [_random_attributes(), _random_attributes(n_attributes=6, seed=3), A8_STRUCTURE])
def test_partitions_are_exactly_the_valid_ones(A, both_signs):
    parts = group_partitions(A, min_test=2, both_signs=both_signs)
    expected = [t for k in range(2, 8) for t in itertools.combinations(range(8), k) if _is_valid(A, t, both_signs)]
    assert [p.test_groups for p in parts] == expected
    for i, p in enumerate(parts):
        assert p.config == i
        assert sorted(p.train_groups + p.test_groups) == list(range(8))
    census = partition_census(A)
    assert census.loc[census["both_signs"] == both_signs, "n_partitions"].sum() == len(parts)


def test_a8_structure_has_no_partition_with_three_valid_test_groups():
    assert group_partitions(A8_STRUCTURE, min_test=3, both_signs=True) == []
    assert group_partitions(A8_STRUCTURE, min_test=4, both_signs=False) == []
    # two test groups remain possible, and none of them tests two of the duplicate groups 3, 4, 5
    two = group_partitions(A8_STRUCTURE, min_test=2, both_signs=True)
    assert two and all(len(set(p.test_groups) & {3, 4, 5}) == 0 for p in two)


def test_sample_of_partitions_is_seeded_and_a_subset():
    A = _random_attributes(n_attributes=16, seed=1)
    every = group_partitions(A, min_test=3, both_signs=False)
    assert len(every) > 5
    some = group_partitions(A, min_test=3, both_signs=False, max_partitions=5, random_state=2)
    assert len(some) == 5
    assert {p.test_groups for p in some} <= {p.test_groups for p in every}
    again = group_partitions(A, min_test=3, both_signs=False, max_partitions=5, random_state=2)
    assert [p.test_groups for p in again] == [p.test_groups for p in some]


@pytest.mark.parametrize("min_test", [1, 8, True, 2.5])
def test_min_test_out_of_range_is_refused(min_test):
    with pytest.raises(ConfigError, match="min_test"):
        group_partitions(_random_attributes(), min_test=min_test)


def _samples(A, informative, per_group=10, seed=0):
    rng = np.random.default_rng(seed)
    groups = np.repeat(np.arange(A.shape[0]), per_group + np.arange(A.shape[0]))  # unequal group sizes
    X = rng.normal(size=(groups.size, 20))
    if informative:
        X[:, : A.shape[1]] += 3.0 * A[groups]
    table = pd.DataFrame({"fabric_id": np.arange(groups.size), "group": groups})
    return FabricSamples("synthetic", "sample", X, groups, table, None)


def test_summary_columns_interval_and_chance():
    A = _random_attributes(n_attributes=16, seed=1)
    summary, parts = run_partitions([_samples(A, True)], A, min_test=4, both_signs=False, max_partitions=12)
    assert len(parts) == 12 and list(summary.columns) == list(PARTITION_COLUMNS)
    assert set(summary["metric"]) == {"class_mean", "trial"}
    chance = np.mean([1 / len(p.test_groups) for p in parts])
    assert np.allclose(summary["chance"], chance)
    assert (summary["ci95_low"] <= summary["accuracy"]).all() and (summary["accuracy"] <= summary["ci95_high"]).all()
    assert (summary["n_partitions"] == 12).all() and (summary["n_failed"] == 0).all()
    cm = summary.set_index("metric").loc["class_mean"]
    # always predicting one group recognises exactly one group per partition: 1 / n_test on class means
    assert cm["majority_baseline"] == pytest.approx(chance)
    assert cm["ci95_low"] > chance  # the attributes are in the features: recognisable above chance
    trial = summary.set_index("metric").loc["trial"]
    assert trial["majority_baseline"] > chance  # unequal group sizes: the largest group beats 1 / n_test


def test_uninformative_features_stay_near_chance():
    A = _random_attributes(n_attributes=16, seed=1)
    informative, _ = run_partitions([_samples(A, True)], A, min_test=4, both_signs=False, max_partitions=12)
    noise, _ = run_partitions([_samples(A, False)], A, min_test=4, both_signs=False, max_partitions=12)
    acc = {name: s.set_index("metric").loc["class_mean", "accuracy"] for name, s in
           (("informative", informative), ("noise", noise))}
    assert acc["noise"] < acc["informative"]
    assert noise.set_index("metric").loc["class_mean", "ci95_low"] < noise["chance"].iloc[0] + 0.15


def test_no_valid_partition_gives_an_empty_table():
    summary, parts = run_partitions([_samples(A8_STRUCTURE, True)], A8_STRUCTURE, min_test=4)
    assert parts == [] and summary.empty and list(summary.columns) == list(PARTITION_COLUMNS)


def test_config_option_reaches_the_study():
    on = validate({"study": "fabric", "partitions": {"enabled": True, "attributes": "a12", "both_signs": False}},
                  "t", Path("."))
    assert on.config.partitions.model_dump() == {"enabled": True, "attributes": "a12", "min_test": 4,
                                                 "both_signs": False, "max_partitions": None}
    assert not validate({"study": "fabric"}, "t", Path(".")).config.partitions.enabled
    with pytest.raises(ConfigError, match="min_test"):
        validate({"study": "fabric", "partitions": {"min_test": 1}}, "t", Path("."))
