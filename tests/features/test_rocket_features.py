"""RocketFeatures (ROCKET kernels of pyts, the extra tzsl[timeseries]) and the ``"rocket"`` signal feature set.

pyts compiles every numba kernel of its transformation module when imported (about a minute of CPU, not
cached). The ``rocket`` fixture imports it once per test process with numba's JIT switched off for that
import only (``numba.config.DISABLE_JIT``): pyts' own Python code then runs uncompiled on the tests' tiny
series, in milliseconds; other numba code of the process is compiled as usual. When pyts was already
imported (compiled) by an earlier test, that import is used.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from tzsl.cli import cli
from tzsl.datasets import write_plain_dataset
from tzsl.exceptions import ConfigError, DataFileError
from tzsl.features import (
    ROCKET_INSTALL_HINT,
    RocketFeatures,
    load_plain_dataset,
    split_signal_features,
)


@pytest.fixture(scope="module")
def rocket():
    """pyts' ROCKET class, imported with its numba kernels left uncompiled (see the module docstring)."""
    pytest.importorskip("numba")
    import numba

    if "pyts.transformation" not in sys.modules:
        before = numba.config.DISABLE_JIT
        numba.config.DISABLE_JIT = True
        try:
            pytest.importorskip("pyts.transformation")
        finally:
            numba.config.DISABLE_JIT = before
    from pyts.transformation import ROCKET

    return ROCKET


def _trials(seed: int = 0, lengths=(120, 90, 300, 40), n_channels: int = 3) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    return [np.cumsum(rng.normal(size=(n, n_channels)), axis=0) for n in lengths]


def test_shapes_names_and_variable_lengths(rocket):
    trials = _trials()
    f = RocketFeatures(n_kernels=3, length=32, channels=["p", "v", "e"]).fit(trials)
    Z = f.transform(trials)
    assert Z.shape == (4, 3 * 2 * 3) and np.isfinite(Z).all()
    names = f.get_feature_names_out()
    assert list(names[:4]) == ["p_rocket0_max", "p_rocket0_ppv", "p_rocket1_max", "p_rocket1_ppv"]
    assert names[-1] == "e_rocket2_ppv" and len(names) == Z.shape[1]
    ppv = Z[:, 1::2]
    assert ((ppv >= 0) & (ppv <= 1)).all()
    assert isinstance(f.rocket_, rocket)
    # a 3-D array of equal-length trials is accepted as well
    assert f.transform(np.stack(_trials(lengths=(50, 50)))).shape == (2, 18)


def test_fit_reads_no_test_trial_and_each_trial_is_transformed_alone(rocket):
    """No leakage: the features of a test trial do not depend on the trials fit saw, nor on its batch."""
    train_a, train_b, test = _trials(1), _trials(2, lengths=(400, 30)), _trials(3, lengths=(70, 150))
    on_a = RocketFeatures(n_kernels=4, length=32).fit(train_a).transform(test)
    on_b = RocketFeatures(n_kernels=4, length=32).fit(train_b).transform(test)
    np.testing.assert_array_equal(on_a, on_b)
    alone = RocketFeatures(n_kernels=4, length=32).fit(train_a).transform(test[1:])
    np.testing.assert_array_equal(on_a[1:], alone)


def test_random_state_makes_it_deterministic(rocket):
    trials = _trials()
    one = RocketFeatures(n_kernels=4, length=32, random_state=7).fit(trials).transform(trials)
    two = RocketFeatures(n_kernels=4, length=32, random_state=7).fit(trials).transform(trials)
    other = RocketFeatures(n_kernels=4, length=32, random_state=8).fit(trials).transform(trials)
    np.testing.assert_array_equal(one, two)
    assert not np.array_equal(one, other)


def test_constant_channel_is_finite_and_nan_is_one_line(rocket):
    trials = _trials()
    trials[0][:, 1] = 5.0
    Z = RocketFeatures(n_kernels=3, length=32).fit(trials).transform(trials)
    assert np.isfinite(Z).all()
    trials[2][7, 0] = np.nan
    with pytest.raises(DataFileError, match=r"signal 2 holds NaN/inf \(first at row 7\)") as err:
        RocketFeatures(n_kernels=3, length=32).fit(trials).transform(trials)
    assert "\n" not in str(err.value)
    with pytest.raises(DataFileError, match="signal 0 has 1 rows"):
        RocketFeatures(n_kernels=3, length=32).fit(trials).transform([np.ones((1, 3))])
    with pytest.raises(DataFileError, match="signal 0 has 2 channels; fitted on 3"):
        RocketFeatures(n_kernels=3, length=32).fit(trials).transform([np.ones((9, 2))])


