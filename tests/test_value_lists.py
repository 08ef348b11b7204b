"""Every value list is written once (tzsl.value_lists) and read by the schema, the command line and the code
(issue 34, item 4): a value added to a list reaches all three, and nothing else spells one."""

from __future__ import annotations

import ast
from pathlib import Path
from typing import get_args

import click
from click.testing import CliRunner

from tzsl import value_lists
from tzsl.cli import EXIT_USAGE, cli
from tzsl.studies.config import DaskCompute, GzslSettings, ZeroShotMethods, ZeroShotSplits

PACKAGE = Path(__file__).resolve().parents[1] / "tzsl"


def _choices(command: str, option: str) -> tuple[str, ...]:
    params = {p.name: p for p in cli.commands[command].params}
    assert isinstance(params[option].type, click.Choice), (command, option)
    return tuple(params[option].type.choices)


def test_schema_and_command_line_read_the_lists():
    fields = ZeroShotMethods.model_fields
    assert get_args(get_args(fields["fusions"].annotation)[0]) == value_lists.FUSIONS
    assert get_args(get_args(fields["priors"].annotation)[0]) == value_lists.PRIORS
    assert get_args(GzslSettings.model_fields["fusion"].annotation) == value_lists.FUSIONS
    assert get_args(get_args(ZeroShotSplits.model_fields["kinds"].annotation)[0]) == value_lists.SPLIT_SOURCES
    assert get_args(DaskCompute.model_fields["backend"].annotation) == value_lists.STUDY_BACKENDS
    assert _choices("train-attributes", "fusion") == value_lists.FUSIONS
    assert _choices("train-attributes", "prior") == value_lists.PRIORS
    assert _choices("splits", "kind") == value_lists.SPLIT_KINDS
    assert _choices("run", "backend") == value_lists.STUDY_BACKENDS


def test_no_module_spells_a_list_again():
    """No tuple or list literal elsewhere in the package equals (as a set) the DAP fusions, priors or backends."""
    watched = {frozenset(v): name for name, v in (("FUSIONS", value_lists.FUSIONS), ("PRIORS", value_lists.PRIORS),
                                                  ("JOBLIB_BACKENDS", value_lists.JOBLIB_BACKENDS))}
    found = []
    for path in PACKAGE.rglob("*.py"):
        if path.name == "value_lists.py":
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Tuple | ast.List | ast.Set) and node.elts and all(
                    isinstance(e, ast.Constant) and isinstance(e.value, str) for e in node.elts):
                values = frozenset(e.value for e in node.elts)
                if values in watched:
                    found.append(f"{path.relative_to(PACKAGE.parent)}:{node.lineno}: {watched[values]} spelled again")
    assert not found, "\n".join(found)


def test_dataset_option_reads_the_dataset_registry():
    from tzsl.datasets import dataset_names

    result = CliRunner().invoke(cli, ["splits", "--dataset", "no-such-data"])
    assert result.exit_code == EXIT_USAGE
    assert all(name in result.output for name in dataset_names())
