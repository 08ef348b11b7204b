"""``[svm] solver`` and ``max_exact_trials``: validated, defaults from AttributeClassifierBank, passed to the bank."""

from __future__ import annotations

import inspect
from pathlib import Path

import pytest

from tzsl.exceptions import ConfigError
from tzsl.models import AttributeClassifierBank
from tzsl.studies.config import load_experiment
from tzsl.studies.zero_shot.study import attribute_bank


def _experiment(tmp_path: Path, svm: str):
    path = tmp_path / "exp.toml"
    path.write_text(f"study = 'phac2-dap'\n[dataset]\nplain = 'd'\n[svm]\n{svm}\n")
    return load_experiment(path)


def test_defaults_are_the_banks():
    svm = load_experiment("phac2-dap").config.svm
    params = inspect.signature(AttributeClassifierBank).parameters
    assert svm.solver == params["solver"].default
    assert svm.max_exact_trials == params["max_exact_trials"].default


def test_schema_offers_exactly_the_banks_solvers():
    from tzsl.models.detectors._attribute_training import SOLVERS
    from tzsl.studies.config._zero_shot import SvmSettings

    field = SvmSettings.model_fields["solver"]
    assert set(field.annotation.__args__) == set(SOLVERS)


def test_the_keys_reach_the_estimator(tmp_path):
    exp = _experiment(tmp_path, "solver = 'approximate'\nmax_exact_trials = 123")
    config = exp.config
    assert (config.svm.solver, config.svm.max_exact_trials) == ("approximate", 123)
    bank = attribute_bank(config, ["a", "b"], seed=0)
    assert bank.get_params()["solver"] == "approximate"
    assert bank.get_params()["max_exact_trials"] == 123
    params = config.svm.estimator_params()
    assert "solver" not in params and "max_exact_trials" not in params  # not SVM parameters


@pytest.mark.parametrize(("svm", "message"), [
    ("solver = 'fast'", "svm.solver: 'fast': expected 'auto', 'exact' or 'approximate'"),
    ("max_exact_trials = 0", "svm.max_exact_trials: 0: must be >= 1"),
    ("max_exact_trials = 'many'", "svm.max_exact_trials: 'many': expected a valid integer"),
])
def test_bad_values_are_named_with_file_and_key(tmp_path, svm, message):
    with pytest.raises(ConfigError) as err:
        _experiment(tmp_path, svm)
    assert f"{tmp_path / 'exp.toml'}: {message}" in str(err.value)
