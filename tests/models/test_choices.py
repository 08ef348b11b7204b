"""The registry of inherited choices (issue 23): complete entries, values read from the code."""

from __future__ import annotations

import importlib.util
import inspect
import sys
from pathlib import Path

import pytest

from tzsl.models import (
    INHERITED_CHOICES,
    AttributeSVM,
    ScoreEnsembleZSL,
    get_method,
)
from tzsl.models.choices import DEFAULT_METHOD, NO_SELECTION_SPLITS, inherited_choices

DOCS = Path(__file__).resolve().parents[2] / "docs"


def test_every_choice_is_complete_and_named_once():
    keys = [c.key for c in INHERITED_CHOICES]
    assert len(keys) == len(set(keys))
    for c in inherited_choices():
        assert all(c[field] for field in ("key", "what", "value", "selection", "numbers")), c
        # an honest entry: either splits are named, or it says there were none
        assert NO_SELECTION_SPLITS in c["selection"] or "split" in c["selection"] or c["selection"].startswith("none")
        # the datasets it saw: none exactly when it was made on no splits (issue 42: which datasets a choice saw)
        assert c["datasets"] and (c["datasets"].startswith("none") == c["selection"].startswith(NO_SELECTION_SPLITS))


def test_the_defaults_checked_across_datasets_name_the_benchmark_catalog():
    """Issue 42: the default method and the study's detector say which datasets the benchmark checked them on."""
    from tzsl.models.choices import BENCHMARK_CHECKED
    from tzsl.studies.benchmark.catalog import BENCHMARK_DATASETS

    assert sorted(BENCHMARK_CHECKED) == sorted(d.name for d in BENCHMARK_DATASETS)
    by_key = {c["key"]: c for c in inherited_choices()}
    for key in ("default-method", "study-detector"):
        assert all(name in by_key[key]["datasets"] for name in BENCHMARK_CHECKED), key


def test_the_choices_a_user_meets_are_listed():
    assert {"default-method", "ensemble-members", "attribute-svm-grid", "approximate-solver", "eszsl-grid",
            "sae-grid", "compatibility-sgd"} <= {c.key for c in INHERITED_CHOICES}


def test_values_are_read_from_the_code_not_typed():
    """The registry follows the code: the values are the shipped defaults."""
    by_key = {c.key: c for c in INHERITED_CHOICES}
    members = inspect.signature(ScoreEnsembleZSL).parameters["methods"].default
    assert by_key["ensemble-members"].read() == members
    assert by_key["default-method"].read() == dict(get_method(DEFAULT_METHOD).preset)
    assert by_key["attribute-svm-grid"].read()["grid"] == AttributeSVM().grid


def test_the_docs_page_lists_every_choice(tmp_path):
    """The page is generated from the registry (docs/_ext/tzsl_docgen.py), one section per choice."""
    spec = importlib.util.spec_from_file_location("tzsl_docgen_probe", DOCS / "_ext" / "tzsl_docgen.py")
    docgen = importlib.util.module_from_spec(spec)
    sys.modules["tzsl_docgen_probe"] = docgen
    try:
        spec.loader.exec_module(docgen)
        docgen.choices_page(tmp_path)
    finally:
        del sys.modules["tzsl_docgen_probe"]
    page = (tmp_path / "choices_table.md").read_text()
    for c in inherited_choices():
        assert f"### `{c['key']}`" in page and c["value"] in page
    assert "choices_table.md" in (DOCS / "user_guide" / "choices.md").read_text()


@pytest.mark.parametrize("key", [c.key for c in INHERITED_CHOICES])
def test_a_command_is_a_real_file_or_make_target(key):
    """Every command names a script of the repository or a make target that exists."""
    root = DOCS.parent
    command = next(c for c in INHERITED_CHOICES if c.key == key).command
    for word in command.split():
        if word.endswith(".py"):
            assert (root / word).is_file(), word
    if command.startswith("make "):
        target = command.split()[1]
        assert f"\n{target}:" in (root / "Makefile").read_text(), target
