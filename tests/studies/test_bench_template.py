"""``make bench``'s template part: the SIMULATED dataset's shape and the unchanged template beside it (no timing)."""

from __future__ import annotations

from pathlib import Path

import pytest

from tzsl.benchmarks import bench_template
from tzsl.benchmarks.bench_template import DEFAULT_TEMPLATE, TEMPLATE_SHAPE, run_template, write_template_dataset
from tzsl.datasets import read_plain_dataset

REPO = Path(__file__).resolve().parents[2]


def test_the_simulated_dataset_has_the_shape_of_the_public_one(tmp_path):
    data = read_plain_dataset(write_template_dataset(tmp_path / "my_dataset"))
    assert data.X.shape == (2549, 3, TEMPLATE_SHAPE["n_features"])  # 2,549 grasps, 3 fingers
    assert data.classes.shape == (41, TEMPLATE_SHAPE["n_attributes"])
    assert data.trials["object_name"].nunique() == 41 and data.trials["class"].nunique() == 41  # an object a class
    assert "SIMULATED" in data.name
    assert len(data.classes.drop_duplicates()) == 41 and data.classes.sum().min() >= 2  # distinct rows, each
    # attribute present in 2+ objects


def test_the_template_is_timed_unchanged_beside_the_dataset(tmp_path, monkeypatch):
    seen = {}

    def fake_cold_and_warm(part, args, work, **kwargs):
        seen.update(part=part, args=args, **kwargs)
        return []

    monkeypatch.setattr(bench_template, "cold_and_warm", fake_cold_and_warm)
    template = REPO / DEFAULT_TEMPLATE
    run_template(tmp_path, template=template, n_jobs=1, echo=lambda _line: None)
    command, experiment = seen["args"]
    assert (seen["part"], command, seen["simulated"], seen["n_jobs"]) == ("template", "run", True, 1)
    assert Path(experiment).read_text() == template.read_text()  # the shipped file, not an edited copy
    assert read_plain_dataset(Path(experiment).parent / "my_dataset").X.shape[0] == TEMPLATE_SHAPE["n_trials"]
    with pytest.raises(FileNotFoundError, match="no such template"):
        run_template(tmp_path / "other", template=tmp_path / "missing.toml")
