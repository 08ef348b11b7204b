"""A comparison shows the DAP detectors it was asked for, not all of them (issue 43, item 3).

``[methods] compare`` names DAP as ``dap`` with parameters or by an older name (an alias); a row is
labelled by its configuration (:func:`tzsl.studies.config.method_label`: ``dap-avg-logistic``); the
study's own DAP takes the detector of the first DAP entry when ``[svm]`` gives none, so a two-method
study (``["dap-avg", "eszsl"]``) shows no DAP of a detector nobody named. The dataset of the runs is
SIMULATED: it exercises the labels and the wiring, it measures nothing.
"""

from __future__ import annotations

import pandas as pd
import pytest
from click.testing import CliRunner

from tests.studies.test_zero_shot_study import simulated_dataset
from tzsl.cli import cli
from tzsl.exceptions import TzslError
from tzsl.models import DAP_METHOD
from tzsl.models.detectors import STUDY_DETECTOR
from tzsl.studies.config import ZeroShotSettings, load_experiment, method_label, registered_method

#: A small, fast study on the simulated dataset; the test adds ``[methods] compare`` and ``[svm]`` keys.
FAST = ('gzsl = false\nsweep = false\n[splits]\nkinds = ["random"]\nn_splits = 2\nn_test = 3\n'
        '[svm]\ncv = 2\nn_C = 1\nn_gamma = 1\nn_draws = 1\n')


def _file(tmp_path, compare: str, svm: str = "", name: str = "exp") -> tuple:
    """An experiment file on a SIMULATED plain dataset, and its output folder."""
    data = tmp_path / "data"
    if not data.exists():
        simulated_dataset(data, 10, 4, 2, seed=1)
    out = tmp_path / f"out_{name}"
    path = tmp_path / f"{name}.toml"
    path.write_text(f'study = "zero-shot"\n[dataset]\nplain = "{data}"\n[methods]\ncompare = {compare}\n'
                    + FAST + svm + f'[output]\nfolder = "{out}"\n')
    return path, out


def _rows(out) -> pd.DataFrame:
    return pd.read_csv(out / "method_comparison.csv").set_index("method")


def test_labels_name_a_dap_entry_by_its_configuration():
    assert method_label({"name": "dap"}) == "dap-avg"
    assert method_label({"name": "dap", "detector": "logistic"}) == "dap-avg-logistic"
    assert method_label({"name": "dap", "detector": "logistic-c1", "fusion": "avg"}) == "dap-avg-logistic-c1"
    assert method_label({"name": "dap-avg-logistic-c1"}) == "dap-avg-logistic-c1"  # the paper CSVs' row label
    assert method_label({"name": "dap-max", "detector": "auto"}) == "dap-max-auto"
    assert method_label({"name": "dap", "prior": "train", "solver": "exact"}) == "dap-avg-train-prior_solver_exact"
    assert method_label({"name": "dap-avg", "solver": "exact"}) == "dap-avg_solver_exact"
    assert method_label({"name": "embedding", "lam": 0.1}) == "embedding_lam_0.1"
    assert registered_method("dap-max-logistic-c1") == registered_method("dap-avg_solver_exact") == DAP_METHOD
    assert registered_method("embedding_lam_0.1") == "embedding"


def test_the_default_comparison_has_one_dap_not_one_per_detector():
    compared = [method_label(spec) for spec in ZeroShotSettings().methods.method_specs()]
    dap_rows = [label for label in compared if registered_method(label) == DAP_METHOD]
    assert dap_rows == (["dap-avg"] if STUDY_DETECTOR != "rbf-svm" else [])  # the paper's DAP beside the study's
    paper = ZeroShotSettings(svm={"detector": "rbf-svm"}).methods.method_specs()
    assert not [spec for spec in paper if registered_method(method_label(spec)) == DAP_METHOD]


