"""The one engine from the command line: CLI == TOML, ``tzsl run NAME``, option validation, exit codes."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner

from tests.csv_compare import folder_csvs
from tzsl.cli import EXIT_TZSL_ERROR, EXIT_USAGE, cli

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "tests" / "studies"))
from test_config_run import _plain_dataset  # noqa: E402


def _run(*args, cwd: Path | None = None):
    return CliRunner().invoke(cli, [str(a) for a in args])


def _csvs(folder: Path) -> dict[str, bytes]:
    return folder_csvs(folder)  # byte for byte but for the wall-clock fit_seconds


EVALUATE_TOML = """
study = "phac2-dap"
[dataset]
plain = "toy"
[splits]
kinds = ["{kind}"]
n_splits = 1
n_test = 4
seed = 3
[svm]
cv = 2
undersampling = "none"
[compute]
cache = false
progress = false
"""


@pytest.fixture(scope="module")
def toy(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("engine_cli")
    _plain_dataset(root / "toy", n_objects=24)
    return root


def _evaluate_and_run(toy: Path, tmp_path: Path, kind: str) -> tuple[dict, dict]:
    cli_out, toml_out = tmp_path / "cli", tmp_path / "toml"
    result = _run("evaluate", "--split", kind, "--plain", toy / "toy", "--n-splits", 1, "--n-test", 4, "--seed", 3,
                  "--cv", 2, "--undersampling", "none", "--no-cache", "--no-progress", "--out", cli_out)
    assert result.exit_code == 0, result.output
    experiment = toy / f"evaluate_{kind}.toml"
    experiment.write_text(EVALUATE_TOML.format(kind=kind))
    ran = _run("run", experiment, "--out", toml_out)
    assert ran.exit_code == 0, ran.output
    return _csvs(cli_out), _csvs(toml_out)


def test_evaluate_builds_the_same_config_as_the_toml(toy):
    from tzsl.cli._dap_commands import evaluate_values
    from tzsl.studies.config import config_from_options, load_experiment

    path = toy / "same.toml"
    path.write_text(EVALUATE_TOML.format(kind="challenging") + '[output]\nfolder = "o"\n')
    values = evaluate_values(kind="challenging", splits_file=None, n_splits=1, n_test=4, multilabel=False,
                             sweep=False, out="o", dataset=None, features_file=None, plain_dir=toy / "toy", path=None,
                             undersampling="none", cv=2, grid=None, no_progress=True, no_cache=True, seed=3,
                             n_jobs=1, backend="loky", scheduler=None, data_dir=None)
    from_cli, from_file = config_from_options("phac2-dap", values), load_experiment(path)
    assert from_cli.config.svm.grid == "extended"  # left out: the schema's default, as in the file
    assert config_from_options("phac2-dap", {**values, "svm.grid": "paper"}).config.svm.grid == "paper"
    assert from_cli.resolve(from_cli.config.dataset.plain) == from_file.resolve(from_file.config.dataset.plain)
    # the shared options' paths are absolute (tzsl.studies.config.option_values), the file's relative to its folder
    assert Path(from_cli.config.output.folder) == Path("o").absolute()
    assert from_cli.config.model_dump(exclude={"dataset": {"plain"}, "output": {"folder"}}) == \
        from_file.config.model_dump(exclude={"dataset": {"plain"}, "output": {"folder"}})


def test_evaluate_random_gives_the_toml_csvs_byte_for_byte(toy, tmp_path):
    from_cli, from_toml = _evaluate_and_run(toy, tmp_path, "random")
    assert "table1_fusion.csv" in from_cli
    assert from_cli == from_toml


@pytest.mark.slow
def test_evaluate_challenging_gives_the_toml_csvs_byte_for_byte(toy, tmp_path):
    from_cli, from_toml = _evaluate_and_run(toy, tmp_path, "challenging")
    assert "table3_challenging.csv" in from_cli
    assert from_cli == from_toml


def test_run_name_print_config_round_trip(tmp_path):
    for name in ("phac2-dap", "hand-simulated", "fabric"):
        printed = _run("run", name, "--print-config")
        assert printed.exit_code == 0, printed.output
        path = tmp_path / f"{name}.toml"
        path.write_text(printed.output)
        again = _run("run", path, "--print-config")
        assert again.exit_code == 0 and again.output == printed.output
    over = _run("run", "phac2-dap", "--print-config", "--n-jobs", 2, "--seed", 7, "--no-progress")
    assert "n_jobs = 2" in over.output and "seed = 7" in over.output and "progress = false" in over.output


def test_run_unknown_name_lists_the_builtin_studies():
    result = _run("run", "phac2")
    assert result.exit_code == EXIT_TZSL_ERROR
    assert "no such experiment file or built-in study" in result.output and "hand-simulated" in result.output


@pytest.mark.parametrize("args", [("--n-jobs", 0), ("--seed", -1), ("--seed", 2**40), ("--n-jobs", "two")])
@pytest.mark.parametrize("command", [("run", "phac2-dap"), ("evaluate",), ("evaluate-fabric",), ("evaluate-hand",),
                                     ("reproduce-tables",)])
def test_bad_options_are_usage_errors_in_one_line(command, args):
    if command == ("reproduce-tables",) and args[0] == "--seed":
        pytest.skip("reproduce-tables runs the built-in files' seeds")
    result = _run(*command, *args)
    assert result.exit_code == EXIT_USAGE, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("tzsl: error: ") and args[0] in lines[0], result.output


def test_run_option_that_does_not_apply_is_refused():
    result = _run("run", "fabric", "--backend", "dask")
    assert result.exit_code == EXIT_TZSL_ERROR and "--backend does not apply to study 'fabric'" in result.output


def test_run_check_finds_missing_paths_and_split_file(tmp_path):
    (tmp_path / "toy").mkdir()
    path = tmp_path / "exp.toml"
    path.write_text("study = 'phac2-dap'\n[dataset]\nplain = 'missing'\n")
    result = _run("run", path, "--check")
    assert result.exit_code == EXIT_TZSL_ERROR and f"{path}: dataset.plain: folder" in result.output
    path.write_text("study = 'phac2-dap'\n[dataset]\nplain = 'toy'\n[splits]\nkinds = ['file']\n"
                    "[compute]\nn_jobs = 0\n")
    result = _run("run", path, "--check")
    assert result.exit_code == EXIT_TZSL_ERROR and f"{path}: compute.n_jobs: n_jobs = 0" in result.output
    path.write_text("study = 'phac2-dap'\n[dataset]\nplain = 'toy'\n[splits]\nkinds = ['file']\n")
    result = _run("run", path, "--check")
    assert result.exit_code == EXIT_TZSL_ERROR and "splits.kinds: file" in result.output and "splits.csv not found" \
        in result.output


def test_run_check_relaxes_too_many_folds_and_says_so(toy):
    """Issue 20: more folds than training objects are lowered to what the dataset allows, with a note."""
    path = toy / "folds.toml"
    path.write_text("study = 'phac2-dap'\n[dataset]\nplain = 'toy'\n[svm]\ncv = 50\n")
    result = _run("run", path, "--check")
    assert result.exit_code == 0, result.output
    assert "note: relaxed svm.cv: 50 -> 14 (a split has only 14 training objects)" in result.output
    path.write_text("study = 'phac2-dap'\n[dataset]\nplain = 'toy'\n[svm]\ncv = 3\n")
    result = _run("run", path, "--check")
    assert result.exit_code == 0 and "relaxed" not in result.output


def test_train_attributes_refuses_too_many_folds_before_any_fit(toy, tmp_path):
    """Outside a study there is no split to relax for: the one-line refusal stands."""
    model = tmp_path / "m.tzsl"
    result = _run("train-attributes", "--plain", toy / "toy", "--cv", 50, "--no-progress", "--out", model)
    assert result.exit_code == EXIT_TZSL_ERROR
    assert result.output.strip() == ("tzsl: error: command line: svm.cv: 50 object-grouped folds, but a split has "
                                     "only 24 training objects; use at most 24 (0 = leave-one-object-out)")
    assert not model.exists()


def test_run_check_relaxes_test_objects_per_split(toy):
    path = toy / "draw.toml"
    path.write_text("study = 'phac2-dap'\n[dataset]\nplain = 'toy'\n[splits]\nkinds = ['random']\nn_test = 22\n"
                    "[svm]\ncv = 2\n")
    result = _run("run", path, "--check")
    assert result.exit_code == 0, result.output
    assert "note: relaxed splits.n_test: 22 -> " in result.output


@pytest.mark.parametrize("command", ["evaluate", "train-attributes"])
def test_binary_features_csv_is_one_clear_error(tmp_path, command):
    binary = tmp_path / "features.csv"
    binary.write_bytes(bytes(range(256)) * 16)
    out = tmp_path / ("m.tzsl" if command == "train-attributes" else "o")
    result = _run(command, "--features", binary, "--no-progress", "--out", out)
    assert result.exit_code == EXIT_TZSL_ERROR and "Traceback" not in result.output
    assert result.stderr.strip() == f"tzsl: error: {binary}: not a UTF-8 text file (a binary file given as CSV?)"
    assert not out.exists()


def test_binary_experiment_file_is_one_clear_error(tmp_path):
    path = tmp_path / "exp.toml"
    path.write_bytes(bytes(range(256)))
    result = _run("run", path)
    assert result.exit_code == EXIT_TZSL_ERROR
    assert result.output.strip() .startswith(f"tzsl: error: {path}: not a text (UTF-8) TOML file")
    assert "Traceback" not in result.output


def test_help_imports_no_heavy_library():
    """``tzsl --help`` stays fast: registering every command imports neither pandas, sklearn nor pydantic."""
    code = ("import sys; from tzsl.cli import cli; "
            "from click.testing import CliRunner; r = CliRunner().invoke(cli, ['--help']); assert r.exit_code == 0; "
            "print(sorted(m for m in ('pandas', 'sklearn', 'pydantic', 'numpy', 'torch') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         env={"PYTHONPATH": str(REPO), "PATH": "/usr/bin:/bin"})
    assert out.stdout.strip() == "[]", out.stdout + out.stderr


def test_unreachable_scheduler_is_one_error_before_any_data(tmp_path):
    pytest.importorskip("distributed")
    result = _run("evaluate", "--backend", "dask", "--scheduler", "tcp://unreachable:8786", "--out", tmp_path / "o")
    assert result.exit_code == EXIT_TZSL_ERROR
    assert "command line: compute.scheduler: cannot reach the Dask scheduler tcp://unreachable:8786" in result.output
    assert not (tmp_path / "o").exists()
