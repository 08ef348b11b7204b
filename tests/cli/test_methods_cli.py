"""``tzsl methods``: every registered method with family, parameters and paper."""

from __future__ import annotations

import json

from click.testing import CliRunner

from tzsl.cli import cli
from tzsl.models import available_methods, get_method, method_aliases
from tzsl.models.detectors import DETECTORS


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
    assert records["multilabel-dap"]["preset"] == {"prior": "uni"}
    assert records["dap"]["aliases"]["dap-max"] == {"fusion": "max", "prior": "uni"}
    assert records["dap"]["values"]["detector"] == list(get_method("dap").options()["detector"])
    assert records["eszsl"]["parameters"]["gammas"] == list(get_method("eszsl").parameters()["gammas"])
    assert records["embedding"]["family"] == "embedding" and records["embedding"]["parameters"]["lam"] == 1.0


def test_dap_is_listed_once_with_its_detectors_as_values_and_its_aliases():
    """Issue 43, item 3: one DAP method; the detector families are values of its parameter, the older
    method names its aliases (each shown as the configuration it names)."""
    result = CliRunner().invoke(cli, ["methods"])
    assert result.exit_code == 0, result.output
    lines = result.output.splitlines()
    methods = [line.split()[0] for line in lines[1:] if line and not line[0].isspace()]
    assert methods == available_methods() and methods.count("dap") == 1
    assert not {"dap-avg", "dap-max", "dap-avg-logistic-c1"} & set(methods)
    values = next(line for line in lines if "detector: " in line and " | " in line)
    assert values.split("detector: ")[1] == " | ".join(sorted(DETECTORS))
    for alias, entry in method_aliases().items():
        fixed = ", ".join(f"{k}={v!r}" for k, v in entry.items() if k != "name")
        assert sum(line.strip().endswith(f"{alias} = dap({fixed})") for line in lines) == 1, alias
    assert "dap-avg-logistic-c1 = dap(detector='logistic-c1', fusion='avg', prior='uni')" in result.output


def test_train_attributes_takes_an_old_name_and_dap_with_a_detector(tmp_path):
    """``--method`` accepts an alias and ``dap`` (the bundle names that configuration); an unknown name fails
    before any data is read, listing the methods and the aliases. The dataset is SIMULATED."""
    from tests.studies.test_zero_shot_study import simulated_dataset
    from tzsl.inference.bundle import read_bundle_header
    from tzsl.studies.config import method_label

    data = simulated_dataset(tmp_path / "data", 8, 3, 2, seed=2)
    for name in ("dap-avg-logistic-c1", "dap"):
        model = tmp_path / f"{name}.tzsl"
        result = CliRunner().invoke(cli, ["train-attributes", "--plain", str(data), "--method", name, "--no-cache",
                                          "--no-progress", "--out", str(model)])
        assert result.exit_code == 0, result.output + result.stderr
        recorded = read_bundle_header(model).metadata["method"]  # the name given, or its row label
        assert method_label({"name": recorded}) == method_label({"name": name})
    result = CliRunner().invoke(cli, ["train-attributes", "--plain", str(data), "--method", "dap-svm",
                                      "--out", str(tmp_path / "x.tzsl")])
    assert result.exit_code != 0 and "unknown method 'dap-svm'" in result.output + result.stderr
    assert "aliases: [" in result.output + result.stderr and not (tmp_path / "x.tzsl").exists()
