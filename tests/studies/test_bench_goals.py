"""``make bench``'s table: goals attached to the measurements they name, ratios, the printout and ``--only``.

Every run here is a fake (hand-made measurements, stand-ins for the parts): the table and its
formatting are checked, never a speed (a speed goal is checked by the benchmark, not by a test).
"""

from __future__ import annotations

import math

import pandas as pd
import pytest

from tzsl.benchmarks import bench_goals
from tzsl.benchmarks._common import measurement
from tzsl.benchmarks.bench_goals import BENCH_COLUMNS, bench_table, main, summary_lines
from tzsl.benchmarks.goals import GOALS, PARTS, Goal, goal_by_name


def _m(part, study, stage, run, quantity, unit, value, *, n_jobs=2, simulated=False):
    return measurement(part, study, stage, run, quantity, unit, value, n_jobs=n_jobs, simulated=simulated, load=1.0)


def _fake_rows(*, reproduce_cold=128.0, split_fit=True):
    rows = []
    if split_fit:
        rows += [_m("split-fit", "random_0", "n_jobs=1", "cold", "wall", "s", 16.0),
                 _m("split-fit", "random_0", "n_jobs=2", "cold", "wall", "s", 8.0)]
    for run, wall in (("cold", reproduce_cold), ("warm", 3.0)):
        rows += [_m("reproduce", "total", "total", run, "wall", "s", wall),
                 _m("reproduce", "total", "total", run, "cpu", "s", 2 * wall),
                 _m("reproduce", "fabric", "total", run, "wall", "s", wall / 2),
                 _m("reproduce", "fabric", "fit", run, "wall", "s", wall / 4),
                 _m("reproduce", "fabric", "fit_store.hit", run, "count", "events", 7)]
    rows += [_m("template", "total", "total", run, "wall", "s", wall, simulated=True)
             for run, wall in (("cold", 290.0), ("warm", 2.0))]
    for method, cold in (("eszsl", 0.8), ("dap", 4.0)):
        rows += [_m("predict", method, "predict", "cold", "wall", "s", [cold, cold + 1, cold - 0.1], n_jobs=1,
                    simulated=True),
                 _m("predict", method, "load", "api", "wall", "ms", 50.0, n_jobs=1, simulated=True),
                 _m("predict", method, "rank", "api", "per_grasp", "ms", [0.1, 0.2, 30.0], n_jobs=1, simulated=True),
                 _m("predict", method, "add", "api", "per_grasp", "ms", 12.0 if method == "dap" else 0.2, n_jobs=1,
                    simulated=True)]
    return rows


def _goal_rows(table, name):
    return table[table["goal"] == name]


def test_every_goal_is_beside_its_measurement_or_says_who_measures_it():
    table = bench_table(_fake_rows(), ("reproduce", "template", "predict"))
    assert tuple(table.columns) == BENCH_COLUMNS
    assert set(table["goal"]) - {""} == {goal.name for goal in GOALS}  # every goal, written once
    cold = _goal_rows(table, "reproduce-cold").iloc[0]
    assert (cold.study, cold.stage, cold.run, cold.quantity, cold.value) == ("total", "total", "cold", "wall", 128.0)
    assert cold.goal_limit == goal_by_name("reproduce-cold").limit and cold.meets_goal is False
    # the ratio divides by the split fit of the run's n_jobs (2 jobs: the n_jobs=2 fits)
    ratio = _goal_rows(table, "reproduce-cold-ratio").iloc[0]
    assert ratio.value == pytest.approx(128.0 / 8.0) and ratio.unit == "x" and ratio.meets_goal is False
    assert _goal_rows(table, "reproduce-warm").iloc[0].meets_goal is True
    template = _goal_rows(table, "template-cold").iloc[0]
    assert template.simulated and template.meets_goal is True and template.value == 290.0
    # predict: the goal on each method; the median of the repeats, with min and max beside it
    predict = _goal_rows(table, "predict-cold").set_index("study")
    assert list(predict.index) == ["eszsl", "dap"]
    assert predict.at["eszsl", "value"] == 0.8 and predict.at["eszsl", "max"] == 1.8 and predict.at["eszsl", "n"] == 3
    assert predict.at["eszsl", "meets_goal"] and not predict.at["dap", "meets_goal"]
    api = _goal_rows(table, "predict-api")
    assert set(zip(api.study, api.stage, strict=True)) == {(m, s) for m in ("eszsl", "dap") for s in ("rank", "add")}
    assert api.set_index(["study", "stage"]).at[("eszsl", "rank"), "value"] == 0.2  # median, not the slow outlier
    assert table[(table.stage == "load") & (table.part == "predict")]["goal"].eq("").all()  # loading once: no goal
    # goals this run did not measure: a row each, empty value, the reason in the note
    notes = table[table["value"].isna()].set_index("goal")["note"]
    assert notes["evidence-cold"] == "not measured in this run (--only evidence)"
    assert "make bench-scale" in notes["scale-100k"] and "new clone" in notes["fresh-clone"]
    assert table[table["value"].isna()]["meets_goal"].isna().all()


