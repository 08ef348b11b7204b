"""The generic zero-shot study on the built-in fabric-depth and hand-simulated datasets, and the paper
presets ``fabric`` and ``hand`` that run it before their paper protocol (small settings).

hand-simulated grasps are SIMULATED: these runs exercise the studies, they measure nothing.
"""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner

from tzsl.cli import cli
from tzsl.studies.config import get_study, validate
from tzsl.studies.zero_shot.preset import PRESET_DATASETS, generic_experiment

#: A small generic study: one random and the challenging splits, a one-point SVM grid, two methods.
SMALL = ('[splits]\nn_splits = 1\n[svm]\ncv = 3\nn_C = 1\nn_gamma = 1\nn_draws = 1\ngrid = "paper"\n'
         '[methods]\ncompare = ["eszsl", "sae"]\ncompare_on = ["random", "challenging"]\n')


def _run(path: Path, *args):
    return CliRunner().invoke(cli, ["run", str(path), "--no-progress", *map(str, args)])


def _no_paper_column(folder: Path, pattern: str = "*.csv") -> list[str]:
    """Paper columns or paper notes in any generic table of ``folder``."""
    found = []
    for csv in folder.glob(pattern):
        table = pd.read_csv(csv)
        found += [f"{csv.name}:{c}" for c in table.columns if c.startswith("paper")]
        if "note" in table.columns:
            found += [f"{csv.name}:note" for n in table["note"].dropna().astype(str) if "paper" in n.lower()]
    return found


def _zero_shot(tmp_path: Path, builtin: str, data_dir: Path | None = None) -> Path:
    out = tmp_path / "out"
    home = f'data_dir = "{data_dir}"\n' if data_dir is not None else ""
    path = tmp_path / "zs.toml"
    path.write_text(f'study = "zero-shot"\n[dataset]\nbuiltin = "{builtin}"\n{home}{SMALL}'
                    f'[output]\nfolder = "{out}"\n')
    return path


def _check_generic(out: Path, data: str, prefix: str = "", kinds=("random", "challenging")) -> None:
    comparison = pd.read_csv(out / f"{prefix}method_comparison.csv")
    assert set(comparison["data"]) == {data} and set(comparison["study"]) == {"zero-shot" + (
        f"-{prefix[:-1]}" if prefix else "")}
    assert set(kinds) == set(comparison["split_kind"])
    assert {"eszsl", "sae"} <= set(comparison["method"])
    for name in ("table1_fusion", "gzsl") + (("table3_challenging",) if "challenging" in kinds else ()):
        assert (out / f"{prefix}{name}.csv").is_file(), name
    assert not _no_paper_column(out, f"{prefix}*.csv")


def test_zero_shot_on_hand_simulated_says_simulated_and_no_paper_number(tmp_path):
    result = _run(_zero_shot(tmp_path, "hand-simulated"))
    assert result.exit_code == 0, result.output
    _check_generic(tmp_path / "out", "simulated")
    manifest = json.loads((tmp_path / "out" / "manifest.json").read_text())
    assert manifest["config"]["labels"] == {"study": "zero-shot", "data": "simulated", "paper": False, "note": ""}


@pytest.mark.slow
def test_zero_shot_on_fabric_depth_has_no_paper_number(tmp_path, data_dir):
    """Fabric groups are the objects: 8 classes, 3 of them sharing a row; what cannot be honoured is relaxed."""
    result = _run(_zero_shot(tmp_path, "fabric-depth", data_dir))
    assert result.exit_code == 0, result.output
    _check_generic(tmp_path / "out", "real")
    manifest = json.loads((tmp_path / "out" / "manifest.json").read_text())
    assert manifest["config"]["dataset"] == "fabric-depth"
    relaxed = {r["setting"] for r in manifest["config"]["relaxations"]}
    assert "splits.n_test" in relaxed and "note: relaxed splits.n_test" in result.output


