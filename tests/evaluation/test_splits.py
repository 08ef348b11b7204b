"""Random (F5) and challenging (F6) object splits on synthetic tables."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from tzsl.evaluation import (
    Split,
    attribute_exclusions,
    challenging_splits,
    check_attribute_table,
    duplicate_attribute_groups,
    random_object_splits,
)
from tzsl.exceptions import SplitError


def _table(A: np.ndarray) -> pd.DataFrame:
    A = np.asarray(A, dtype=int)
    return pd.DataFrame(
        A,
        index=[f"obj{i:02d}" for i in range(A.shape[0])],
        columns=[f"att{j}" for j in range(A.shape[1])],
    )


def _assert_split_rules(split: Split, table: pd.DataFrame, mtp: int, mtn: int) -> None:
    train, test = list(split.train_objects), list(split.test_objects)
    assert not set(train) & set(test)
    # exclusion rule holds exactly, attribute by attribute
    pos = table.loc[train].sum(axis=0)
    neg = len(train) - pos
    expected = [a for a in table.columns if pos[a] < mtp or neg[a] < mtn]
    assert [a for a, _ in split.excluded_attributes] == expected
    assert all(reason for _, reason in split.excluded_attributes)
    kept = list(split.kept_attributes)
    assert kept == [a for a in table.columns if a not in expected]
    # test vectors mutually different over the kept attributes
    assert not table.loc[test, kept].duplicated().any()
    # objects are listed in table order
    order = {o: i for i, o in enumerate(table.index)}
    assert [order[o] for o in train] == sorted(order[o] for o in train)
    assert [order[o] for o in test] == sorted(order[o] for o in test)


# --------------------------------------------------------------------------- random splits

tables = st.integers(4, 24).flatmap(
    lambda n: arrays(np.int8, st.tuples(st.just(n), st.integers(1, 6)), elements=st.integers(0, 1))
)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(A=tables, data=st.data())
def test_random_splits_properties(A, data):
    table = _table(A)
    n = len(table)
    n_distinct = len(np.unique(A, axis=0))
    n_test = data.draw(st.integers(1, max(1, min(n - 1, n_distinct))), label="n_test")
    n_splits = data.draw(st.integers(1, 4), label="n_splits")
    mtp = data.draw(st.integers(0, 3), label="min_train_positives")
    seed = data.draw(st.integers(0, 2**31 - 1), label="seed")
    kwargs = dict(n_test=n_test, n_splits=n_splits, random_state=seed, min_train_positives=mtp, max_draws=50)
    try:
        splits = random_object_splits(table, **kwargs)
    except SplitError as exc:
        # only legitimate when the draws kept failing: the message says why
        assert "no valid draw" in str(exc) and "rejected for" in str(exc)
        return
    assert len(splits) == n_splits
    assert [s.name for s in splits] == [f"random-{k}" for k in range(1, n_splits + 1)]
    for s in splits:
        assert s.kind == "random" and s.seed == seed
        assert len(s.test_objects) == n_test and len(s.train_objects) == n - n_test
        assert set(s.train_objects) | set(s.test_objects) == set(table.index)
        assert s.attributes == tuple(table.columns)
        _assert_split_rules(s, table, mtp, 1)
    # seeded and reproducible
    assert random_object_splits(table, **kwargs) == splits


def test_random_splits_seed_changes_draw_and_prefix_is_stable():
    rng = np.random.default_rng(1)
    table = _table(rng.integers(0, 2, size=(40, 8)))
    a = random_object_splits(table, n_test=6, n_splits=5, random_state=3, min_train_positives=1)
    b = random_object_splits(table, n_test=6, n_splits=5, random_state=4, min_train_positives=1)
    c = random_object_splits(table, n_test=6, n_splits=2, random_state=3, min_train_positives=1)
    assert [s.test_objects for s in a] != [s.test_objects for s in b]
    assert c == a[:2]
    # a RandomState instance works too, the seed is then unknown
    d = random_object_splits(table, n_test=6, n_splits=1, random_state=np.random.RandomState(3), min_train_positives=1)
    assert d[0].seed is None and d[0].test_objects == a[0].test_objects


def test_random_splits_redraw_rejects_duplicate_test_vectors():
    # 2 groups of identical objects: any valid 2-object test set takes one of each group
    table = _table([[1, 0]] * 5 + [[0, 1]] * 5)
    for s in random_object_splits(table, n_test=2, n_splits=20, random_state=0, min_train_positives=0):
        vecs = table.loc[list(s.test_objects)].to_numpy()
        assert not (vecs[0] == vecs[1]).all()


def test_random_splits_report_exclusion_when_positives_leave_training():
    # att1 has exactly 3 positives; a test set holding one of them excludes att1
    A = np.zeros((12, 2), dtype=int)
    A[:, 0] = np.arange(12) % 2
    A[[0, 1, 2], 1] = 1
    table = _table(A)
    found_excluded = found_kept = False
    for s in random_object_splits(table, n_test=2, n_splits=30, random_state=0, min_train_positives=3):
        n_pos_test = len({"obj00", "obj01", "obj02"} & set(s.test_objects))
        has_pos = n_pos_test > 0
        excluded = dict(s.excluded_attributes)
        assert ("att1" in excluded) == has_pos
        if has_pos:
            assert excluded["att1"] == f"{3 - n_pos_test} positive training object(s) < 3"
            found_excluded = True
        else:
            found_kept = True
    assert found_excluded and found_kept


def test_random_splits_impossible_constraints():
    table = _table([[1, 0]] * 5 + [[0, 1]] * 5)
    with pytest.raises(SplitError, match="only 2 distinct vectors"):
        random_object_splits(table, n_test=3)
    with pytest.raises(SplitError, match="leaves no training object"):
        random_object_splits(table, n_test=10)
    # every draw leaves an attribute-less split: bounded number of draws, then a clear error
    with pytest.raises(SplitError, match=r"no valid draw .* in 25 draws .*every attribute excluded"):
        random_object_splits(table, n_test=2, min_train_positives=9, max_draws=25)
    with pytest.raises(SplitError, match="n_splits must be a positive integer"):
        random_object_splits(table, n_test=2, n_splits=0)


@pytest.mark.parametrize(
    "bad, match",
    [
        (pd.DataFrame([[0, 1], [1, 2]], index=["a", "b"], columns=["x", "y"]), r"object 'b', attribute 'y': 2"),
        (pd.DataFrame([[0, np.nan], [1, 0]], index=["a", "b"], columns=["x", "y"]), r"object 'a', attribute 'y'"),
        (pd.DataFrame([[0, "yes"], [1, 0]], index=["a", "b"], columns=["x", "y"]), r"'yes'"),
        (pd.DataFrame([[0, 1], [1, 0]], index=["a", "a"], columns=["x", "y"]), r"duplicate object name\(s\) \['a'\]"),
        (pd.DataFrame(np.zeros((0, 2))), "empty"),
        (np.zeros((3, 2)), "must be a pandas DataFrame"),
    ],
)
def test_attribute_table_validation(bad, match):
    with pytest.raises(SplitError, match=match):
        check_attribute_table(bad)
    with pytest.raises(SplitError, match=match):
        random_object_splits(bad, n_test=1)


def test_attribute_exclusions_and_duplicate_groups():
    A = np.array([[1, 0, 1], [1, 0, 1], [0, 0, 1], [1, 0, 1]], dtype=bool)
    out = attribute_exclusions(A, ["p", "q", "r"], min_train_positives=3, min_train_negatives=1)
    assert out == (
        ("q", "0 positive training object(s) < 3"),
        ("r", "0 negative training object(s) < 1"),
    )
    groups = duplicate_attribute_groups(A)
    assert [g.tolist() for g in groups] == [[0, 1, 3]]
    assert duplicate_attribute_groups(A[:1]) == []


# --------------------------------------------------------------------------- challenging splits

# Hand-made map, symmetric under y -> -y with zero mean, var(x) >> var(y): PCA is the identity
# (sklearn flips component signs so their largest entry is positive), so the map is the input.
POINTS = {
    "lu1": (-5, 1), "lu2": (-4, 2), "lu3": (-6, 0.5),  # left wedge, upper half
    "ll1": (-5, -1), "ll2": (-4, -2), "ll3": (-6, -0.5),  # left wedge, lower half
    "b1": (1, -3),  # bottom
    "r1": (6, 1), "r2": (6, -1), "r3": (7, 2), "r4": (7, -2), "r5": (2, 0),  # right
    "t1": (1, 3),  # top
}
EXPECTED = {"lu": (1, "left-upper"), "ll": (2, "left-lower"), "b": (3, "bottom"), "r": (4, "right"), "t": (5, "top")}


def _geometry(points: dict[str, tuple[float, float]], A: np.ndarray | None = None):
    names = list(points)
    feats = pd.DataFrame([points[n] for n in names], index=names, columns=["f0", "f1"], dtype=float)
    if A is None:  # distinct binary codes
        A = (np.arange(1, len(names) + 1)[:, None] >> np.arange(4)) & 1
    attrs = pd.DataFrame(A, index=names, columns=[f"att{j}" for j in range(np.shape(A)[1])])
    return feats, attrs


def test_challenging_geometry_hand_made():
    feats, attrs = _geometry(POINTS)
    splits, m = challenging_splits(feats, attrs, standardize=False, min_train_positives=0, min_train_negatives=0)
    m = m.set_index("object")
    np.testing.assert_allclose(m[["x", "y"]].to_numpy(), feats.to_numpy() - feats.mean().to_numpy(), atol=1e-9)
    assert m.attrs["halved_wedge"] == "left"
    assert m.attrs["wedge_counts"] == {"left": 6, "bottom": 1, "right": 5, "top": 1}
    for obj in POINTS:
        part, label = EXPECTED[obj.rstrip("0123456789")]
        assert (m.loc[obj, "partition"], m.loc[obj, "partition_label"]) == (part, label), obj
    assert [s.name for s in splits] == [f"challenging-{k}" for k in range(1, 6)]
    for k, s in enumerate(splits, start=1):
        assert set(s.test_objects) == set(m.index[m["partition"] == k])
        assert set(s.train_objects) == set(m.index[m["partition"] != k])
        assert s.kind == "challenging" and s.dropped_objects == () and s.excluded_attributes == ()


def test_challenging_trial_rows_are_averaged_per_object():
    # two "trials" per object symmetric about the object's point: same map as one row per object
    feats, attrs = _geometry(POINTS)
    jitter = np.array([0.3, -0.2])
    trials = pd.concat([feats + jitter, feats - jitter]).sort_index()
    _, m1 = challenging_splits(feats, attrs, standardize=False, min_train_positives=0, min_train_negatives=0)
    _, m2 = challenging_splits(trials, attrs, standardize=False, min_train_positives=0, min_train_negatives=0)
    assert m2["object"].tolist() == list(attrs.index)
    assert m2["partition"].tolist() == m1["partition"].tolist()


# Dense top wedge: again symmetric (x -> -x), zero mean, var(x) > var(y), so PCA is the identity.
TOP_POINTS = {
    "tr1": (0.5, 3), "tr2": (1, 4), "tr3": (0.3, 2.5), "tl1": (-0.5, 3), "tl2": (-1, 4), "tl3": (-0.3, 2.5),
    "b1": (0.5, -9.5), "b2": (-0.5, -9.5), "l1": (-20, 0), "r1": (20, 0),
}


@pytest.mark.parametrize(
    "points, halved, order",
    [
        ({n: (-x, y) for n, (x, y) in POINTS.items()}, "right",
         ["right-lower", "right-upper", "top", "left", "bottom"]),
        (TOP_POINTS, "top", ["top-right", "top-left", "left", "bottom", "right"]),
    ],
)
def test_challenging_densest_wedge_is_halved(points, halved, order):
    feats, attrs = _geometry(points)
    splits, m = challenging_splits(feats, attrs, standardize=False, min_train_positives=0, min_train_negatives=0)
    assert m.attrs["halved_wedge"] == halved
    labels = m.drop_duplicates("partition").sort_values("partition")["partition_label"].tolist()
    assert labels == order
    # the halved wedge's two halves hold 3 objects each
    assert m.groupby("partition_label").size()[order[:2]].tolist() == [3, 3]
    if halved != "right":
        return
    # the paper's choice can be forced
    _, m_left = challenging_splits(feats, attrs, standardize=False, halve="left", min_train_positives=0,
                                   min_train_negatives=0)
    assert m_left.attrs["halved_wedge"] == "left"


def test_challenging_drops_duplicate_test_vectors_and_reports_exclusions():
    feats, attrs = _geometry(POINTS)
    A = attrs.to_numpy().copy()
    A[:, 3] = 0
    A[[0, 1, 2], 3] = 1  # att3 only on the left-upper objects -> excluded when they are tested
    A[2] = A[0]  # lu3 repeats lu1's vector
    attrs = pd.DataFrame(A, index=attrs.index, columns=attrs.columns)
    splits, m = challenging_splits(feats, attrs, standardize=False, min_train_positives=1, min_train_negatives=0)
    s1 = splits[0]
    assert s1.test_objects == ("lu1", "lu2")
    assert s1.dropped_objects == (("lu3", "same attribute vector as test object 'lu1'"),)
    assert "lu3" not in s1.train_objects
    assert dict(s1.excluded_attributes) == {"att3": "0 positive training object(s) < 1"}
    assert m.set_index("object")["dropped"].to_dict()["lu3"]
    assert m["dropped"].sum() == 1
    # other splits train on all three left-upper objects and keep att3
    assert all("lu3" in s.train_objects and s.excluded_attributes == () for s in splits[1:])


def test_challenging_exclusion_can_reveal_duplicates():
    # lu1 and lu2 differ only in att3, which no training object has: they collide once it is left out
    feats, attrs = _geometry(POINTS)
    A = np.zeros((len(POINTS), 4), dtype=int)
    A[:, :3] = (np.arange(1, len(POINTS) + 1)[:, None] >> np.arange(3)) & 1
    A[0, :3] = A[1, :3] = [1, 1, 1]
    A[0, 3] = 1
    attrs = pd.DataFrame(A, index=attrs.index, columns=attrs.columns)
    splits, _ = challenging_splits(feats, attrs, standardize=False, min_train_positives=1, min_train_negatives=0)
    assert dict(splits[0].excluded_attributes).keys() == {"att3"}
    assert [d for d, _ in splits[0].dropped_objects] == ["lu2"]


@settings(max_examples=25, deadline=None)
@given(
    P=arrays(np.float64, st.tuples(st.integers(10, 30), st.just(3)), elements=st.floats(-10, 10, allow_nan=False)),
    seed=st.integers(0, 1000),
)
def test_challenging_partition_follows_the_map(P, seed):
    n = P.shape[0]
    rng = np.random.default_rng(seed)
    feats = pd.DataFrame(P, index=[f"o{i}" for i in range(n)])
    attrs = pd.DataFrame(rng.integers(0, 2, size=(n, 5)), index=feats.index)
    attrs.columns = [f"a{j}" for j in range(5)]
    try:
        splits, m = challenging_splits(feats, attrs, min_train_positives=1)
    except SplitError as exc:
        assert "hold no object" in str(exc) or "do not vary" in str(exc)
        return
    x, y = m["x"].to_numpy(), m["y"].to_numpy()
    wedge = m["wedge"].to_numpy()
    tol = 1e-9
    assert np.all(x[wedge == "left"] <= -np.abs(y[wedge == "left"]) + tol)
    assert np.all(x[wedge == "right"] >= np.abs(y[wedge == "right"]) - tol)
    assert np.all(y[wedge == "top"] >= np.abs(x[wedge == "top"]) - tol)
    assert np.all(y[wedge == "bottom"] <= -np.abs(x[wedge == "bottom"]) + tol)
    counts = m.attrs["wedge_counts"]
    assert counts[m.attrs["halved_wedge"]] == max(counts.values())
    assert sorted(m["partition"].unique()) == [1, 2, 3, 4, 5]
    seen = []
    for k, s in enumerate(splits, start=1):
        part = set(m["object"][m["partition"] == k])
        assert set(s.test_objects) | {d for d, _ in s.dropped_objects} == part
        assert set(s.train_objects) == set(m["object"]) - part
        _assert_split_rules(s, attrs, 1, 1)
        seen += list(s.test_objects) + [d for d, _ in s.dropped_objects]
    assert sorted(seen) == sorted(feats.index)


def test_challenging_bad_input():
    feats, attrs = _geometry(POINTS)
    kw = dict(standardize=False, min_train_positives=0, min_train_negatives=0)
    with pytest.raises(SplitError, match=r"not in the attribute table: \['ghost'\]"):
        challenging_splits(pd.concat([feats, pd.DataFrame([[0.0, 0.0]], index=["ghost"], columns=feats.columns)]),
                           attrs, **kw)
    with pytest.raises(SplitError, match=r"have no features: \['t1'\]"):
        challenging_splits(feats.drop(index="t1"), attrs, **kw)
    with pytest.raises(SplitError, match=r"NaN or infinite .*'b1'"):
        challenging_splits(feats.assign(f0=feats["f0"].where(feats.index != "b1")), attrs, **kw)
    with pytest.raises(SplitError, match="halve must be"):
        challenging_splits(feats, attrs, halve="north", **kw)
    with pytest.raises(SplitError, match=r"partition\(s\) \['top'\] hold no object"):
        challenging_splits(feats.drop(index="t1"), attrs.drop(index="t1"), **kw)
