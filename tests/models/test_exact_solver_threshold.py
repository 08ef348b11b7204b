"""``solver="auto"``'s threshold (issue 33): the template's mid-size data are approximate, no built-in study changes."""

from __future__ import annotations

import numpy as np
import pytest

from tests.benchmark_scripts import benchmark_script
from tzsl.benchmarks.bench_template import TEMPLATE_SHAPE
from tzsl.models import AttributeClassifierBank, ScalableAttributeClassifier
from tzsl.models.attribute_training import AUTO_MAX_EXACT_TRIALS


def test_no_built_in_dataset_reaches_the_threshold(data_dir):
    """Every trial of a built-in dataset with an attribute table, training or not, stays below the threshold:
    the paper tables and the evidence fit their RBF-SVMs exactly whatever the split."""
    from tzsl.datasets import load_fabric, load_hand_table4  # noqa: PLC0415
    from tzsl.features import dataset_features  # noqa: PLC0415
    from tzsl.studies.config import HandSimulation  # noqa: PLC0415

    sizes = {"phac2-penn": dataset_features("phac2-penn", data_dir=data_dir).X.shape[0],
             "fabric-depth": load_fabric(data_dir).image_labels().size,
             "hand-simulated": len(load_hand_table4().K) * HandSimulation().n_grasps_per_object}
    assert all(0 < n < AUTO_MAX_EXACT_TRIALS for n in sizes.values()), sizes


def test_the_template_bench_trains_above_the_threshold():
    """The issue's mid-size dataset (41 objects, 2,549 grasps): even its smallest random training set (the
    5 test classes with the most trials held out, classes of equal size up to rounding) is approximate."""
    per_class = TEMPLATE_SHAPE["n_trials"] / TEMPLATE_SHAPE["n_classes"]
    smallest_training_set = TEMPLATE_SHAPE["n_trials"] - 5 * np.ceil(per_class)
    assert smallest_training_set > AUTO_MAX_EXACT_TRIALS


def test_auto_fits_the_approximate_model_above_the_threshold_and_the_exact_one_below():
    rng = np.random.default_rng(0)
    n = AUTO_MAX_EXACT_TRIALS + 40
    X = rng.normal(size=(n, 1, 3))
    groups = np.arange(n) % 20
    y = (groups % 2).reshape(-1, 1)
    X[:, 0, 0] += 2.0 * y[:, 0]
    big = AttributeClassifierBank(random_state=0, max_exact_trials=AUTO_MAX_EXACT_TRIALS).fit(X, y, groups)
    assert isinstance(big.estimators_[0][0], ScalableAttributeClassifier)
    keep = np.arange(n) < 400
    small = AttributeClassifierBank(random_state=0).fit(X[keep], y[keep], groups[keep])
    assert not isinstance(small.estimators_[0][0], ScalableAttributeClassifier)


def test_the_guard_reads_the_criterion_of_paired_splits():
    import pandas as pd  # noqa: PLC0415

    with benchmark_script("exact_solver_threshold.py") as bench:
        per_split = pd.DataFrame({"split": ["1", "2", "mean", "std", "1", "2"],
                                  "split_kind": ["random"] * 4 + ["challenging"] * 2,
                                  bench.label("exact"): [0.40, 0.30, 0.35, 0.05, 0.20, 0.30],
                                  bench.label("approximate"): [0.38, 0.28, 0.33, 0.90, 0.10, 0.20]})
        summary = bench.paired_summary(per_split, n_boot=200)
        criterion = summary.set_index("split_kind").loc["criterion"]
        assert criterion["difference"] == pytest.approx(-0.06)  # (-0.02 + -0.10) / 2: the "mean" and "std" rows left out
        assert not bench.guard_holds(summary)
        assert bench.guard_holds(bench.paired_summary(per_split.assign(**{bench.label("approximate"):
                                                                          per_split[bench.label("exact")]})))
