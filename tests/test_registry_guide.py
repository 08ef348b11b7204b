"""Every registry entry has what docs/user_guide/extending.md says it needs.

The guide's "The registry entry" tables mark each field of a method, a reader (``LAB_READERS``), a
built-in experiment file and a study kind as required or not. This test reads those tables from
the page, checks that it knows how to check exactly the required fields (so the page and this test
cannot drift apart), then checks every registered entry. It also checks that the files the guide
says an extension touches exist, that the guide lists every parameter of ``register_method``, and
that no user-guide page jumps a heading level (Sphinx -W fails on H1 -> H3).
"""

from __future__ import annotations

import importlib
import inspect
import re
import tomllib
from itertools import pairwise
from pathlib import Path
from typing import get_args

import pytest
from pydantic import BaseModel

from tzsl.datasets import LAB_READERS
from tzsl.models import FAMILIES, INPUT_KINDS, available_methods, get_method, register_method
from tzsl.studies.config import builtin_names, builtin_text, load_experiment, study_kinds, study_names

REPO = Path(__file__).resolve().parents[1]
GUIDE = REPO / "docs" / "user_guide"
PAGE = GUIDE / "extending.md"


def _sections(text: str, level: int) -> dict[str, str]:
    """Heading text -> body, for the headings of ``level`` (``#`` count) in markdown ``text``."""
    parts = re.split(rf"^{'#' * level} (.+)$", text, flags=re.M)
    return {parts[i].strip(): parts[i + 1] for i in range(1, len(parts) - 1, 2)}


def _tables(body: str) -> list[list[list[str]]]:
    """The markdown tables of ``body``: rows of cells, header and rule rows dropped."""
    tables, rows = [], []
    for line in body.splitlines() + [""]:
        if line.startswith("|"):
            rows.append([c.strip() for c in line.strip().strip("|").split("|")])
        elif rows:
            tables.append(rows[2:])
            rows = []
    return tables


def _entry_tables(section: str) -> list[dict[str, bool]]:
    """Field -> required, for each table under "The registry entry" of the guide's ``section``."""
    body = _sections(_sections(PAGE.read_text(encoding="utf-8"), 2)[section], 3)["The registry entry"]
    out = []
    for rows in _tables(body):
        fields = {}
        for row in rows:
            for name in re.findall(r"`([^`]+)`", row[0]):
                fields[name] = row[1] == "yes"
        out.append(fields)
    return out


def _required(fields: dict[str, bool]) -> set[str]:
    return {name for name, required in fields.items() if required}


# --------------------------------------------------------------------------- methods

METHOD_CHECKS = {
    "name": lambda m: bool(m.name.strip()),
    "family": lambda m: m.family in FAMILIES,
    "paper": lambda m: bool(m.paper.strip()),
    "description": lambda m: bool(m.description.strip()),
    "components": lambda m: all(c is not None and (c.__doc__ or "").strip() for c in m.components()),
    "input_kind": lambda m: m.input_kind in INPUT_KINDS,
}


def test_the_guide_requires_what_this_test_checks_for_a_method():
    (fields,) = _entry_tables("A method")
    assert _required(fields) == set(METHOD_CHECKS)
    # and it lists every parameter of register_method (the classes as "components")
    params = set(inspect.signature(register_method).parameters) - {"replace"}
    named = {"components" if p in ("attribute_model", "decision_rule", "estimator") else p for p in params}
    assert named <= set(fields), f"extending.md does not list {sorted(named - set(fields))}"


@pytest.mark.parametrize("name", available_methods())
def test_every_registered_method_has_the_required_fields(name):
    method = get_method(name)
    missing = [field for field, ok in METHOD_CHECKS.items() if not ok(method)]
    assert not missing, f"method {name!r} lacks {missing} (docs/user_guide/extending.md, 'A method')"


# --------------------------------------------------------------------------- readers


def _from_help() -> str:
    from tzsl.cli import cli

    option = next(p for p in cli.commands["convert"].params if "--from" in getattr(p, "opts", ()))
    return option.help or ""


READER_CHECKS = {
    "kind": lambda kind, model, reader: get_args(model.model_fields["kind"].annotation) == (kind,),
    "mapping model": lambda kind, model, reader: issubclass(model, BaseModel) and bool((model.__doc__ or "").strip()),
    "reader": lambda kind, model, reader: callable(reader) and bool((reader.__doc__ or "").strip()),
    "--from help": lambda kind, model, reader: re.search(rf"\b{re.escape(kind)}\b", _from_help()) is not None,
    "docs section": lambda kind, model, reader: re.search(
        rf"^#+ .*\(`--from {re.escape(kind)}`\)\s*$", (GUIDE / "lab_formats.md").read_text(encoding="utf-8"),
        flags=re.M) is not None,
}


def test_the_guide_requires_what_this_test_checks_for_a_reader():
    (fields,) = _entry_tables("A reader")
    assert _required(fields) == set(READER_CHECKS)


