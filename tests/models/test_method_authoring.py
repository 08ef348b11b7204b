"""A method added the way docs/user_guide/extending.md says (issue 43, item 5): ConSE, public imports only.

The guide shows ``docs/user_guide/conse_method.py`` as it is (``literalinclude``); this test imports that
file, so the page and the code cannot drift. It checks the file imports no private name of tzsl, that
ConSE passes scikit-learn's ``check_estimator``, that the one registration line makes it a method that
:func:`tzsl.models.build_method` builds and a zero-shot study runs, and that it predicts unseen classes
well above chance on SIMULATED data (features a noisy linear image of the attribute rows).
"""

from __future__ import annotations

import ast
import importlib.util
import re
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from sklearn.utils.estimator_checks import check_estimator

import tzsl
from tzsl.datasets import write_plain_dataset
from tzsl.models import ZeroShotClassifier, available_methods, build_method, get_method, unregister_method

REPO = Path(__file__).resolve().parents[2]
EXAMPLE = REPO / "docs" / "user_guide" / "conse_method.py"
GUIDE = REPO / "docs" / "user_guide" / "extending.md"
NAME = "conse-authoring-test"


def _load_example():
    """The example as the module ``conse_method`` (in ``sys.modules``, so its classes pickle as a user's do)."""
    spec = importlib.util.spec_from_file_location("conse_method", EXAMPLE)
    module = importlib.util.module_from_spec(spec)
    sys.modules["conse_method"] = module
    spec.loader.exec_module(module)
    return module


conse = _load_example()


@pytest.fixture
def registered():
    conse.register_conse(NAME)
    yield get_method(NAME)
    unregister_method(NAME)


def _simulated(n_classes=10, n_attributes=8, per_class=15, seed=0):
    """SIMULATED data: distinct 0/1 attribute rows, features a noisy linear image of them."""
    rng = np.random.default_rng(seed)
    rows = np.unique((rng.random((4 * n_classes, n_attributes)) < 0.5).astype(float), axis=0)
    rows = rows[rng.choice(len(rows), n_classes, replace=False)]
    assert len(rows) == n_classes and np.all(rows.min(axis=0) < rows.max(axis=0))  # every attribute has both values
    y = np.repeat(np.arange(n_classes), per_class)
    X = rows[y] @ rng.normal(size=(n_attributes, 12)) + 0.3 * rng.normal(size=(len(y), 12))
    return X, y, rows


def test_the_guide_shows_the_tested_file():
    page = GUIDE.read_text(encoding="utf-8")
    assert re.search(r"```\{literalinclude\} conse_method\.py", page), "extending.md does not include conse_method.py"


def test_the_example_imports_no_private_name_of_tzsl():
    """Every tzsl import of the example names public modules and public names (``tzsl.models``, ``.base``)."""
    tree = ast.parse(EXAMPLE.read_text(encoding="utf-8"))
    modules, private = set(), []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("tzsl"):
            modules.add(node.module)
            private += [f"{node.module}.{a.name}" for a in node.names if a.name.startswith("_")]
            private += [node.module] if any(p.startswith("_") for p in node.module.split(".")) else []
        elif isinstance(node, ast.Import):
            private += [a.name for a in node.names if a.name.startswith("tzsl") and "._" in a.name]
    assert modules == {"tzsl.models", "tzsl.models.base"} and not private, (modules, private)


def test_conse_passes_check_estimator():
    check_estimator(conse.ConSE(n_top=2))


def test_conse_combines_the_top_rows_convexly():
    X, y, rows = _simulated()
    model = conse.ConSE(n_top=3).fit(X, rows[y])
    F = model.decision_function(X)
    assert F.shape == (len(X), rows.shape[1]) and model.score_kind == "embedding"
    assert np.all(F >= -1e-12) and np.all(F <= 1 + 1e-12)  # a convex combination of 0/1 rows stays in [0, 1]
    one = conse.ConSE(n_top=1).fit(X, rows[y]).decision_function(X)  # T = 1: the most probable class's row
    assert {tuple(r) for r in one} <= {tuple(r) for r in rows}


def test_the_registered_method_recognises_unseen_classes(registered):
    assert NAME in available_methods()
    assert registered.attribute_model is conse.ConSE and registered.family == "embedding"
    params = registered.parameters()
    assert params["n_top"] == 10 and params["C"] == 1.0
    X, y, rows = _simulated(n_classes=16, per_class=10)
    seen, unseen = np.arange(12), np.arange(12, 16)
    train, test = np.isin(y, seen), np.isin(y, unseen)
    clf = build_method(NAME, random_state=0)  # calibrated, as a study builds it
    assert isinstance(clf.estimator, ZeroShotClassifier)
    clf.fit(X[train], rows[y[train]], y[train])
    pred = clf.predict(X[test], rows[unseen])
    accuracy = np.mean(unseen[pred] == y[test])
    assert accuracy >= 0.5, accuracy  # chance is 1 / 4 (0.75 on these data)
    proba = clf.predict_proba(X[test], rows[unseen])
    np.testing.assert_allclose(proba.sum(axis=1), 1.0)


def test_a_zero_shot_study_runs_the_registered_method(registered, tmp_path):
    X, y, rows = _simulated(n_classes=12, per_class=6, seed=1)
    names = np.array([f"c{c:02d}" for c in range(len(rows))], dtype=object)
    classes = pd.DataFrame(rows.astype(int), index=pd.Index(names, name="class"),
                           columns=[f"a{j}" for j in range(rows.shape[1])])
    trials = pd.DataFrame({"trial_id": [f"t{i}" for i in range(len(y))], "class": names[y]})
    data = write_plain_dataset(tmp_path / "data", classes, trials, sensors=["s0"], X=X[:, None, :],
                               feature_names=[f"f{i}" for i in range(X.shape[1])], settings={"name": "sim-SIMULATED"})
    experiment = tmp_path / "conse.toml"
    experiment.write_text(f"""study = "zero-shot"
description = "ConSE on SIMULATED data"

[dataset]
plain = "{data}"

[methods]
compare = ["{NAME}"]
sweep = false

[gzsl]
methods = ["dap"]

[splits]
kinds = ["random"]
n_splits = 2
n_test = 4

[svm]
n_C = 1
n_gamma = 1
n_draws = 1

[output]
folder = "{tmp_path / 'out'}"
""")
    tzsl.run(experiment)
    comparison = pd.read_csv(tmp_path / "out" / "method_comparison.csv")
    (row,) = comparison[comparison["method"] == NAME].itertuples()  # one row: random splits, confirmation
    assert row.n_splits == 2 and row.accuracy > 2 * row.chance, (row.accuracy, row.chance)  # 0.92 vs 0.25 here
