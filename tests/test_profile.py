"""Where a run's time goes (issue 22, item 1): exclusive wall / CPU seconds per stage."""

from __future__ import annotations

import time

from tzsl._profile import profile_lines, profiling, stage, timed


@timed("fit")
def _fit(seconds: float) -> None:
    time.sleep(seconds)


def test_nested_stages_count_once_and_the_rest_is_other():
    with profiling("study") as profile:
        with stage("tables"):
            time.sleep(0.05)
            _fit(0.1)  # inside "tables": charged to fit only
        time.sleep(0.02)
    rows = {r["stage"]: r for r in profile.rows()}
    assert set(rows) == {"tables", "fit", "other"}
    assert rows["fit"]["calls"] == 1 and rows["tables"]["calls"] == 1 and rows["other"]["calls"] == 0
    assert 0.09 <= rows["fit"]["wall_s"] < 0.2 and 0.04 <= rows["tables"]["wall_s"] < 0.1
    assert rows["other"]["wall_s"] >= 0.015
    assert [r["stage"] for r in profile.rows()][0] == "fit"  # longest first
    assert profile_lines(profile.rows())[1].startswith("study            fit")


def test_stages_cost_nothing_outside_a_profile():
    with stage("fit"):
        pass
    assert _fit(0.0) is None
