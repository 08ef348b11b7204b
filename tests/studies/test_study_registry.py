"""The study registry (issue 24, item 1): every study kind is one registration line; the engine names none."""

from __future__ import annotations

import json
from typing import Literal

import pandas as pd
import pytest
from pydantic import Field

from tzsl.exceptions import ConfigError
from tzsl.studies.config import (
    Compute,
    Output,
    builtin_names,
    get_study,
    load_experiment,
    register_study,
    study_kinds,
    study_names,
    unregister_study,
)
from tzsl.studies.config._common import Section
from tzsl.studies.engine import run, run_experiment
from tzsl.studies.outputs.study_run import StudyRun

PLUGIN = "echo-test"


class EchoStudy(Section):
    """A study a plug-in could add: one table of ``n`` rows."""

    study: Literal["echo-test"] = PLUGIN
    description: str = ""
    n: int = Field(3, ge=1)
    compute: Compute = Field(default_factory=Compute)
    output: Output = Field(default_factory=Output)


def run_echo(exp, results, say) -> StudyRun:
    """The plug-in's runner: writes ``echo.csv``."""
    table = pd.DataFrame({"row": range(exp.config.n)})
    results.write_csv("echo.csv", table)
    say(f"echo: {exp.config.n} rows")
    return StudyRun({"echo": table}, {"study_kind": PLUGIN})


@pytest.fixture
def plugin():
    register_study(PLUGIN, schema=EchoStudy, runner=f"{__name__}:run_echo", main_table="echo",
                   description="a test plug-in")
    yield get_study(PLUGIN)
    unregister_study(PLUGIN)


def test_every_builtin_study_is_registered_and_its_hooks_import():
    for name in builtin_names():
        assert load_experiment(name).study in study_names()
    for kind in study_kinds():
        assert kind.hook("runner") is not None, kind.name
        for hook in ("results", "outputs", "notes"):
            assert getattr(kind, hook) is None or callable(kind.hook(hook)), (kind.name, hook)
    assert get_study("phac2-dap").preset_of == "zero-shot"


def test_the_engine_names_no_study():
    """No study kind is a string in the engine's code (docstrings aside): it finds every runner in the registry."""
    import ast
    import inspect

    import tzsl.studies.engine as engine

    tree = ast.parse(inspect.getsource(engine))
    docstrings = {id(node.value) for node in ast.walk(tree) if isinstance(node, ast.Expr)}
    strings = {node.value for node in ast.walk(tree)
               if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in docstrings}
    assert not strings & set(study_names())


def test_a_registered_study_runs_through_the_engine(plugin, tmp_path):
    toml = tmp_path / "echo.toml"
    toml.write_text(f'study = "{PLUGIN}"\nn = 4\n[output]\nfolder = "{tmp_path / "out"}"\n')
    results, done = run_experiment(toml)
    assert pd.read_csv(results.root / "echo.csv")["row"].tolist() == [0, 1, 2, 3]
    manifest = json.loads((results.root / "manifest.json").read_text())
    assert manifest["config"]["study"] == PLUGIN
    assert len(run(toml, out=tmp_path / "again")) == 4  # tzsl.run returns the registered main table


def test_registering_twice_or_with_a_schema_that_refuses_the_name_fails(plugin):
    with pytest.raises(ValueError, match="already registered"):
        register_study(PLUGIN, schema=EchoStudy, runner=f"{__name__}:run_echo", main_table="echo", description="")
    with pytest.raises(ValueError, match="does not accept"):
        register_study("other-name", schema=EchoStudy, runner=f"{__name__}:run_echo", main_table="echo",
                       description="")


def test_an_unknown_study_is_one_line_naming_the_file(tmp_path):
    toml = tmp_path / "x.toml"
    toml.write_text('study = "no-such-study"\n')
    with pytest.raises(ConfigError, match=r"x\.toml: study: 'no-such-study': expected one of zero-shot, "):
        load_experiment(toml)
