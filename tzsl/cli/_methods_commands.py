"""``tzsl methods``: the zero-shot methods of the registry, their parameters and papers."""

from __future__ import annotations

import json
from typing import Any

import click

from tzsl.cli._root import cli


def _jsonable(value):
    """A default as JSON: numbers, strings, booleans and None as is, lists for tuples, else repr."""
    if value is None or isinstance(value, bool | int | float | str):
        return value
    if isinstance(value, tuple | list):
        return [_jsonable(v) for v in value]
    return repr(value)


@cli.command()
@click.option("--json", "as_json", is_flag=True, help="Print the methods as JSON instead of a table.")
def methods(as_json: bool) -> None:
    """List every zero-shot method: name, family, parameters with defaults, paper.

    A method is built by name (tzsl.models.build_method(NAME, **params)); the defaults shown
    are read from the estimators' signatures.
    """
    from tzsl.models import available_methods, get_method  # noqa: PLC0415 (keep --help fast)

    records: list[dict[str, Any]] = []
    for name in available_methods():
        m = get_method(name)
        records.append({
            "name": name,
            "family": m.family,
            "description": m.description,
            "components": [c.__name__ for c in m.components()],
            "preset": {k: _jsonable(v) for k, v in m.preset.items()},
            "parameters": {k: _jsonable(v) for k, v in m.parameters().items()},
            "paper": m.paper,
        })
    if as_json:
        click.echo(json.dumps(records, indent=2))
        return
    width = max(len(r["name"]) for r in records)
    fam = max(len(r["family"]) for r in records)
    click.echo(f"{'method':<{width}}  {'family':<{fam}}  description")
    for r in records:
        click.echo(f"{r['name']:<{width}}  {r['family']:<{fam}}  {r['description']}")
        built = " + ".join(r["components"])
        preset = ", ".join(f"{k}={v!r}" for k, v in r["preset"].items())
        click.echo(f"{'':<{width}}  {'':<{fam}}  estimator: {built}" + (f" ({preset})" if preset else ""))
        params = ", ".join(f"{k}={v!r}" for k, v in r["parameters"].items())
        click.echo(f"{'':<{width}}  {'':<{fam}}  parameters: {params}")
        click.echo(f"{'':<{width}}  {'':<{fam}}  paper: {r['paper']}")
