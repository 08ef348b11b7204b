"""``[svm] detector``: the attribute detector family of a study's own DAP (issue 32).

The paper presets keep the DAP paper's RBF-SVM; the generic study defaults to
:data:`tzsl.models.attribute_training.STUDY_DETECTOR`. The dataset of the run is SIMULATED: it
exercises the labels and the wiring, it measures nothing.
"""

from __future__ import annotations

import pandas as pd
import pytest
from click.testing import CliRunner

from tests.studies.test_zero_shot_study import TEMPLATE, simulated_dataset
from tzsl.cli import cli
from tzsl.exceptions import TzslError
from tzsl.models.attribute_training import STUDY_DETECTOR
from tzsl.studies.config import dap_label, load_experiment


def _experiment(tmp_path, body: str, study: str = "zero-shot", dataset: str = 'builtin = "phac2-penn"'):
    path = tmp_path / "exp.toml"
    path.write_text(f'study = "{study}"\n[dataset]\n{dataset}\n{body}')
    return path


def test_paper_presets_keep_the_rbf_svm_and_the_generic_study_takes_the_chosen_family():
    assert load_experiment("phac2-dap").config.svm.detector == "rbf-svm"
    assert load_experiment("phac2-headlines").config.svm.detector == "rbf-svm"
    template = load_experiment(TEMPLATE)
    assert template.config.svm.detector == STUDY_DETECTOR


def test_an_unknown_detector_is_one_line_naming_the_key(tmp_path):
    with pytest.raises(TzslError, match=r"svm\.detector.*unknown detector 'rbf'"):
        load_experiment(_experiment(tmp_path, '[svm]\ndetector = "rbf"\n'))


def test_the_study_dap_named_in_compare_is_read_from_the_study_fits(tmp_path):
    """Issue 43: no longer refused; the entry names the study's own DAP row, fitted once."""
    exp = load_experiment(_experiment(tmp_path, '[methods]\ncompare = ["dap-avg-logistic-c1", "eszsl"]\n'
                                                '[svm]\ndetector = "logistic-c1"\n'))
    assert exp.config.methods.compare == [{"name": "eszsl"}]


def test_dap_labels_name_the_family_except_the_papers():
    assert dap_label("avg") == "dap-avg" and dap_label("max", "rbf-svm") == "dap-max"
    assert dap_label("avg", "logistic-c1") == "dap-avg-logistic-c1"  # the alias of that configuration


def test_a_study_with_a_linear_detector_labels_its_dap_rows_and_pairs_with_them(tmp_path):
    data = simulated_dataset(tmp_path / "data", 10, 4, 2, seed=1)
    out = tmp_path / "out"
    path = _experiment(tmp_path, '[methods]\ncompare = ["dap-avg", "eszsl"]\ngzsl = false\nsweep = false\n'
                                 '[splits]\nkinds = ["random"]\nn_splits = 2\nn_test = 3\n'
                                 '[svm]\ndetector = "logistic-c1"\ncv = 2\n'
                                 f'[output]\nfolder = "{out}"\n', dataset=f'plain = "{data}"')
    result = CliRunner().invoke(cli, ["run", str(path), "--no-progress"])
    assert result.exit_code == 0, result.output + result.stderr
    comparison = pd.read_csv(out / "method_comparison.csv")
    assert set(comparison["reference"]) == {"dap-avg-logistic-c1"}
    assert {"dap-avg-logistic-c1", "dap-max-logistic-c1", "dap-avg", "eszsl"} <= set(comparison["method"])
    own = comparison.set_index("method").loc["dap-avg-logistic-c1"]
    assert pd.isna(own["difference"]) and "attribute detector logistic-c1" in own["note"]
    assert comparison.set_index("method")["difference"].drop("dap-avg-logistic-c1").notna().all()
    fusion = pd.read_csv(out / "dap_fusion_prior.csv")
    assert set(fusion["reference"]) == {"dap-avg-logistic-c1"}


def test_the_paper_presets_generic_part_keeps_the_rbf_svm_beside_the_chosen_family():
    """fabric-evidence / hand-evidence compare dap-avg-logistic-c1 in their generic part, whose own DAP
    stays the RBF-SVM; listing the run's files builds that part with the preset's [svm] too (it failed
    with the generic study's default detector, whose DAP is dap-avg-logistic-c1 itself)."""
    from tzsl.studies.zero_shot.preset import generic_experiment, preset_outputs

    for name in ("fabric-evidence", "hand-evidence"):
        exp = load_experiment(name)
        assert generic_experiment(exp).config.svm.detector == "rbf-svm"
        assert {s["name"] for s in generic_experiment(exp).config.methods.compare} >= {"dap-avg-logistic-c1"}
        assert preset_outputs(exp.config, [])
