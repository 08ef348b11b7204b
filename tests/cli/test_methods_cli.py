"""``tzsl methods``: every registered method with family, parameters and paper."""

from __future__ import annotations

import json

from click.testing import CliRunner

from tzsl.cli import cli
from tzsl.models import available_methods, get_method


def test_methods_table_lists_every_method():
    result = CliRunner().invoke(cli, ["methods"])
    assert result.exit_code == 0, result.output
    for name in available_methods():
        assert name in result.output
    assert "prior='train'" in result.output and "Romera-Paredes" in result.output


def test_methods_json():
    result = CliRunner().invoke(cli, ["methods", "--json"])
    assert result.exit_code == 0, result.output
    records = {r["name"]: r for r in json.loads(result.output)}
    assert sorted(records) == available_methods()
    assert records["dap-max"]["preset"] == {"fusion": "max", "prior": "uni"}
    assert records["eszsl"]["parameters"]["gammas"] == list(get_method("eszsl").parameters()["gammas"])
    assert records["embedding"]["family"] == "embedding" and records["embedding"]["parameters"]["lam"] == 1.0
