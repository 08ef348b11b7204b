"""``make bench``'s study runs: cold and warm on a tiny stand-in study, manifests read as measurements (no timing)."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pandas as pd
import pytest

from tzsl.benchmarks import bench_reproduce
from tzsl.benchmarks._common import MEASURE_COLUMNS, manifest_rows
from tzsl.benchmarks.bench_reproduce import run_split_fit, run_study_list, split_fit_seconds
from tzsl.studies import engine

sys.path.insert(0, str(Path(__file__).parent))
from test_reproduce import TINY_HAND

#: The shared tiny hand study, without the registry methods.
TINY_HAND_NO_COMPARE = TINY_HAND.replace("[splits]", "compare = []\n[splits]")


def test_a_study_list_runs_cold_then_warm_from_an_empty_cache(tmp_path, capsys):
    hand = tmp_path / "hand.toml"
    hand.write_text(TINY_HAND_NO_COMPARE)
    work = tmp_path / "work"
    table = pd.DataFrame(run_study_list("reproduce", work, studies=[str(hand)], n_jobs=1))
    assert tuple(table.columns) == MEASURE_COLUMNS
    assert list(dict.fromkeys(table["run"])) == ["cold", "warm"]
    for run in ("cold", "warm"):
        rows = table[table.run == run]
        # a subset of the studies is not the command: its total is named so, and no goal matches it
        assert set(rows.study) == {"total (subset)", str(hand)}
        process = rows[rows.study == "total (subset)"].set_index("quantity")
        assert list(process.index) == ["wall", "cpu"] and (process["value"] > 0).all()
        study = rows[rows.study == str(hand)]
        assert study.iloc[0][["stage", "quantity"]].tolist() == ["total", "wall"]
        assert {"figures"} <= set(study.stage) and study["simulated"].all()  # the hand's simulated grasps
        counters = study[study.quantity == "count"]
        assert counters.stage.str.startswith("fit_store.").all() and (counters["unit"] == "events").all()
        assert (study[study.quantity == "wall"]["value"] > 0).all()
    assert (work / "reproduce-warm" / "manifest.json").is_file() and (work / "reproduce-cold.log").is_file()
    assert "reproduce, cold run" in capsys.readouterr().out
    with pytest.raises(RuntimeError, match="not empty"):  # a second bench cannot start from a filled cache
        run_study_list("reproduce", work, studies=[str(hand)], n_jobs=1)


def test_a_single_study_manifest_is_read_like_a_study_list_one(tmp_path):
    hand = tmp_path / "hand.toml"
    hand.write_text(TINY_HAND_NO_COMPARE)
    engine.run_experiment(hand, out=tmp_path / "out")  # what tzsl run writes
    manifest = json.loads((tmp_path / "out" / "manifest.json").read_text())
    rows = pd.DataFrame(manifest_rows(manifest, part="template", run="cold", n_jobs=1, simulated=False))
    assert set(rows.study) == {"hand"} and "figures" in set(rows.stage)
    assert rows["simulated"].all()  # read from the study's built-in dataset
    assert not (rows.stage == "total").any()  # tzsl run's whole is the process's time


def test_split_fit_rows_and_the_fits_a_run_is_divided_by(tmp_path, monkeypatch):
    def fake_tzsl(args, **kwargs):
        out = Path(args[args.index("--out") + 1])
        pd.DataFrame({"method": ["tzsl n_jobs=1", "tzsl n_jobs=2"], "split": ["random_0"] * 2,
                      "seconds": [10.0, 6.0], "avgdap_accuracy": [0.4, 0.4]}).to_csv(out, index=False)
        return 12.0, 15.0, ""

    monkeypatch.setattr(bench_reproduce, "run_tzsl", fake_tzsl)
    table = pd.DataFrame(run_split_fit(tmp_path, n_jobs=2, echo=lambda _line: None))
    assert list(zip(table.study, table.stage, table.quantity, table.value, strict=True)) == [
        ("total", "total", "wall", 12.0), ("total", "total", "cpu", 15.0),
        ("random_0", "n_jobs=1", "wall", 10.0), ("random_0", "n_jobs=2", "wall", 6.0)]
    assert (split_fit_seconds(table, 1), split_fit_seconds(table, 2), split_fit_seconds(table, -1)) == (10.0, 6.0, 6.0)


def test_a_study_list_manifest_gives_each_study_its_total_stages_and_counters():
    manifest = {"config": {"studies": {"hand-simulated": {"settings": {"dataset": {"builtin": "hand-simulated"}}},
                                       "fabric": {"settings": {}}}},
                "timings_s": {"hand-simulated_s": 4.0, "fabric_s": 9.0},
                "profile": [{"study": "hand-simulated", "stage": "fit", "wall_s": 3.0, "cpu_s": 2.5, "calls": 2},
                            {"study": "hand-simulated", "stage": "fit_store.miss", "wall_s": 0.0, "cpu_s": 0.0,
                             "calls": 5},
                            {"study": "fabric", "stage": "other", "wall_s": 9.0, "cpu_s": 8.0, "calls": 0}]}
    rows = pd.DataFrame(manifest_rows(manifest, part="reproduce", run="warm", n_jobs=2))
    assert list(zip(rows.study, rows.stage, rows.quantity, rows.value, strict=True)) == [
        ("hand-simulated", "total", "wall", 4.0), ("hand-simulated", "fit", "wall", 3.0),
        ("hand-simulated", "fit", "cpu", 2.5), ("hand-simulated", "fit_store.miss", "count", 5.0),
        ("fabric", "total", "wall", 9.0), ("fabric", "other", "wall", 9.0), ("fabric", "other", "cpu", 8.0)]
    assert rows.groupby("study")["simulated"].all().to_dict() == {"fabric": False, "hand-simulated": True}
    assert set(rows.run) == {"warm"} and set(rows.n_jobs) == {2}
