"""The terminal answers in one screen (issue 43, item 2).

``tzsl run`` of the template on a small SIMULATED plain dataset (8 objects, features as columns:
they follow the attributes, with noise, and measure nothing) ends with at most 40 lines of at most
100 characters without ``--verbose``; ``--verbose`` prints the study's tables too and the CSVs are
the same; no progress bar reaches a stream that is not a terminal. The summary's lines are read
from the run's own tables (hand-made ones here, for the cases a small run does not reach).
"""

from __future__ import annotations

import io
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from tests.csv_compare import folder_csvs
from tests.study_settings import FAST_TEMPLATE
from tzsl._progress import bars_wanted, progress_bar
from tzsl.cli import cli
from tzsl.datasets import write_plain_dataset
from tzsl.models.choices import DEFAULT_METHOD
from tzsl.reporting.terminal import MAX_LINES, WIDTH, notes_only, run_summary, study_lines

REPO = Path(__file__).resolve().parents[2]
TEMPLATE = REPO / "experiments" / "my_dataset_template.toml"
ROWS = {  # hard rough cold soft
    "mug": [1, 0, 1, 0], "sponge": [0, 1, 0, 1], "can": [1, 0, 1, 1], "towel": [0, 1, 0, 0],
    "stone": [1, 1, 1, 0], "tissue": [0, 0, 0, 1], "bottle": [1, 0, 0, 0], "brush": [0, 1, 1, 1],
}


def _template_runs(root: Path) -> dict:
    """The fast template run twice on one small plain dataset: without and with --verbose."""
    classes = pd.DataFrame.from_dict(ROWS, orient="index", columns=["hard", "rough", "cold", "soft"])
    classes.index.name = "class"
    rng = np.random.default_rng(0)
    names = np.repeat(classes.index.to_numpy(), 4)
    levels = classes.loc[names].to_numpy(dtype=float)
    X = np.stack([levels * 2 + rng.normal(0, 0.6, levels.shape) + k for k in range(2)], axis=1)
    write_plain_dataset(root / "my_dataset", classes,
                        pd.DataFrame({"trial_id": [f"t{i}" for i in range(len(names))], "class": names}),
                        sensors=["left", "right"], X=X, feature_names=["f0", "f1", "f2", "f3"],
                        settings={"name": "lab-sim"})
    out: dict = {}
    for name, extra in (("plain", []), ("verbose", ["--verbose"])):
        folder = f"results/{name}"  # relative, as a user types it (the caller runs in root)
        (root / f"{name}.toml").write_text(TEMPLATE.read_text().replace('"results/my_dataset"', f'"{folder}"')
                                           + FAST_TEMPLATE)
        result = CliRunner().invoke(cli, ["run", f"{name}.toml", *extra])
        assert result.exit_code == 0, result.output + result.stderr
        out[name] = result
        out[f"{name}_csvs"] = folder_csvs(root / folder)
    return out


@pytest.mark.slow
def test_the_template_run_fits_one_screen_verbose_prints_the_tables_and_no_bar_is_logged(tmp_path, monkeypatch):
    """One test for both runs (each a few seconds), so parallel workers do not run them twice."""
    monkeypatch.chdir(tmp_path)
    runs = _template_runs(tmp_path)
    text = runs["plain"].stdout  # warnings go to stderr, one line per kind
    lines = text.splitlines()
    assert len(lines) <= MAX_LINES and max(map(len, lines)) <= WIDTH, text
    assert "dataset lab-sim: 32 trials, 8 objects, 2 sensor(s), 4 features per sensor, 4 attributes" in text
    assert "relaxed: " in text and "note: relaxed " in text  # the study's notes, then how many
    assert "random splits, 2 splits, " in text and "accuracy [95% interval], chance " in text
    assert "intervals clear chance" in text or "no interval clears chance" in text
    assert "deploy: " in text and " (deployment.json): " in text  # the study's choice (tests/cli/test_deploy_choice.py)
    assert f"model: tzsl train-attributes --from-results {Path('results/plain')} --out model.tzsl" in text
    assert "tables: 13 CSV and 3 figures in results/plain" in text  # with class_accuracy.csv (per split and class)
    assert "report: tzsl report results/plain" in text and "wrote " in lines[-1]
    assert "Methods vs" not in text  # the tables are --verbose's
    # --verbose: the tables before the summary, and the same files
    verbose = runs["verbose"].stdout
    assert "Methods vs" in verbose and "MAXDAP vs AVGDAP" in verbose
    assert verbose.count("deploy: ") == 1 and verbose.index("Methods vs") < verbose.index("deploy: ")
    assert runs["plain_csvs"] == runs["verbose_csvs"]  # byte for byte, but the wall-clock fit_seconds
    assert len(runs["plain_csvs"]) == 13  # with class_accuracy.csv
    # no carriage-return bar reaches a stream that is not a terminal (CliRunner's are not)
    for name in ("plain", "verbose"):
        assert "\r" not in runs[name].output + runs[name].stderr
        assert "it/s" not in runs[name].stderr


