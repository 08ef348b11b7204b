"""PHAC-2 end to end through the command line: splits -> train-attributes --out -> predict."""

from __future__ import annotations

import numpy as np
import pandas as pd
from click.testing import CliRunner

from tzsl.cli import cli
from tzsl.datasets._feature_table import read_feature_table, write_feature_table
from tzsl.inference.bundle import read_bundle_header
from tzsl.inference.zero_shot_bundles import load_predictor
from tzsl.models.choices import DEFAULT_METHOD


def _ok(args):
    result = CliRunner().invoke(cli, [str(a) for a in args], catch_exceptions=False)
    assert result.exit_code == 0, result.output
    return result.output


def test_train_on_split_then_predict_unseen_object(data_dir, tmp_path):
    splits, model, feats = tmp_path / "splits.csv", tmp_path / "model.tzsl", tmp_path / "features.npz"
    _ok(["splits", "--split", "random", "--n-splits", "1", "--out", splits, "--data-dir", data_dir])
    out = _ok(["train-attributes", "--splits", splits, "--out", model, "--cv", "3", "--no-progress", "--no-cache",
               "--data-dir", data_dir])
    assert "wrote" in out
    header = read_bundle_header(model)
    assert header.kind == "zero-shot" and header.metadata["method"] == DEFAULT_METHOD
    meta = header.metadata
    table = pd.read_csv(splits)
    test_objects = table.loc[table["role"] == "test", "object"].tolist()
    assert set(meta["training_objects"]).isdisjoint(test_objects)
    assert len(meta["training_objects"]) == 50

    _ok(["extract", "--dataset", "phac2-penn", "--out", feats, "--data-dir", data_dir])
    fs = read_feature_table(feats)
    classes = tmp_path / "classes.csv"
    fs.attributes.loc[test_objects, meta["attribute_names"]].rename_axis("class").reset_index().to_csv(
        classes, index=False)
    obj = test_objects[0]
    one = tmp_path / "object.npz"
    write_feature_table(fs.subset(fs.objects == obj), one)
    out = _ok(["predict", "--model", model, "--classes", classes, "--multi-grasp", "df", one])
    assert "DF-MDAP: decided" in out
    # the bundle predicts exactly what the saved attribute model gives
    predictor = load_predictor(model)
    P = predictor.model.attribute_scores(fs.subset(fs.objects == obj).X)
    assert P.shape == (10, 2, len(meta["attribute_names"]))
    assert np.all((P >= 0) & (P <= 1))


def test_train_attributes_refuses_overwrite(data_dir, tmp_path):
    model = tmp_path / "model.tzsl"
    model.write_text("x")
    result = CliRunner().invoke(cli, ["train-attributes", "--out", str(model), "--data-dir", str(data_dir)])
    assert result.exit_code == 3 and "--force" in result.output
