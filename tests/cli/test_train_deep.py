"""``tzsl train-deep`` end to end: fabric depth images (real data) and user GelSight videos."""

from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner

from tzsl.cli import EXIT_TZSL_ERROR, cli

SKIP_REASON = "PyTorch is not installed (the optional deep extra: pip install 'tzsl[deep]')"
# A small run: random frozen CNN on 16 x 16 frames, a few epochs (checks plumbing, not accuracy).
FAST = ["--backbone", "small-cnn", "--image-size", "16", "--hidden-size", "8", "--epochs", "3", "--no-progress",
        "--n-threads", "1"]


@pytest.fixture
def torch():
    return pytest.importorskip("torch", reason=SKIP_REASON)


def _run(*args: str):
    return CliRunner().invoke(cli, list(args), catch_exceptions=False)


#: Columns of the deep study's tables that hold wall-clock times.
TIMES = ["seconds_per_epoch", "feature_seconds", "seconds_per_epoch_std"]


def _runs(folder):
    import pandas as pd

    return pd.read_csv(folder / "fabric_deep_runs.csv")


def test_option_errors_are_one_line(tmp_path):
    out = tmp_path / "m.tzsl-deep"
    for args, message in [
        (["--lam", "much"], "--lam"),
        (["--finetune", "deep"], "--finetune"),
        (["--resume"], "--resume needs --checkpoint-dir"),
        (["--condition", "Flat"], "--condition needs --gelsight-root"),
    ]:
        result = _run("train-deep", "--out", str(out), *args)
        assert result.exit_code == EXIT_TZSL_ERROR, result.output
        assert message in result.output
    out.write_text("keep me")
    result = _run("train-deep", "--out", str(out))
    assert result.exit_code == EXIT_TZSL_ERROR and "--force" in result.output
    assert out.read_text() == "keep me"


@pytest.mark.slow
def test_train_deep_on_fabric_depth_images(torch, data_dir, tmp_path):
    from tzsl.inference.deep_bundles import load_deep_bundle

    out = tmp_path / "m.tzsl-deep"
    ckpt = tmp_path / "ckpt"
    common = ["--out", str(out), "--data-dir", str(data_dir), "--checkpoint-dir", str(ckpt), *FAST]
    result = _run("train-deep", "--results", str(tmp_path / "a"), *common)
    assert result.exit_code == 0, result.output
    runs = _runs(tmp_path / "a")
    # config 1, its zero-shot protocol (the saved model's fit): group 5 (a training row) left out of the test
    assert runs[["n_train", "n_test"]].values.tolist() == [[92, 21]]
    assert runs["accuracy"].between(0, 1).all() and runs["train_accuracy"].between(0, 1).all()
    model = load_deep_bundle(out)
    assert model.sequence_shape_ == (5, 224, 224, 1) and model.n_epochs_ == 3
    assert sorted(model.classes_.tolist()) == [1, 2, 3, 4, 6]
    # resume from the last epoch: nothing left to train for the same --epochs, same model
    again = _run("train-deep", "--results", str(tmp_path / "b"), "--resume", "--force", *common)
    assert again.exit_code == 0, again.output
    cols = ["accuracy", "train_accuracy", "final_loss"]
    assert _runs(tmp_path / "b")[cols].values.tolist() == runs[cols].values.tolist()


@pytest.mark.slow
def test_train_deep_and_the_matching_experiment_file_write_the_same_tables(torch, data_dir, tmp_path):
    """train-deep is a front-end of the fabric-deep study: its config and tables are those of the file."""
    import pandas as pd

    from tzsl.studies.engine import run_experiment

    result = _run("train-deep", "--out", str(tmp_path / "cli" / "m.tzsl-deep"), "--data-dir", str(data_dir),
                  "--config", "2", "--lam", "inf", "--seed", "3", "--early-stopping", *FAST)
    assert result.exit_code == 0, result.output
    toml = tmp_path / "deep.toml"
    toml.write_text(f"""
study = "fabric-deep"
[dataset]
data_dir = "{data_dir}"
[methods]
embedding_lambdas = ["inf"]
[methods.model]
backbone = "small-cnn"
image_size = 16
hidden_size = 8
epochs = 3
n_threads = 1
early_stopping = true
[splits]
configs = [2]
seed = 3
[compute]
progress = false
[output]
model = "file/m.tzsl-deep"
""")
    run_experiment(toml, out=tmp_path / "file")
    for name in ("fabric_deep_runs.csv", "fabric_deep_table.csv"):
        cli = pd.read_csv(tmp_path / "cli" / name)
        file = pd.read_csv(tmp_path / "file" / name)
        pd.testing.assert_frame_equal(cli.drop(columns=TIMES, errors="ignore"),
                                      file.drop(columns=TIMES, errors="ignore"))
    runs = _runs(tmp_path / "cli")
    assert runs["early_stopping"].all() and 1 <= runs["epochs"].iloc[0] <= 3
    assert (tmp_path / "file" / "m.tzsl-deep").is_file()


def _write_press(path, group: int, rng):
    """A 14-frame 32 x 32 MJPG press: contact-free start, then a group-specific pattern grows."""
    import imageio.v3 as iio

    path.parent.mkdir(parents=True, exist_ok=True)
    ramp = np.clip(np.arange(14) - 3, 0, 8)[:, None, None] / 8.0
    xx = np.arange(32)[None, None, :]
    pattern = 60 + 50 * np.sin(xx * (group + 1) * 0.4) + 10 * group
    frames = 40 + ramp * pattern + rng.normal(0, 2, (14, 32, 32))
    frames = np.repeat(np.clip(frames, 0, 255).astype(np.uint8)[..., None], 3, axis=-1)
    iio.imwrite(path, frames, plugin="FFMPEG", fps=30, codec="mjpeg", quality=10, macro_block_size=16)


