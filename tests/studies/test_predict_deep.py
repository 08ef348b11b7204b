"""``tzsl predict`` with a saved deep (CNN + LSTM) bundle: nearest attribute vector, SC/DF fusion."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from tzsl.cli import cli
from tzsl.inference.predict import read_class_table
from tzsl.inference.recogniser import predict_grasps
from tzsl.inference.zero_shot_bundles import load_predictor

torch = pytest.importorskip("torch", reason="PyTorch is not installed (the optional deep extra)")

from tzsl.inference.deep_bundles import save_deep_bundle  # noqa: E402
from tzsl.models import DeepAttributeEmbedding  # noqa: E402

A = np.array([[1, 0, 1], [0, 1, 1], [1, 1, 0]], dtype=float)


def _sequences(seed: int = 0):
    rng = np.random.default_rng(seed)
    y = np.repeat(np.arange(3), 6)
    X = 60 + 60 * y[:, None, None, None] + rng.normal(0, 4, (len(y), 5, 12, 12))
    return np.clip(X, 0, 255).astype(np.uint8), y


@pytest.fixture
def deep_bundle(tmp_path):
    torch.set_num_threads(1)
    X, y = _sequences()
    model = DeepAttributeEmbedding(backbone="small-cnn", finetune="all", hidden_size=8, epochs=3, batch_size=6,
                                   lr=1e-2, random_state=0, n_threads=1).fit(X, y, A)
    path = tmp_path / "model.tzsl-deep"
    save_deep_bundle(model, path)
    return model, path


def test_deep_bundle_scores_equal_the_model(deep_bundle, tmp_path):
    model, path = deep_bundle
    X, _ = _sequences(seed=1)
    files = []
    for i in (0, 7, 13):
        f = tmp_path / f"press_{i}.npz"
        np.savez(f, frames=X[i])
        files.append(f)
    predictor = load_predictor(path)
    classes = pd.DataFrame(A.astype(int), index=pd.Index(["a", "b", "c"], name="class"),
                           columns=predictor.attribute_names)
    pred = predict_grasps(predictor, classes, files, mode="df")
    expected = model.predict_proba(X[[0, 7, 13]], A)
    np.testing.assert_allclose(pred.grasp_posteriors, expected, rtol=1e-6)
    # DF-MDAP: nearest class to the mean attribute estimate of the three presses
    F = model.transform(X[[0, 7, 13]]).mean(axis=0)
    assert pred.final == int(np.argmin(((F[None] - A) ** 2).sum(axis=1)))


def test_predict_cli_with_deep_bundle(deep_bundle, tmp_path):
    _, path = deep_bundle
    X, _ = _sequences(seed=2)
    np.savez(tmp_path / "p1.npz", frames=X[0])
    np.savez(tmp_path / "p2.npz", frames=X[1])
    classes = tmp_path / "classes.csv"
    pd.DataFrame({"class": ["a", "b", "c"], "attr_0": A[:, 0].astype(int), "attr_1": A[:, 1].astype(int),
                  "attr_2": A[:, 2].astype(int)}).to_csv(classes, index=False)
    read_class_table(classes, ["attr_0", "attr_1", "attr_2"])
    result = CliRunner().invoke(cli, ["predict", "--model", str(path), "--classes", str(classes), "--k", "2",
                                      str(tmp_path / "p1.npz"), str(tmp_path / "p2.npz")])
    assert result.exit_code == 0, result.output
    assert "SC-MDAP (k=2)" in result.output
    bad = CliRunner().invoke(cli, ["predict", "--model", str(path), "--classes", str(classes),
                                   str(tmp_path / "missing.npz")])
    assert bad.exit_code == 3 and "missing.npz" in bad.output