@pytest.mark.parametrize(("params", "message"), [
    ({"n_kernels": 0}, "n_kernels must be an integer >= 1"),
    ({"length": 8}, "length must be an integer >= 16"),
    ({"n_kernels": "many"}, "'n_kernels' parameter of RocketFeatures must be an instance of 'int'"),
    ({"channels": ["a"]}, "channels names 1 channels but the signals have 3"),
])
def test_bad_parameters_are_one_line_config_errors(rocket, params, message):
    with pytest.raises(ConfigError, match=message) as err:
        RocketFeatures(**params).fit(_trials())
    assert "\n" not in str(err.value)


def test_missing_extra_is_one_line(monkeypatch):
    monkeypatch.setitem(sys.modules, "pyts.transformation", None)  # import pyts.transformation -> ImportError
    with pytest.raises(ConfigError) as err:
        RocketFeatures().fit(_trials())
    assert str(err.value) == ROCKET_INSTALL_HINT == (
        "the 'rocket' signal transform needs pyts: pip install 'tzsl[timeseries]'")


def test_statistics_setting_names_the_transform():
    assert split_signal_features(["mean", "rocket", "std"]) == (("mean", "std"), ("rocket",))
    assert split_signal_features(["rocket"]) == ((), ("rocket",))
    with pytest.raises(ConfigError, match="lists a name twice"):
        split_signal_features(["rocket", "rocket"])
    with pytest.raises(ConfigError, match="unknown signal statistic.*or the transform.s. rocket"):
        split_signal_features(["mean", "minirocket"])
    with pytest.raises(ConfigError, match="non-empty sequence"):
        split_signal_features("rocket")


ROWS = {"mug": [1, 0, 1], "sponge": [0, 1, 0], "can": [1, 0, 0], "towel": [0, 1, 1], "stone": [1, 1, 0],
        "tissue": [0, 0, 1], "foam": [0, 1, 1], "brush": [1, 0, 1]}


def _signal_dataset(folder: Path) -> Path:
    """8 SIMULATED classes x 2 trials, one sensor of 2 channels whose rhythm and level follow the attributes."""
    classes = pd.DataFrame.from_dict(ROWS, orient="index", columns=["hard", "rough", "cold"])
    classes.index.name = "class"
    rng = np.random.default_rng(0)
    trials, signals = [], []
    for name, row in classes.iterrows():
        for g in range(2):
            n = int(rng.integers(40, 80))
            t = np.arange(n)
            wave = np.sin(t * (0.2 + 0.6 * row["rough"])) + rng.normal(0, 0.2, n)
            trials.append((f"{name}_{g}", name))
            signals.append([np.column_stack([wave + 2 * row["hard"], row["cold"] * t / n + rng.normal(0, 0.1, n)])])
    return write_plain_dataset(folder, classes, pd.DataFrame(trials, columns=["trial_id", "class"]),
                               sensors=["finger"], signals=signals, channels=("pressure", "vibration"),
                               signal_format="csv",
                               settings={"name": "rocket-SIMULATED", "classes": {"allow_identical_rows": True}})


def test_plain_dataset_appends_rocket_after_the_statistics(rocket, tmp_path):
    folder = _signal_dataset(tmp_path / "data")
    both = load_plain_dataset(folder, statistics=["mean", "rocket"], cache=False)
    assert both.X.shape == (16, 1, 2 * (1 + 2 * 25))
    assert both.feature_names[:2] == ("pressure_mean", "vibration_mean")
    assert both.feature_names[2] == "pressure_rocket0_max" and both.info["statistics"] == ["mean", "rocket"]
    stats = load_plain_dataset(folder, statistics=["mean"], cache=False)
    np.testing.assert_array_equal(both.X[:, :, :2], stats.X)


def test_a_study_naming_rocket_runs_end_to_end(rocket, tmp_path):
    folder = _signal_dataset(tmp_path / "data")
    experiment = tmp_path / "exp.toml"
    experiment.write_text(f"""study = "zero-shot"
[dataset]
plain = "{folder}"
[features]
statistics = ["rocket"]
[splits]
kinds = ["random"]
n_splits = 2
n_test = 2
[methods]
compare = ["eszsl"]
sweep = false
gzsl = false
[svm]
n_C = 1
n_gamma = 1
n_draws = 1
[output]
folder = "{tmp_path / 'results'}"
""")
    done = CliRunner().invoke(cli, ["run", str(experiment), "--no-progress"])
    assert done.exit_code == 0, done.output + done.stderr
    comparison = pd.read_csv(tmp_path / "results" / "method_comparison.csv")
    methods = set(comparison["method"])
    assert "eszsl" in methods and any(m.startswith("dap-avg") for m in methods)
    manifest = (tmp_path / "results" / "manifest.json").read_text()
    assert '"rocket"' in manifest
