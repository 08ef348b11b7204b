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


def call(entry: dict[str, Any]) -> str:
    """A method entry as a call: ``{"name": "dap", "fusion": "max"}`` -> ``dap(fusion='max')``."""
    return f"{entry['name']}({', '.join(f'{k}={v!r}' for k, v in entry.items() if k != 'name')})"


@cli.command()
@click.option("--json", "as_json", is_flag=True, help="Print the methods as JSON instead of a table.")
def methods(as_json: bool) -> None:
    """List every zero-shot method: name, family, parameters with defaults, their values, aliases, paper.

    A method is built by name (tzsl.models.build_method(NAME, **params)); the defaults shown
    are read from the estimators' signatures and the string values a parameter takes from
    their parameter constraints. An alias (an older name, e.g. dap-avg) is one configuration of a
    method, accepted wherever a method is named.
    """
    from tzsl.models import available_methods, get_method, method_aliases  # noqa: PLC0415 (keep --help fast)

    aliases = method_aliases()
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
            "values": {k: list(v) for k, v in m.options().items()},
            "aliases": {alias: {k: _jsonable(v) for k, v in entry.items() if k != "name"}
                        for alias, entry in aliases.items() if entry["name"] == name},
            "paper": m.paper,
        })
    if as_json:
        click.echo(json.dumps(records, indent=2))
        return
    width = max(len(r["name"]) for r in records)
    fam = max(len(r["family"]) for r in records)
    click.echo(f"{'method':<{width}}  {'family':<{fam}}  description")
    for r in records:
        pad = f"{'':<{width}}  {'':<{fam}}  "
        click.echo(f"{r['name']:<{width}}  {r['family']:<{fam}}  {r['description']}")
        built = " + ".join(r["components"])
        preset = ", ".join(f"{k}={v!r}" for k, v in r["preset"].items())
        click.echo(f"{pad}estimator: {built}" + (f" ({preset})" if preset else ""))
        params = ", ".join(f"{k}={v!r}" for k, v in r["parameters"].items())
        click.echo(f"{pad}parameters: {params}")
        for i, (key, values) in enumerate(r["values"].items()):
            click.echo(f"{pad}{'string values: ' if i == 0 else ' ' * 15}{key}: {' | '.join(values)}")
        for i, (alias, fixed) in enumerate(r["aliases"].items()):
            click.echo(f"{pad}{'aliases: ' if i == 0 else ' ' * 9}{alias} = {call({'name': r['name'], **fixed})}")
        click.echo(f"{pad}paper: {r['paper']}")