def test_train_deep_on_user_gelsight_videos(torch, data_dir, tmp_path):
    from tzsl.inference.deep_bundles import load_deep_bundle

    rng = np.random.default_rng(0)
    root = tmp_path / "gelsight"
    root.mkdir()
    rows = ["fabric_id,fabric_name,group"]
    for g in range(8):
        name = f"F{g + 1:04d}"
        rows.append(f"{g + 1},{name},{g}")
        for press in range(2):
            _write_press(root / "Flat" / name / f"{press}.avi", g, rng)
    (root / "fabric_groups.csv").write_text("\n".join(rows) + "\n")
    out = tmp_path / "v.tzsl-deep"
    result = _run("train-deep", "--out", str(out), "--data-dir", str(data_dir), "--gelsight-root", str(root),
                  "--condition", "Flat", *FAST)
    assert result.exit_code == 0, result.output
    runs = _runs(tmp_path)
    # the saved model's fit is the zero-shot protocol of config 1 (group 5 shares a training row: dropped)
    assert (runs[["condition", "protocol", "n_train", "n_test"]].values.tolist()
            == [["gelsight-Flat", "zero-shot-drop", 10, 4]])
    assert load_deep_bundle(out).sequence_shape_ == (5, 32, 32, 3)


@pytest.mark.slow
def test_deep_fabric_study_table(torch, data_dir, tmp_path):
    """The study behind ``evaluate-fabric --model deep``: runs, table, manifest; refuses overwrites."""
    from tzsl.exceptions import ConfigError
    from tzsl.studies.config import FabricDeepStudy
    from tzsl.studies.fabric.deep import format_deep_table, run_deep_fabric_study
    from tzsl.studies.outputs.results_folder import ResultsDir

    params = {"backbone": "small-cnn", "image_size": 16, "hidden_size": 8, "epochs": 2, "n_threads": 1}
    settings = FabricDeepStudy(splits={"n_seeds": 2, "configs": [1]}, compute={"progress": False},
                               methods={"embedding_lambdas": [0.1, "inf"], "model": params})
    kwargs = dict(data_dir=data_dir, cache_dir=tmp_path / "cache")
    result = run_deep_fabric_study(ResultsDir(tmp_path / "out"), settings, **kwargs)
    runs, table = result["runs"], result["table"]
    # the paper's split (not zero-shot for config 1) and its zero-shot variant, 2 lambdas x 2 seeds each
    assert len(runs) == 8 and set(runs["method"]) == {"lam_0.1", "lam_inf"}
    assert set(runs["protocol"]) == {"paper", "zero-shot-drop"}
    assert (runs["n_train"] == 92).all()
    assert runs.groupby("protocol")["n_test"].first().to_dict() == {"paper": 27, "zero-shot-drop": 21}
    assert table["n_seeds"].tolist() == [2, 2, 2, 2]
    mean = runs.groupby(["protocol", "method"], sort=False)["accuracy"].mean()
    got = table.set_index(["protocol", "method"])["accuracy"]
    np.testing.assert_allclose(got.loc[mean.index].to_numpy(), mean.to_numpy())
    for name in ("fabric_deep_table.csv", "fabric_deep_runs.csv"):
        assert (tmp_path / "out" / name).is_file()
    assert not (tmp_path / "out" / "fabric_deep_manifest.json").exists()  # the run's one manifest is the engine's
    assert "lam_inf" in format_deep_table(table)
    with pytest.raises(ConfigError, match="--force"):
        run_deep_fabric_study(ResultsDir(tmp_path / "out"), settings, **kwargs)


def test_evaluate_fabric_model_deep_calls_the_deep_study(torch, tmp_path, monkeypatch):
    """``evaluate-fabric --model deep`` hands its options to run_deep_fabric_study (the study
    itself is tested above)."""
    import pandas as pd

    import tzsl.studies.fabric.deep as deep

    seen = {}

    def fake_study(out, settings, record, **kwargs):
        seen.update(kwargs, settings=settings, out=out.final_root)  # out.root is the staging folder while running
        record.update(fabric_deep={"study": "fabric-deep"}, data_files=[])  # what the real study hands the manifest
        table = pd.DataFrame({"condition": ["depth-sequence"], "config": [1], "method": ["lam_0.1"], "n_seeds": [2],
                              **{c: [0.5] for c in ("accuracy", "per_class_mean_accuracy", "train_accuracy")},
                              **{f"{c}_std": [0.0] for c in ("accuracy", "per_class_mean_accuracy", "train_accuracy")},
                              "seconds_per_epoch": [0.1]})
        return {"table": table, "runs": table}

    monkeypatch.setattr(deep, "run_deep_fabric_study", fake_study)
    (tmp_path / "data").mkdir()
    result = _run("evaluate-fabric", "--model", "deep", "--out", str(tmp_path / "res"), "--n-seeds", "2",
                  "--config", "1", "--no-progress", "--data-dir", str(tmp_path / "data"))
    assert result.exit_code == 0, result.output
    settings = seen["settings"]
    assert settings.splits.n_seeds == 2 and settings.splits.configs == [1] and settings.compute.progress is False
    assert seen["out"] == tmp_path / "res"
    assert "50.00 +- 0.00" in result.output and "manifest.json" in result.output