def test_fabric_and_hand_are_presets_of_the_generic_study():
    for name in ("fabric", "hand"):
        kind = get_study(name)
        assert kind.preset_of == "zero-shot" and kind.hook("outputs") is not None
    exp = validate({"study": "fabric", "zero_shot": {"splits": {"n_splits": 2}}}, "f.toml", Path("."))
    generic = generic_experiment(exp)
    assert generic.study == "zero-shot" and generic.config.dataset.builtin == PRESET_DATASETS["fabric"]
    assert generic.config.splits.n_splits == 2 and generic.config.output.prefix == "fabric-depth"
    # the paper protocol's sections are unchanged: the generic part lives in [zero_shot] only
    assert exp.config.splits.configs == [1, 2] and exp.config.methods.embedding_lambdas[-1] == "inf"
    off = validate({"study": "hand", "dataset": {"builtin": "hand-simulated"}, "zero_shot": {"enabled": False}},
                   "h.toml", Path("."))
    assert generic_experiment(off) is None
    # the generic part's files and the paper's never share a name
    outputs = get_study("hand").hook("outputs")(validate(
        {"study": "hand", "dataset": {"builtin": "hand-simulated"}}, "h.toml", Path(".")).config)
    assert len(outputs) == len(set(outputs)) and "hand_table5.csv" in outputs
    assert "hand-simulated_table1_fusion.csv" in outputs


HAND_PRESET = ('study = "hand"\n[dataset]\nbuiltin = "hand-simulated"\n[methods]\nn_sequences = 5\nmax_T = 3\n'
               'max_k = 2\n[splits]\nseeds = [0]\n[zero_shot.splits]\nn_splits = 1\n'
               '[zero_shot.svm]\ncv = 3\nn_C = 1\nn_gamma = 1\nn_draws = 1\ngrid = "paper"\n'
               '[compute]\nprogress = false\n')


def test_hand_preset_writes_the_generic_and_the_paper_tables(tmp_path):
    out = tmp_path / "out"
    path = tmp_path / "hand.toml"
    path.write_text(HAND_PRESET + f'[output]\nfolder = "{out}"\n')
    result = _run(path)
    assert result.exit_code == 0, result.output
    assert (out / "hand_table5.csv").is_file() and (out / "hand_multigrasp_T.csv").is_file()
    assert "paper_T1_ldap" in pd.read_csv(out / "hand_multigrasp_T.csv").columns  # the paper's number stays
    for name in ("table1_fusion", "table3_challenging", "gzsl", "splits"):
        assert (out / f"hand-simulated_{name}.csv").is_file(), name
    assert not _no_paper_column(out, "hand-simulated_*.csv")
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["config"]["study_kind"] == "hand"
    assert manifest["config"]["zero_shot"]["labels"]["data"] == "simulated"
    assert "zero_shot_table1_fusion" in manifest["tables"] and "table5" in manifest["tables"]
    # a second run refuses every file, the generic part's too, before any fit
    again = _run(path)
    assert again.exit_code != 0 and "already exist" in (again.output + str(again.exception))


def test_hand_preset_without_the_generic_part_writes_the_paper_tables_only(tmp_path):
    out = tmp_path / "out"
    path = tmp_path / "hand.toml"
    path.write_text(HAND_PRESET + f'[zero_shot]\nenabled = false\n[output]\nfolder = "{out}"\n')
    result = _run(path)
    assert result.exit_code == 0, result.output
    assert (out / "hand_table5.csv").is_file() and not list(out.glob("hand-simulated_*"))
    assert "generic zero-shot tables not run" in result.output


@pytest.mark.slow
def test_fabric_preset_writes_the_generic_and_the_paper_tables(tmp_path, data_dir):
    out = tmp_path / "out"
    path = tmp_path / "fabric.toml"
    path.write_text(f'study = "fabric"\n[dataset]\ndata_dir = "{data_dir}"\n[features]\nconditions = ["depth-image"]\n'
                    '[methods]\nembedding_lambdas = [0]\nalphas = [0.1]\nmax_iter = 50\n[splits]\nconfigs = [1]\n'
                    'n_seeds = 1\n[zero_shot.splits]\nn_splits = 1\n'
                    '[zero_shot.svm]\ncv = 3\nn_C = 1\nn_gamma = 1\nn_draws = 1\ngrid = "paper"\n'
                    f'[compute]\nprogress = false\n[output]\nfolder = "{out}"\n')
    result = _run(path)
    assert result.exit_code == 0, result.output
    table1 = pd.read_csv(out / "fabric_table1.csv")
    assert [c for c in table1.columns if c.startswith("paper")]  # the paper protocol keeps its numbers
    for name in ("table1_fusion", "table3_challenging", "gzsl"):
        assert (out / f"fabric-depth_{name}.csv").is_file(), name
    assert not _no_paper_column(out, "fabric-depth_*.csv")