def test_the_first_dap_entry_gives_the_study_its_detector(tmp_path):
    def config(compare: str, svm: str = ""):
        return load_experiment(_file(tmp_path, compare, svm)[0]).config

    asked = config('[{name = "dap", detector = "logistic"}, "eszsl"]')
    assert asked.svm.detector == "logistic" and asked.methods.compare == [{"name": "eszsl"}]
    assert config('["eszsl", "dap-avg", "dap-avg-logistic"]').svm.detector == "rbf-svm"
    assert config('["eszsl", "sae"]').svm.detector == STUDY_DETECTOR  # no DAP named: the default
    pinned = config('["dap-avg", "eszsl"]', svm='detector = "logistic-c1"\n')  # [svm] says: kept
    assert pinned.svm.detector == "logistic-c1" and pinned.methods.compare == [{"name": "dap-avg"}, {"name": "eszsl"}]


def test_an_unknown_detector_value_is_one_line_naming_the_key(tmp_path):
    path, _ = _file(tmp_path, '["eszsl", {name = "dap", detector = "svm"}]')
    with pytest.raises(TzslError) as caught:
        load_experiment(path)
    assert str(caught.value).count("\n") == 0
    assert str(caught.value).endswith("methods.compare[1].detector: method 'dap': detector = 'svm' is not one of "
                                      "auto, linear-svm, logistic, logistic-c1, rbf-svm, robust-logistic")
    result = CliRunner().invoke(cli, ["run", str(path), "--check"])
    assert result.exit_code != 0 and "compare[1].detector" in result.output + result.stderr


@pytest.mark.slow
def test_a_two_method_study_shows_the_dap_asked_for_and_aliases_still_run(tmp_path):
    """``["dap-avg", "eszsl"]``: the DAP rows are the RBF-SVM DAP's (its two fusions, one fit), none of the
    generic study's default detector. With ``[svm] detector = "rbf-svm"``, an old name
    (``dap-avg-logistic-c1``) and ``{name = "dap", detector = "logistic"}`` are fitted beside it, each
    labelled by its configuration."""
    two, out_two = _file(tmp_path, '["dap-avg", "eszsl"]', name="two")
    more, out_more = _file(tmp_path, '["dap-avg-logistic-c1", {name = "dap", detector = "logistic"}, "eszsl"]',
                           svm='detector = "rbf-svm"\n', name="more")
    for path in (two, more):
        result = CliRunner().invoke(cli, ["run", str(path), "--no-progress"])
        assert result.exit_code == 0, result.output + result.stderr
    rows = _rows(out_two)
    assert list(rows.index) == ["dap-avg", "dap-max", "eszsl"] and set(rows["reference"]) == {"dap-avg"}
    rows = _rows(out_more)
    assert list(rows.index) == ["dap-avg", "dap-max", "dap-avg-logistic-c1", "dap-avg-logistic", "eszsl"]
    assert rows.loc[["dap-avg-logistic-c1", "dap-avg-logistic"], "accuracy"].notna().all()
    assert rows.loc[["dap-avg-logistic-c1", "dap-avg-logistic"], "difference"].notna().all()


def test_the_stacked_comparison_counts_every_dap_row_as_a_run_of_dap():
    """``tzsl evidence``'s stacked table: a study whose DAP rows are ``dap-avg-logistic-c1`` and
    ``dap-max-logistic-c1`` ran ``dap``; a study without DAP gets one ``dap`` row saying why, not one per
    detector name."""
    from tzsl.models import available_methods
    from tzsl.studies.comparison.method_runs import combine_comparisons

    def table(study, methods, reference):
        return pd.DataFrame({"study": study, "data": "real", "split_kind": "random", "method": methods,
                             "reference": reference, "accuracy": 0.5})

    combined = combine_comparisons([table("zero-shot", ["dap-avg-logistic-c1", "dap-max-logistic-c1", "eszsl"],
                                          "dap-avg-logistic-c1"),
                                    table("fabric", ["embedding_lam_0.1", "eszsl"], "embedding_lam_0.1")],
                                   {"fabric": {DAP_METHOD: "too few classes"}})
    generic = combined[combined["study"] == "zero-shot"]
    assert DAP_METHOD not in set(generic["method"]) and generic["method"].is_unique
    fabric = combined[combined["study"] == "fabric"].set_index("method")
    assert fabric.loc[DAP_METHOD, "note"] == "too few classes" and "dap-avg" not in fabric.index
    assert set(combined["method"]) <= set(available_methods()) | {"dap-avg-logistic-c1", "dap-max-logistic-c1",
                                                                   "embedding_lam_0.1"}