def test_every_wall_time_of_a_study_part_has_its_ratio_and_none_without_a_split_fit():
    table = bench_table(_fake_rows(), ("reproduce", "template", "predict"))
    walls = table[table.part.isin(["reproduce", "template"]) & (table.quantity == "wall")]
    ratios = table[table.quantity == "ratio_to_split_fit"]
    assert len(ratios) == len(walls)
    fit = table[(table.part == "reproduce") & (table.study == "fabric") & (table.stage == "fit")]
    assert fit.set_index(["run", "quantity"]).at[("cold", "ratio_to_split_fit"), "value"] == pytest.approx(32.0 / 8.0)
    assert table[(table.part == "predict")]["quantity"].ne("ratio_to_split_fit").all()
    one_job = bench_table([_m("split-fit", "random_0", "n_jobs=1", "cold", "wall", "s", 16.0),
                           _m("split-fit", "random_0", "n_jobs=2", "cold", "wall", "s", 8.0),
                           _m("reproduce", "total", "total", "cold", "wall", "s", 32.0, n_jobs=1)], ("reproduce",))
    assert _goal_rows(one_job, "reproduce-cold-ratio").iloc[0].value == pytest.approx(2.0)  # the one-job fits
    bare = bench_table(_fake_rows(split_fit=False), ("reproduce",))
    assert not (bare[bare.value.notna()].quantity == "ratio_to_split_fit").any()
    assert math.isnan(_goal_rows(bare, "reproduce-cold-ratio").iloc[0].value)


def test_printout_names_every_goal_met_or_not_and_labels_simulated_numbers():
    table = bench_table(_fake_rows(), ("reproduce", "template", "predict"))
    lines = summary_lines(table)
    text = "\n".join(lines)
    for goal in GOALS:
        assert goal.text in text
    template = next(line for line in lines if goal_by_name("template-cold").text in line)
    assert "SIMULATED" in template and "290 s -> met" in template
    assert next(line for line in lines if line.strip().startswith("tzsl reproduce-tables, cold (")).endswith(
        "128 s -> NOT MET")
    assert "16.00x -> NOT MET" in text and "[dap add] SIMULATED" in text
    # goals first, in the goal table's order; then a block per part, runs across
    goal_lines = [line for line in lines[1:len(GOALS) + 3] if line.startswith("  ")]
    firsts = [next(g.name for g in GOALS if g.text in line) for line in goal_lines]
    assert firsts == sorted(firsts, key=[g.name for g in GOALS].index)
    assert "template (SIMULATED data)" in lines and "predict (SIMULATED data)" in lines
    header = next(line for line in lines if line.strip().startswith("study") and "warm" in line)
    assert header.split()[-2:] == ["cold", "warm"]
    assert any("fit_store.hit" in line and "7 events" in line for line in lines)


def test_two_goals_on_one_measurement_are_refused(monkeypatch):
    monkeypatch.setattr(bench_goals, "GOALS", (*GOALS, Goal("again", "again", 1.0, "s", "reproduce")))
    with pytest.raises(ValueError, match="all match one measurement"):
        bench_table(_fake_rows(), ("reproduce",))


def test_only_runs_the_parts_asked_and_writes_one_csv(tmp_path, monkeypatch, capsys):
    calls = []
    fakes = _fake_rows()

    def part_rows(part):
        def run(*args, **kwargs):
            calls.append(part)
            return [row for row in fakes if row["part"] == part]
        return run

    monkeypatch.setattr(bench_goals, "run_split_fit", part_rows("split-fit"))
    monkeypatch.setattr(bench_goals, "run_template", part_rows("template"))
    monkeypatch.setattr(bench_goals, "run_predict", part_rows("predict"))
    monkeypatch.setattr(bench_goals, "run_study_list", lambda part, *a, **k: part_rows(part)())
    out = tmp_path / "bench.csv"
    main(["--only", "predict", "--out", str(out)])
    assert calls == ["predict"]  # no split fit: no part of studies
    written = pd.read_csv(out, keep_default_na=False, na_values=[""])
    assert tuple(written.columns) == BENCH_COLUMNS
    assert set(written[written["value"].notna()]["part"]) == {"predict"}
    assert written["simulated"].astype(str).eq("True").sum() == 8
    assert f"wrote {out}" in capsys.readouterr().out
    before = out.read_bytes()
    with pytest.raises(SystemExit):
        main(["--only", "predict", "--out", str(out)])  # no --force: refused before any run
    assert out.read_bytes() == before and calls == ["predict"]
    calls.clear()
    main(["--only", "template", "--only", "reproduce", "--out", str(out), "--force"])
    assert calls == ["split-fit", "reproduce", "template"]  # the fits first, then the goal table's order
    calls.clear()
    main([])
    assert calls == ["split-fit", "reproduce", "template", "predict"]  # evidence only when asked
    assert set(PARTS) - set(bench_goals.DEFAULT_PARTS) == {"evidence"}
    with pytest.raises(SystemExit):
        main(["--only", "scale"])


def test_a_failed_run_or_a_bad_option_is_one_line(tmp_path, monkeypatch, capsys):
    def failing(*args, **kwargs):
        raise RuntimeError("tzsl bench --skip-literal failed (exit 3):\ntzsl: error: data missing")

    monkeypatch.setattr(bench_goals, "run_split_fit", failing)
    out = tmp_path / "bench.csv"
    with pytest.raises(SystemExit) as exited:
        main(["--only", "reproduce", "--out", str(out)])
    assert exited.value.code == 3 and not out.exists()
    assert "bench: error: tzsl bench --skip-literal failed" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exited:
        main(["--only", "predict", "--methods", "svm-forest"])
    assert exited.value.code == 2 and "unknown svm-forest" in capsys.readouterr().err