@pytest.mark.parametrize("kind", sorted(LAB_READERS))
def test_every_registered_reader_has_the_required_fields(kind):
    model, reader = LAB_READERS[kind]
    missing = [field for field, ok in READER_CHECKS.items() if not ok(kind, model, reader)]
    assert not missing, f"reader {kind!r} lacks {missing} (docs/user_guide/extending.md, 'A reader')"


# --------------------------------------------------------------------------- presets and study kinds


def _checked(name: str) -> bool:
    load_experiment(name)  # raises a one-line ConfigError naming the key
    return True


PRESET_CHECKS = {
    "header comment": lambda name, text, data: text.startswith("#"),
    "study": lambda name, text, data: data.get("study") in study_names(),
    "description": lambda name, text, data: bool(str(data.get("description", "")).strip()),
    "output.folder": lambda name, text, data: bool((data.get("output") or {}).get("folder")),
    "checked": lambda name, text, data: _checked(name),
    "docs row": lambda name, text, data: re.search(
        rf"^\| `{re.escape(name)}` \| `{re.escape(str(data.get('study')))}` \|",
        (GUIDE / "reproducing.md").read_text(encoding="utf-8"), flags=re.M) is not None,
}


def _documented_kind(name: str) -> bool:
    return any(f'study = "{name}"' in page.read_text(encoding="utf-8") for page in GUIDE.glob("*.md"))


KIND_CHECKS = {
    "name": lambda k: k.name in get_args(k.schema.model_fields["study"].annotation),
    "schema": lambda k: issubclass(k.schema, BaseModel),
    "runner": lambda k: callable(k.hook("runner")),
    "main_table": lambda k: bool(k.main_table.strip()),
    "description": lambda k: bool(k.description.strip()),
    "docs paragraph": lambda k: _documented_kind(k.name),
}


def test_the_guide_requires_what_this_test_checks_for_a_preset_and_a_study_kind():
    preset, kind = _entry_tables("A study preset")
    assert _required(preset) == set(PRESET_CHECKS)
    assert _required(kind) == set(KIND_CHECKS)
    from tzsl.studies.config import StudyKind

    fields = {f for f in StudyKind.__dataclass_fields__}
    listed = {name.strip() for row in kind for name in row.split(",")}
    assert fields <= listed, f"extending.md does not list the study kind field(s) {sorted(fields - listed)}"


@pytest.mark.parametrize("name", builtin_names())
def test_every_builtin_experiment_file_has_the_required_fields(name):
    text = builtin_text(name)
    data = tomllib.loads(text)
    missing = [field for field, ok in PRESET_CHECKS.items() if not ok(name, text, data)]
    assert not missing, f"built-in study {name!r} lacks {missing} (docs/user_guide/extending.md, 'A study preset')"


@pytest.mark.parametrize("kind", study_kinds(), ids=lambda k: k.name)
def test_every_registered_study_kind_has_the_required_fields(kind):
    missing = [field for field, ok in KIND_CHECKS.items() if not ok(kind)]
    assert not missing, f"study kind {kind.name!r} lacks {missing} (docs/user_guide/extending.md)"
    if kind.preset_of is not None:
        assert kind.preset_of in study_names()


# --------------------------------------------------------------------------- the page itself


def test_the_files_the_guide_names_exist():
    """Every ``tzsl/...`` or ``docs/...`` path of a "Files it touches" table exists, unless marked (new)."""
    for section, body in _sections(PAGE.read_text(encoding="utf-8"), 2).items():
        files = _sections(body, 3).get("Files it touches")
        if files is None:
            continue
        for (path_cell, *_rest) in _tables(files)[0]:
            for path in re.findall(r"`((?:tzsl|docs)/[^`]+)`", path_cell):
                assert "(new)" in path_cell or (REPO / path).exists(), f"{section}: {path} does not exist"
    for name in ("datasets", "models", "studies"):
        importlib.import_module(f"tzsl.{name}")


def test_the_guide_is_in_the_toctree_and_no_user_guide_page_jumps_a_heading_level():
    toctree = (GUIDE / "index.md").read_text(encoding="utf-8")
    assert re.search(r"^(extending|\*)$", toctree, flags=re.M), "extending.md is not in the user guide's toctree"
    for page in sorted(GUIDE.glob("*.md")):
        text = re.sub(r"^(```|~~~).*?^\1", "", page.read_text(encoding="utf-8"), flags=re.M | re.S)
        levels = [len(m.group(1)) for m in re.finditer(r"^(#{1,6}) ", text, flags=re.M)]
        assert levels and levels[0] == 1, f"{page.name} does not open with one H1"
        jumps = [(a, b) for a, b in pairwise(levels) if b > a + 1]
        assert not jumps, f"{page.name} jumps heading levels {jumps} (Sphinx -W fails)"