def test_a_progress_bar_is_drawn_only_on_a_terminal(monkeypatch):
    monkeypatch.setattr(sys, "stderr", io.StringIO())
    assert not bars_wanted(True)
    for _ in progress_bar(range(3), show=True, desc="fits"):
        pass
    assert sys.stderr.getvalue() == ""

    class Terminal(io.StringIO):
        def isatty(self) -> bool:
            return True

    monkeypatch.setattr(sys, "stderr", Terminal())
    assert bars_wanted(True) and bars_wanted(None) and not bars_wanted(False)
    for _ in progress_bar(range(3), show=True, desc="fits", file=sys.stderr):
        pass
    assert "fits" in sys.stderr.getvalue() and "\r" in sys.stderr.getvalue()


def _comparison(groups: dict[tuple[str, str], dict[str, tuple[float, float, float]]], chance: float = 0.25):
    rows = []
    for (study, kind), methods in groups.items():
        for method, (acc, low, high) in methods.items():
            rows.append({"study": study, "split_kind": kind, "purpose": "confirm", "method": method,
                         "accuracy": acc, "ci95_low": low, "ci95_high": high, "chance": chance,
                         "reference": "dap-avg", "difference": acc - 0.5, "difference_ci95_low": acc - 0.6,
                         "difference_ci95_high": acc - 0.4, "n_splits": 4})
    return pd.DataFrame(rows)


def test_no_interval_above_chance_is_said_with_the_numbers():
    tables = {"method_comparison": _comparison({("zero-shot", "random"): {
        "dap-avg": (0.3, 0.1, 0.5), "eszsl": (0.35, 0.2, 0.5)}})}
    lines = run_summary(tables, {"dataset": "my-lab"}, Path("results"), [Path("results/method_comparison.csv")])
    text = "\n".join(lines)
    assert "chance 0.250" in text and "eszsl    0.350 [0.200, 0.500]  interval includes chance" in text
    assert "no interval clears chance (2 compared)" in text and "relaxed: nothing" in text
    assert "vs the reference dap-avg: -0.150 [-0.250, -0.050] (interval includes 0)" in text


def test_many_groups_and_long_notes_stay_within_the_screen():
    groups = {(f"zero-shot-{i}{suffix}", kind): {f"m{j}": (0.5 + j / 100, 0.3, 0.7) for j in range(12)}
              for i in range(6) for suffix, kind in (("", "random"), ("-challenging", "challenging"))}
    record = {"dataset": "x", "relaxations": [{"setting": f"s{i}", "asked": 1, "used": 2, "why": "w"}
                                              for i in range(3)]}
    tables = {"method_comparison": _comparison(groups)}
    for printed in (1, 12, 30):  # lines the run printed before (its first line, the study's notes)
        lines = run_summary(tables, record, Path("r"), [], printed=printed)
        assert printed + len(lines) <= MAX_LINES - 3 or printed == 30, (printed, lines)
        assert max(map(len, lines)) <= WIDTH
        assert lines[1] == "relaxed: 3 setting(s) to fit the dataset (the notes above; manifest.json 'relaxations')"
        assert lines[2].startswith("zero-shot-0, random splits")  # the first split kind is always said
        assert any("more split kinds or studies" in line for line in lines)
        assert sum(line.startswith(f"deploy: not chosen here; tzsl train-attributes trains {DEFAULT_METHOD}")
                   for line in lines[-5:]) == 1
        assert lines[-1].startswith("report:")
    per_study = study_lines(tables)
    assert sum("splits: most accurate m11 0.610 [0.300, 0.700]" in line for line in per_study) == 12
    assert all(len(line) <= WIDTH for line in per_study)
    shown: list[str] = []
    say = notes_only(shown.append)
    say("\nA table\n  a  b")
    say("note: relaxed gzsl " + "splits random-1, random-2 " * 10)
    assert shown[0].startswith("note: relaxed gzsl ") and len(shown) == 3 and max(map(len, shown)) <= WIDTH
