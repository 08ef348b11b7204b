"""``tzsl reproduce-tables`` and ``tzsl evidence`` are the built-in experiment files run by the engine: no second
code path; the papers' list fits only what the papers report."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner

from tests.csv_compare import folder_csvs
from tzsl.exceptions import ConfigError
from tzsl.models import available_methods
from tzsl.studies import engine, reproduce
from tzsl.studies.config import load_experiment
from tzsl.studies.reproduce import (
    EVIDENCE_STUDIES,
    REPRODUCE_STUDIES,
    STUDY_LISTS,
    evidence,
    reproduce_experiments,
    reproduce_tables,
)


def test_reproduce_runs_the_builtin_files_unchanged():
    assert REPRODUCE_STUDIES == ("phac2-dap", "fabric", "hand-simulated")
    assert EVIDENCE_STUDIES == ("phac2-evidence", "fabric-evidence", "hand-evidence", "active-touch", "phac2-headlines")
    assert STUDY_LISTS == {"reproduce-tables": (REPRODUCE_STUDIES, False), "evidence": (EVIDENCE_STUDIES, True)}
    for studies in (REPRODUCE_STUDIES, EVIDENCE_STUDIES):
        for name, exp in zip(studies, reproduce_experiments(studies), strict=True):
            assert exp.config == load_experiment(name).config, name


def test_paper_presets_fit_only_what_the_papers_report():
    """No other method, no posterior calibrator (pseudo-unseen folds), no generic part, no partitions:
    the paper tables need accuracies only; all of that is in the evidence presets."""
    phac2, fabric, hand = (load_experiment(name).config for name in REPRODUCE_STUDIES)
    assert phac2.methods.method_specs() == [] and not phac2.methods.gzsl
    assert phac2.methods.multilabel and phac2.methods.sweep and set(phac2.splits.kinds) == {"random", "challenging"}
    assert fabric.methods.compare == [] and not fabric.partitions.enabled and not fabric.zero_shot.enabled
    assert set(fabric.features.conditions) == {"depth-sequence", "depth-image"}
    assert hand.methods.compare == [] and not hand.zero_shot.enabled
    from tzsl.studies.zero_shot.runner import zero_shot_outputs

    assert not [name for name in zero_shot_outputs(phac2) if "method" in name or "reliability" in name]


def test_evidence_presets_are_the_paper_presets_and_what_goes_beyond():
    """Same data, splits, SVM settings and paper protocol; the beyond-paper parts switched on."""
    paper = {name: load_experiment(name).config for name in REPRODUCE_STUDIES}
    beyond = {name: load_experiment(name).config for name in ("phac2-evidence", "fabric-evidence", "hand-evidence")}
    p, e = paper["phac2-dap"], beyond["phac2-evidence"]
    assert (e.dataset, e.splits, e.svm, e.methods.fusions, e.methods.priors) == (
        p.dataset, p.splits, p.svm, p.methods.fusions, p.methods.priors)
    assert {"eszsl", "iap", "sae", "ale", "sje", "devise", "ensemble"} <= {s["name"] for s in e.methods.method_specs()}
    assert e.methods.compare_on == ["random", "challenging"] and e.methods.gzsl and e.methods.multilabel
    for paper_name, name in (("fabric", "fabric-evidence"), ("hand-simulated", "hand-evidence")):
        p, e = paper[paper_name], beyond[name]
        beyond_paper = {"description", "output", "zero_shot", "partitions", "methods"}
        assert p.model_dump(exclude=beyond_paper) == e.model_dump(exclude=beyond_paper), name
        assert p.methods.model_dump(exclude={"compare"}) == e.methods.model_dump(exclude={"compare"}), name
        assert e.methods.compare and e.zero_shot.enabled, name
    assert beyond["fabric-evidence"].partitions.enabled


@pytest.fixture
def recorded(monkeypatch):
    """Replace the study execution by a recorder of the experiments it receives."""
    seen: list = []

    def fake_execute(exp, results, echo=None, study_echo=None):
        seen.append((exp.source, exp.config))
        name = re.sub(r"[^\w-]", "_", exp.source)  # one file per study (two evidence studies share a kind)
        results.write_csv(f"{name}.csv", pd.DataFrame({"x": [1]}))
        return engine.StudyRun({exp.study: None}, {"study_kind": exp.study})

    monkeypatch.setattr(engine, "execute_study", fake_execute)
    monkeypatch.setattr(engine, "check_experiment", lambda exp: None)
    monkeypatch.setattr(reproduce, "fetch_study_data", lambda *args, **kwargs: None)  # no study reads the data
    return seen


def test_reproduce_and_tzsl_run_hand_the_engine_the_same_configs(recorded, tmp_path):
    from tzsl.cli import cli
    result = CliRunner().invoke(cli, ["reproduce-tables", "--out", str(tmp_path / "all"), "--n-jobs", "2",
                                      "--no-progress"])
    assert result.exit_code == 0, result.output
    from_reproduce = list(recorded)
    recorded.clear()
    for name in REPRODUCE_STUDIES:
        ran = CliRunner().invoke(cli, ["run", name, "--out", str(tmp_path / name), "--n-jobs", "2", "--no-progress"])
        assert ran.exit_code == 0, ran.output
    from_run = [(source, config.model_dump(exclude={"output"})) for source, config in recorded]
    assert [(s, c.model_dump(exclude={"output"})) for s, c in from_reproduce] == from_run
    assert [s for s, _ in from_run] == [f"builtin:{n}" for n in REPRODUCE_STUDIES]
    assert all(c["compute"]["n_jobs"] == 2 and c["compute"]["progress"] is False for _, c in from_run)
    manifest = json.loads((tmp_path / "all" / "manifest.json").read_text())
    assert manifest["reproduce_studies"] == list(REPRODUCE_STUDIES) and manifest["study_list"] == "reproduce-tables"
    assert sorted(manifest["config"]["studies"]) == sorted(REPRODUCE_STUDIES)
    assert "resolved_toml" in manifest["config"]["studies"]["phac2-dap"]


def test_evidence_command_runs_its_list_through_the_same_loop(recorded, tmp_path):
    from tzsl.cli import cli
    result = CliRunner().invoke(cli, ["evidence", "--out", str(tmp_path / "ev"), "--n-jobs", "2", "--no-progress"])
    assert result.exit_code == 0, result.output
    assert [s for s, _ in recorded] == [f"builtin:{n}" for n in EVIDENCE_STUDIES]
    manifest = json.loads((tmp_path / "ev" / "manifest.json").read_text())
    assert manifest["study_list"] == "evidence" and manifest["reproduce_studies"] == list(EVIDENCE_STUDIES)
    assert "commit" in manifest
    recorded.clear()
    one = CliRunner().invoke(cli, ["evidence", "--out", str(tmp_path / "one"), "--study", "active-touch"])
    assert one.exit_code == 0, one.output
    assert [s for s, _ in recorded] == ["builtin:active-touch"]


def test_reproduce_refuses_existing_results_before_any_study(recorded, tmp_path):
    (tmp_path / "manifest.json").write_text("{}")
    with pytest.raises(ConfigError, match="already exists"):
        reproduce_tables(tmp_path)
    assert recorded == []


TINY_PHAC2 = """
study = "phac2-dap"
[dataset]
builtin = "phac2-penn"
data_dir = "{data_dir}"
[splits]
kinds = ["random"]
n_splits = 1
[svm]
cv = 3
n_C = 1
n_gamma = 1
n_draws = 1
[compute]
cache = false
progress = false
"""

TINY_HAND = """
study = "hand"
[dataset]
builtin = "hand-simulated"
[simulation]
n_grasps_per_object = 20
[methods]
max_T = 2
max_k = 2
sequence_length = 4
n_sequences = 4
[splits]
seeds = [0]
[zero_shot.splits]
kinds = ["random"]
n_splits = 1
[zero_shot.svm]
cv = 3
n_C = 1
n_gamma = 1
n_draws = 1
grid = "paper"
[compute]
progress = false
"""


@pytest.mark.slow
@pytest.mark.realdata
def test_reproduce_csvs_are_byte_identical_to_running_each_file(tmp_path, data_dir):
    phac2 = tmp_path / "phac2.toml"
    phac2.write_text(TINY_PHAC2.format(data_dir=data_dir))
    hand = tmp_path / "hand.toml"
    hand.write_text(TINY_HAND)
    reproduce_tables(tmp_path / "papers", studies=(str(phac2), str(hand)))
    assert not (tmp_path / "papers" / "method_comparison.csv").exists()  # the papers' list stacks none
    evidence(tmp_path / "all", studies=(str(phac2), str(hand)))  # the same loop, with the stacked comparison
    engine.run_experiment(phac2, out=tmp_path / "phac2")
    engine.run_experiment(hand, out=tmp_path / "hand")
    together = folder_csvs(tmp_path / "all")  # byte for byte but for the wall-clock fit_seconds
    alone = {**folder_csvs(tmp_path / "phac2"), **folder_csvs(tmp_path / "hand")}
    assert {"table1_fusion.csv", "table2_priors.csv", "hand_table5.csv", "hand-simulated_table1_fusion.csv"} <= set(
        together)  # the hand preset's generic tables beside phac2-dap's, no name shared
    # method comparisons hold wall-clock fit times: equal but for those
    timed = {"hand_method_comparison.csv", "method_comparison.csv"}
    assert {k: v for k, v in together.items() if k not in timed} == {k: v for k, v in alone.items() if k not in timed}
    read = lambda p: pd.read_csv(p).drop(columns="fit_seconds")  # noqa: E731
    rows = read(tmp_path / "hand" / "hand_method_comparison.csv")
    pd.testing.assert_frame_equal(read(tmp_path / "all" / "hand_method_comparison.csv"), rows)
    combined = read(tmp_path / "all" / "method_comparison.csv")  # evidence only: every method x study
    pd.testing.assert_frame_equal(combined.iloc[: len(rows)], rows, check_dtype=False)
    rest = combined.iloc[len(rows):]
    assert set(rest["method"]) | set(rows["method"].str.split("_").str[0]) == set(available_methods())
    assert rest["accuracy"].isna().all() and rest["note"].str.startswith("not").all()
    manifest = json.loads((tmp_path / "all" / "manifest.json").read_text())
    assert manifest["reproduce_studies"] == [str(phac2), str(hand)]
    assert set(manifest["outputs"]) >= {f"{name}" for name in together}


def test_reproduce_tables_paths(tmp_path):
    """Built-in names and experiment files both work as studies."""
    path = Path(tmp_path / "h.toml")
    path.write_text(TINY_HAND)
    (exp,) = reproduce_experiments((str(path),), n_jobs=2, seed=5)  # no seed key in a hand study: skipped
    assert exp.config.compute.n_jobs == 2 and exp.config.splits.seeds == [0]
