"""The cross-dataset benchmark's statistics and figures (tzsl.studies.benchmark)."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

from tzsl.evaluation import bootstrap_accuracy
from tzsl.exceptions import ConfigError, TzslError
from tzsl.studies.benchmark.figures import critical_difference_diagram, meta_analysis_figure
from tzsl.studies.benchmark.statistics import (
    MIN_VARIANCE,
    critical_difference,
    dataset_ranks,
    friedman_test,
    mean_ranks,
    meta_analysis,
    nemenyi_q,
    paired_effects,
    per_dataset_table,
    rank_groups,
)

# Demšar (2006), Table 5(a): critical values of the two-tailed Nemenyi test, k = 2..10.
DEMSAR_Q05 = [1.960, 2.343, 2.569, 2.728, 2.850, 2.949, 3.031, 3.102, 3.164]
DEMSAR_Q10 = [1.645, 2.052, 2.291, 2.459, 2.589, 2.693, 2.780, 2.855, 2.920]


def long_scores(table: dict[str, dict[str, list[float]]]) -> pd.DataFrame:
    """{dataset: {method: [score per split]}} -> the long scores table (split = position)."""
    return pd.DataFrame([{"dataset": d, "method": m, "split": s, "score": v}
                         for d, methods in table.items() for m, values in methods.items()
                         for s, v in enumerate(values)])


def dl_reference(d: list[float], v: list[float]) -> tuple[float, float, float]:
    """DerSimonian-Laird written out term by term: (effect, se, tau2)."""
    w = [1 / x for x in v]
    fixed = sum(wi * di for wi, di in zip(w, d, strict=True)) / sum(w)
    q = sum(wi * (di - fixed) ** 2 for wi, di in zip(w, d, strict=True))
    c = sum(w) - sum(wi * wi for wi in w) / sum(w)
    tau2 = max(0.0, (q - (len(d) - 1)) / c) if len(d) > 1 else 0.0
    ws = [1 / (x + tau2) for x in v]
    return sum(wi * di for wi, di in zip(ws, d, strict=True)) / sum(ws), 1 / math.sqrt(sum(ws)), tau2


# ---------------------------------------------------------------- Nemenyi and Friedman: published values


@pytest.mark.parametrize("alpha, table", [(0.05, DEMSAR_Q05), (0.10, DEMSAR_Q10)])
def test_nemenyi_q_matches_demsar_table(alpha, table):
    ours = [round(nemenyi_q(k, alpha), 3) for k in range(2, 11)]
    assert ours == pytest.approx(table, abs=1.5e-3)


def test_demsar_worked_example_friedman_and_cd():
    # Demšar (2006) section 3.2.4: four C4.5 variants on 14 data sets, mean ranks 3.143, 2.000,
    # 2.893, 1.964 (rank sums 44, 28, 40.5, 27.5); chi2_F = 9.28, F_F = 3.69, CD = 1.25.
    ranks = pd.DataFrame({"method": ["C4.5", "C4.5+m", "C4.5+cf", "C4.5+m+cf"],
                          "mean_rank": np.array([44, 28, 40.5, 27.5]) / 14, "n_datasets": 14})
    result = friedman_test(ranks)
    assert round(result.chi2, 2) == 9.28 and round(result.f, 2) == 3.69
    assert (result.n_datasets, result.n_methods) == (14, 4)
    # both reject at 0.05: Demšar quotes the critical values 7.8 (chi2, 3 df) and 2.85 (F(3, 39))
    assert result.chi2_pvalue < 0.05 and result.f_pvalue < 0.05
    assert round(stats.chi2.ppf(0.95, 3), 1) == 7.8 and round(stats.f.ppf(0.95, 3, 39), 2) == 2.85
    assert round(critical_difference(4, 14), 2) == 1.25
    assert round(critical_difference(4, 14, alpha=0.10), 2) == 1.12


@settings(max_examples=25, deadline=None)
@given(st.integers(2, 12), st.integers(2, 7), st.integers(0, 2**31 - 1))
def test_friedman_matches_scipy_and_iman_davenport_without_ties(n, k, seed):
    rng = np.random.default_rng(seed)
    scores = rng.permutation(np.linspace(0.05, 0.95, n * k)).reshape(n, k)  # distinct: no ties
    table = pd.DataFrame([{"dataset": f"d{i}", "method": f"m{j}", "split": 0, "score": scores[i, j]}
                          for i in range(n) for j in range(k)])
    ours = friedman_test(table)
    if k > 2:
        reference = stats.friedmanchisquare(*scores.T)
        assert ours.chi2 == pytest.approx(reference.statistic)
        assert ours.chi2_pvalue == pytest.approx(reference.pvalue)
    r = stats.rankdata(-scores, axis=1).mean(axis=0)
    chi2 = 12 * n / (k * (k + 1)) * (np.sum(r**2) - k * (k + 1) ** 2 / 4)
    assert ours.chi2 == pytest.approx(chi2, abs=1e-9)
    if chi2 < n * (k - 1):
        assert ours.f == pytest.approx((n - 1) * chi2 / (n * (k - 1) - chi2))
        assert ours.f_pvalue == pytest.approx(stats.f.sf(ours.f, k - 1, (k - 1) * (n - 1)))
    else:
        assert ours.f == math.inf and ours.f_pvalue == 0.0
    # the three inputs agree
    for other in (friedman_test(mean_ranks(table)), friedman_test(dataset_ranks(table))):
        assert np.allclose(other, ours, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("table", [
    {"a": {"x": [0.5], "y": [0.6]}},  # one dataset
    {"a": {"x": [0.5]}, "b": {"x": [0.4]}},  # one method
])
def test_friedman_refuses_fewer_than_two_datasets_or_methods(table):
    with pytest.raises(ConfigError, match="at least 2 datasets and 2 methods"):
        friedman_test(long_scores(table))


def test_critical_difference_arguments():
    assert critical_difference(3, 5) == pytest.approx(nemenyi_q(3) * math.sqrt(3 * 4 / 30))
    for bad in [dict(k=1, n_datasets=5), dict(k=3, n_datasets=0), dict(k=3, n_datasets=5, alpha=1.5)]:
        with pytest.raises(ConfigError):
            critical_difference(**bad)


# ---------------------------------------------------------------- per-dataset table and ranks


def test_per_dataset_table_by_hand():
    table = long_scores({"a": {"x": [0.5, 0.7, 0.6], "y": [0.2]}, "b": {"x": [0.9, 0.8], "y": [0.1, 0.3]}})
    out = per_dataset_table(table, pd.Series({"a": 0.25, "b": 0.1}), n_boot=500)
    assert list(out.columns) == ["dataset", "method", "score", "ci95_low", "ci95_high", "n_splits", "chance",
                                 "gain_over_chance"]
    row = out.set_index(["dataset", "method"])
    assert row.loc[("a", "x"), "score"] == pytest.approx(0.6) and row.loc[("a", "x"), "n_splits"] == 3
    assert row.loc[("a", "x"), "gain_over_chance"] == pytest.approx(0.35)
    assert row.loc[("b", "y"), "chance"] == 0.1 and row.loc[("b", "y"), "gain_over_chance"] == pytest.approx(0.1)
    # the interval is the package's bootstrap at the split level
    expected = bootstrap_accuracy([0.5, 0.7, 0.6], classes=[0, 0, 0], splits=[0, 1, 2], n_boot=500)
    assert (row.loc[("a", "x"), "ci95_low"], row.loc[("a", "x"), "ci95_high"]) == (expected.ci95_low,
                                                                                  expected.ci95_high)
    assert 0.5 <= expected.ci95_low <= 0.6 <= expected.ci95_high <= 0.7
    # a method with one split has no interval
    assert np.isnan(row.loc[("a", "y"), ["ci95_low", "ci95_high"]].astype(float)).all()


def test_chance_from_a_column_and_missing_chance():
    table = long_scores({"a": {"x": [0.5, 0.7]}, "b": {"x": [0.9, 0.8]}}).assign(chance=[0.2, 0.4, 0.1, 0.1])
    out = per_dataset_table(table, n_boot=50)
    assert out["chance"].tolist() == pytest.approx([0.3, 0.1])
    assert np.isnan(per_dataset_table(table.drop(columns="chance"), n_boot=50)["chance"]).all()
    with pytest.raises(TzslError, match="no chance accuracy for dataset"):
        per_dataset_table(table, {"a": 0.2}, n_boot=50)


def test_mean_ranks_by_hand_with_a_tie():
    table = long_scores({
        "a": {"x": [0.9, 0.7], "y": [0.6], "z": [0.1, 0.3]},  # x 0.8, y 0.6, z 0.2 -> 1, 2, 3
        "b": {"x": [0.5, 0.5], "y": [0.4, 0.6], "z": [0.9]},  # z 0.9, x = y = 0.5 -> 2.5, 2.5, 1
    })
    out = mean_ranks(table, {"a": 0.1, "b": 0.2}).set_index("method")
    assert out["mean_rank"].to_dict() == {"x": 1.75, "y": 2.25, "z": 2.0}
    assert out.loc["x", "mean_score"] == pytest.approx(0.65)
    assert out.loc["z", "mean_gain_over_chance"] == pytest.approx(((0.2 - 0.1) + (0.9 - 0.2)) / 2)
    assert (out["n_datasets"] == 2).all()
    assert list(mean_ranks(table)["method"]) == ["x", "z", "y"]  # best first


def test_a_dataset_lacking_a_method_is_left_out_of_the_ranks():
    table = long_scores({"a": {"x": [0.9], "y": [0.1]}, "b": {"x": [0.2], "y": [0.4]}, "c": {"x": [0.5]}})
    with pytest.warns(UserWarning, match=r"\['c'\] left out of the ranks"):
        ranks = dataset_ranks(table)
    assert list(ranks.index) == ["a", "b"]


@settings(max_examples=25, deadline=None)
@given(st.integers(1, 6), st.integers(1, 6), st.integers(0, 2**31 - 1))
def test_ranks_sum_to_k_k_plus_1_over_2(n, k, seed):
    rng = np.random.default_rng(seed)
    values = rng.integers(0, 4, size=(n, k, 2)) / 4  # coarse values: many ties
    table = pd.DataFrame([{"dataset": i, "method": f"m{j}", "split": s, "score": values[i, j, s]}
                          for i in range(n) for j in range(k) for s in range(2)])
    ranks = dataset_ranks(table)
    assert ranks.shape == (n, k)
    assert np.allclose(ranks.sum(axis=1), k * (k + 1) / 2)
    assert ((ranks >= 1) & (ranks <= k)).all().all()
    assert mean_ranks(table)["mean_rank"].sum() == pytest.approx(k * (k + 1) / 2)


def test_rank_groups():
    ranks = pd.Series({"a": 1.0, "b": 1.5, "c": 2.2, "d": 3.9, "e": 4.0})
    assert rank_groups(ranks, 1.25) == [("a", "b", "c"), ("d", "e")]
    assert rank_groups(ranks, 0.05) == []
    assert rank_groups(ranks, 10) == [("a", "b", "c", "d", "e")]


# ---------------------------------------------------------------- meta-analysis


def test_meta_analysis_by_hand():
    table = long_scores({
        "a": {"x": [0.6, 0.7, 0.8], "y": [0.5, 0.5, 0.6]},  # differences 0.1, 0.2, 0.2
        "b": {"x": [0.4, 0.4, 0.5, 0.3], "y": [0.4, 0.2, 0.5, 0.4]},  # differences 0, 0.2, 0, -0.1
        "c": {"x": [0.3, 0.9, 0.5], "y": [0.1, 0.2, 0.6]},  # differences 0.2, 0.7, -0.1
    })
    per = paired_effects(table).set_index(["dataset", "method_a", "method_b"])
    diffs = {"a": [0.1, 0.2, 0.2], "b": [0, 0.2, 0, -0.1], "c": [0.2, 0.7, -0.1]}
    for dataset, values in diffs.items():
        row = per.loc[(dataset, "x", "y")]
        assert row["difference"] == pytest.approx(np.mean(values))
        assert row["se"] == pytest.approx(np.std(values, ddof=1) / math.sqrt(len(values)))
        assert row["smd"] == pytest.approx(np.mean(values) / np.std(values, ddof=1))
    effect, se, tau2 = dl_reference([np.mean(v) for v in diffs.values()],
                                    [np.var(v, ddof=1) / len(v) for v in diffs.values()])
    meta = meta_analysis(table).set_index(["method_a", "method_b"])
    row = meta.loc[("x", "y")]
    assert row["effect"] == pytest.approx(effect) and row["se"] == pytest.approx(se)
    assert row["tau2"] == pytest.approx(tau2)
    assert row["ci95_low"] == pytest.approx(effect - stats.norm.ppf(0.975) * se)
    assert row["p_value"] == pytest.approx(2 * stats.norm.sf(abs(effect / se)))
    assert row["n_datasets"] == 3 and row["n_datasets_left_out"] == 0
    assert 0 <= row["i2"] < 1
    assert meta.loc[("y", "x"), "effect"] == pytest.approx(-effect)


def test_meta_analysis_of_one_dataset_is_its_paired_effect():
    table = long_scores({"a": {"x": [0.6, 0.7, 0.8, 0.5], "y": [0.5, 0.5, 0.6, 0.55]}})
    d = np.array([0.1, 0.2, 0.2, -0.05])
    row = meta_analysis(table).set_index(["method_a", "method_b"]).loc[("x", "y")]
    se = np.std(d, ddof=1) / 2
    assert row["effect"] == pytest.approx(d.mean()) and row["se"] == pytest.approx(se)
    assert row["tau2"] == 0 and np.isnan(row["i2"]) and np.isnan(row["q"])
    assert row["ci95_high"] == pytest.approx(d.mean() + stats.norm.ppf(0.975) * se)
    assert row["smd"] == pytest.approx(d.mean() / np.std(d, ddof=1))


@settings(max_examples=25, deadline=None)
@given(st.lists(st.floats(0.05, 0.95), min_size=2, max_size=6), st.lists(st.floats(0.05, 0.95), min_size=6,
       max_size=6), st.integers(1, 5))
def test_identical_datasets_have_no_heterogeneity(first, second, n_datasets):
    n = len(first)
    one = {"x": first, "y": second[:n]}
    meta = meta_analysis(long_scores({f"d{i}": one for i in range(n_datasets)}))
    row = meta.set_index(["method_a", "method_b"]).loc[("x", "y")]
    d = np.subtract(first, second[:n])
    assert row["tau2"] == pytest.approx(0, abs=1e-12)
    assert row["effect"] == pytest.approx(d.mean(), abs=1e-12)
    var = max(np.var(d, ddof=1) / n, MIN_VARIANCE)
    assert row["se"] == pytest.approx(math.sqrt(var / n_datasets), rel=1e-6)
    assert row["n_datasets"] == n_datasets


@settings(max_examples=25, deadline=None)
@given(st.integers(1, 5), st.integers(2, 4), st.integers(2, 6), st.integers(0, 2**31 - 1))
def test_swapping_the_methods_negates_the_effect(n_datasets, k, n_splits, seed):
    rng = np.random.default_rng(seed)
    table = pd.DataFrame([{"dataset": d, "method": f"m{j}", "split": s, "score": rng.random()}
                          for d in range(n_datasets) for j in range(k) for s in range(n_splits)])
    meta = meta_analysis(table).set_index(["method_a", "method_b"])
    assert len(meta) == k * (k - 1)
    swapped = meta.copy()
    swapped.index = swapped.index.swaplevel()
    swapped = swapped.loc[meta.index]
    for column in ["effect", "z", "smd"]:
        assert np.allclose(meta[column], -swapped[column], equal_nan=True)
    assert np.allclose(meta["ci95_low"], -swapped["ci95_high"])
    for column in ["se", "p_value", "tau2", "n_datasets"]:
        assert np.allclose(meta[column], swapped[column], equal_nan=True)


def test_meta_analysis_uses_shared_splits_and_counts_left_out_datasets():
    table = long_scores({
        "a": {"x": [0.6, 0.7, 0.8], "y": [0.5, 0.5, 0.6]},
        "b": {"x": [0.4, 0.4, 0.5], "y": [0.4, 0.2, 0.5]},
        "c": {"x": [0.4, 0.4, 0.5], "y": [0.4, np.nan, np.nan]},  # y failed on 2 splits: 1 shared
    })
    table.loc[(table["dataset"] == "b") & (table["method"] == "y") & (table["split"] == 0), "score"] = np.nan
    per = paired_effects(table).set_index(["dataset", "method_a", "method_b"])
    assert per.loc[("b", "x", "y"), "n_splits"] == 2
    assert per.loc[("b", "x", "y"), "difference"] == pytest.approx(0.1)  # splits 1, 2 only: 0.2, 0
    assert per.loc[("c", "x", "y"), "n_splits"] == 1 and np.isnan(per.loc[("c", "x", "y"), "se"])
    row = meta_analysis(table).set_index(["method_a", "method_b"]).loc[("x", "y")]
    assert (row["n_datasets"], row["n_datasets_left_out"]) == (2, 1)


def test_identical_methods_give_no_effect():
    same = [0.3, 0.5, 0.7]
    row = meta_analysis(long_scores({"a": {"x": same, "y": same}, "b": {"x": same, "y": same}})).iloc[0]
    assert row["effect"] == 0 and row["p_value"] == 1 and row["smd"] == 0 and row["tau2"] == 0


def test_a_pair_with_no_shared_splits_has_nan_statistics():
    table = long_scores({"a": {"x": [0.6, np.nan], "y": [np.nan, 0.5]}})
    row = meta_analysis(table).iloc[0]
    assert row["n_datasets"] == 0 and row["n_datasets_left_out"] == 1
    assert np.isnan(row[["effect", "se", "ci95_low", "p_value", "tau2", "smd"]].astype(float)).all()


# ---------------------------------------------------------------- hostile inputs


@pytest.mark.parametrize("score, message", [(math.inf, r"in \[0, 1\]"), (1.5, r"in \[0, 1\]"),
                                            ("good", "numeric")])
def test_bad_scores_are_refused(score, message):
    table = long_scores({"a": {"x": [0.5, 0.6], "y": [0.5, 0.6]}}).astype({"score": object})
    table.loc[0, "score"] = score
    for function in (per_dataset_table, mean_ranks, meta_analysis):
        with pytest.raises(TzslError, match=message):
            function(table)


def test_malformed_tables_are_refused():
    table = long_scores({"a": {"x": [0.5, 0.6], "y": [0.5, 0.6]}})
    with pytest.raises(TzslError, match="lack column"):
        mean_ranks(table.drop(columns="split"))
    with pytest.raises(TzslError, match="several rows"):
        meta_analysis(pd.concat([table, table.iloc[:1]]))
    with pytest.raises(TzslError, match="no score"):
        per_dataset_table(table.assign(score=np.nan))
    with pytest.raises(TzslError, match="DataFrame"):
        friedman_test(table.to_numpy())  # type: ignore[arg-type]


def test_nan_scores_are_failed_fits_and_a_single_split_method_still_counts():
    table = long_scores({"a": {"x": [0.5, np.nan, 0.7], "y": [0.4]}, "b": {"x": [0.9, 0.8], "y": [np.nan, 0.6]}})
    out = per_dataset_table(table, n_boot=50).set_index(["dataset", "method"])
    assert out["n_splits"].to_dict() == {("a", "x"): 2, ("a", "y"): 1, ("b", "x"): 2, ("b", "y"): 1}
    assert out.loc[("a", "x"), "score"] == pytest.approx(0.6)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert mean_ranks(table)["method"].tolist() == ["x", "y"]
    meta = meta_analysis(table)  # one shared split on each dataset: nothing to pool
    assert meta["n_datasets"].tolist() == [0, 0] and meta["n_datasets_left_out"].tolist() == [2, 2]


# ---------------------------------------------------------------- figures


def _is_png(path) -> bool:
    data = path.read_bytes()
    return len(data) > 1000 and data[:8] == b"\x89PNG\r\n\x1a\n"


def test_figures_are_written_as_png(tmp_path):
    rng = np.random.default_rng(0)
    table = pd.DataFrame([{"dataset": d, "method": m, "split": s, "score": min(1.0, base + 0.1 * rng.random())}
                          for d in "abcde" for m, base in [("dap", 0.5), ("eszsl", 0.55), ("chance", 0.2),
                                                           ("ale", 0.3)] for s in range(4)])
    ranks = mean_ranks(table)
    cd = critical_difference(len(ranks), int(ranks["n_datasets"].iloc[0]))
    out = critical_difference_diagram(ranks, cd, tmp_path / "figs" / "cd.png", title="benchmark")
    assert _is_png(out)
    assert _is_png(critical_difference_diagram(ranks.set_index("method")["mean_rank"], 0.0, tmp_path / "cd0.png"))
    forest = meta_analysis_figure(meta_analysis(table), "chance", tmp_path / "forest.png")
    assert _is_png(forest)
    assert sorted(p.name for p in tmp_path.rglob("*") if p.is_file()) == ["cd.png", "cd0.png", "forest.png"]


def test_figures_refuse_what_they_cannot_draw(tmp_path):
    table = long_scores({"a": {"x": [0.6, 0.7], "y": [0.5, 0.5]}})
    with pytest.raises(TzslError, match="reference method 'z'"):
        meta_analysis_figure(meta_analysis(table), "z", tmp_path / "f.png")
    with pytest.raises(TzslError, match="at least 2 methods"):
        critical_difference_diagram(pd.Series({"x": 1.0}), 1.0, tmp_path / "c.png")
    with pytest.raises(TzslError, match="critical difference"):
        critical_difference_diagram(pd.Series({"x": 1.0, "y": 2.0}), math.nan, tmp_path / "c.png")
    assert not list(tmp_path.iterdir())
