"""Selection and confirmation splits (issue 23): no seed of one purpose draws a split of the other.

Tables here are SIMULATED (random 0/1 attribute rows); they exercise the draws, they measure nothing.
"""

from __future__ import annotations

from itertools import combinations

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tzsl.evaluation import PURPOSES, purpose_seed, random_object_splits, split_purpose
from tzsl.exceptions import SplitError
from tzsl.studies.config import SEED_LIMIT

N_OBJECTS, N_TEST = 9, 3  # 84 possible test sets: small enough for seeds to collide without the rule


def _table(n_objects: int = N_OBJECTS, n_attributes: int = 8, seed: int = 0) -> pd.DataFrame:
    """Distinct random attribute rows, every attribute with >= 2 positive and negative objects."""
    rng = np.random.default_rng(seed)
    while True:
        A = (rng.random((n_objects, n_attributes)) < 0.5).astype(int)
        if len(np.unique(A, axis=0)) == n_objects and (A.sum(0) >= 4).all() and (A.sum(0) <= n_objects - 4).all():
            break
    return pd.DataFrame(A, index=[f"obj{i}" for i in range(n_objects)], columns=[f"a{j}" for j in range(n_attributes)])


TABLE = _table()


def _test_sets(seed: int, purpose: str | None, n_splits: int = 4) -> set[frozenset]:
    splits = random_object_splits(TABLE, n_test=N_TEST, n_splits=n_splits, random_state=seed,
                                  min_train_positives=2, purpose=purpose)
    return {frozenset(s.test_objects) for s in splits}


@settings(max_examples=60, deadline=None, derandomize=True)
@given(select_seeds=st.lists(st.integers(0, SEED_LIMIT - 1), min_size=1, max_size=4),
       confirm_seeds=st.lists(st.integers(0, SEED_LIMIT - 1), min_size=1, max_size=4))
def test_no_confirmation_split_is_ever_a_selection_split(select_seeds, confirm_seeds):
    """Over any seeds of the allowed range, the drawn test sets of the two purposes never meet,
    and each split belongs to the purpose it was drawn for."""
    selected = set().union(*(_test_sets(s, "select") for s in select_seeds))
    confirmed = set().union(*(_test_sets(s, "confirm") for s in confirm_seeds))
    assert not selected & confirmed
    assert {split_purpose(t) for t in selected} == {"select"}
    assert {split_purpose(t) for t in confirmed} == {"confirm"}


def test_without_the_rule_seeds_do_share_splits():
    """The property above is not vacuous: on this table, unseparated draws of a few seeds collide."""
    drawn = [_test_sets(seed, None) for seed in range(12)]
    assert any(a & b for a, b in combinations(drawn, 2))


def test_the_partition_splits_the_test_sets_about_evenly_and_ignores_order():
    sets = [tuple(f"obj{i}" for i in c) for c in combinations(range(N_OBJECTS), N_TEST)]
    share = np.mean([split_purpose(s) == "select" for s in sets])
    assert 0.3 < share < 0.7
    assert all(split_purpose(s) == split_purpose(s[::-1]) for s in sets)


@given(seed=st.integers(0, SEED_LIMIT - 1))
def test_the_purpose_enters_the_seed(seed):
    seeds = {purpose_seed(seed, p) for p in PURPOSES}
    assert len(seeds) == 2 and all(0 <= s < 2**32 for s in seeds)
    assert purpose_seed(seed, None) == seed


def test_same_seed_and_purpose_give_the_same_splits_and_record_the_seed():
    a = random_object_splits(TABLE, n_test=N_TEST, n_splits=3, random_state=7, min_train_positives=2,
                             purpose="confirm")
    b = random_object_splits(TABLE, n_test=N_TEST, n_splits=2, random_state=7, min_train_positives=2,
                             purpose="confirm")
    assert a[:2] == b and {s.seed for s in a} == {7}


def test_bad_purpose_or_seed_is_one_clear_error():
    with pytest.raises(SplitError, match="purpose must be one of"):
        random_object_splits(TABLE, n_test=N_TEST, random_state=0, purpose="report")
    with pytest.raises(SplitError, match="needs an integer random_state"):
        random_object_splits(TABLE, n_test=N_TEST, random_state=np.random.RandomState(0), purpose="select")


def test_the_study_schema_defaults_to_confirmation_and_refuses_other_purposes():
    from pydantic import ValidationError

    from tzsl.studies.config import ZeroShotSplits

    assert ZeroShotSplits().purpose == ZeroShotSplits().purpose == "confirm"
    assert ZeroShotSplits(purpose="select").purpose == "select"
    with pytest.raises(ValidationError):
        ZeroShotSplits(purpose="report")


def test_the_command_line_takes_the_purpose():
    from click.testing import CliRunner

    from tzsl.cli import cli
    from tzsl.cli._dap_commands import evaluate_values
    from tzsl.studies.config import config_from_options

    for command in ("splits", "evaluate"):
        shown = CliRunner().invoke(cli, [command, "--help"])
        assert "--purpose [select|confirm]" in shown.output and "default: confirm" in shown.output
    values = evaluate_values(kind="random", splits_file=None, n_splits=1, n_test=4, multilabel=False, sweep=False,
                             out="o", dataset="phac2-penn", features_file=None, plain_dir=None, path=None,
                             undersampling=None, cv=None, grid=None, no_progress=True, no_cache=True, seed=3, n_jobs=1,
                             backend=None, scheduler=None, data_dir=None, purpose="select")
    assert config_from_options("phac2-dap", values).config.splits.purpose == "select"
