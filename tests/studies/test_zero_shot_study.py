"""The generic zero-shot study (issue 20): any dataset, every method, no paper number in sight.

Datasets here are SIMULATED (attribute rows drawn at random, features a noisy linear image of
the rows): they exercise the study, they measure nothing.
"""

from __future__ import annotations

import json
import os
import re
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from tzsl.cli import cli
from tzsl.datasets import write_plain_dataset
from tzsl.studies.config import load_experiment
from tzsl.studies.papers.run_labels import paper_protocol

REPO = Path(__file__).resolve().parents[2]
TEMPLATE = REPO / "experiments" / "my_dataset_template.toml"


#: Pathologies of real recordings a drawn dataset may have (see :func:`simulated_dataset`).
PATHOLOGIES = ("none", "constant-channel", "huge-scale", "tiny-scale", "separable")


def simulated_dataset(folder: Path, n_classes: int, n_attributes: int, n_sensors: int, *, seed: int,
                      positive_rate: float = 0.4, trials_per_class: int = 3, n_features: int = 3,
                      pathology: str = "none") -> Path:
    """A SIMULATED plain dataset; classes may share attribute rows (allowed in its dataset.toml).

    ``pathology`` (one of :data:`PATHOLOGIES`): a constant first feature, every feature times 1e6 or
    1e-6, or noise-free features (each attribute perfectly separable: posteriors of exactly 0 and 1).
    """
    rng = np.random.default_rng(seed)
    K = (rng.random((n_classes, n_attributes)) < positive_rate).astype(int)
    W = rng.normal(size=(n_sensors, n_attributes, n_features))
    cls = np.repeat(np.arange(n_classes), trials_per_class)
    noise = 0.0 if pathology == "separable" else 0.5
    X = np.einsum("na,saf->nsf", K[cls], W) + noise * rng.normal(size=(len(cls), n_sensors, n_features))
    X = X * {"huge-scale": 1e6, "tiny-scale": 1e-6}.get(pathology, 1.0)
    if pathology == "constant-channel":
        X[:, :, 0] = 5.0
    names = np.array([f"c{c:03d}" for c in range(n_classes)], dtype=object)
    classes = pd.DataFrame(K, index=pd.Index(names, name="class"), columns=[f"a{j:02d}" for j in range(n_attributes)])
    trials = pd.DataFrame({"trial_id": [f"t{i}" for i in range(len(cls))], "class": names[cls]})
    return write_plain_dataset(folder, classes, trials, sensors=[f"s{k}" for k in range(n_sensors)], X=X,
                               feature_names=[f"f{i}" for i in range(n_features)],
                               settings={"name": "sim-SIMULATED", "classes": {"allow_identical_rows": True}})


def template_for(folder: Path, dataset: Path, out: Path) -> Path:
    """The shipped template with its two paths changed, nothing else."""
    text = TEMPLATE.read_text().replace('plain = "my_dataset"', f'plain = "{dataset}"')
    text = text.replace('folder = "results/my_dataset"', f'folder = "{out}"')
    path = folder / "my_experiment.toml"
    path.write_text(text)
    return path


#: Largest tables the default property test draws (CI budget; see the test's docstring).
MAX_CLASSES = 24
MAX_ATTRIBUTES = 10
#: The issue's full range, drawn by the wide variant (opt-in: ``TZSL_WIDE_PROPERTY_TEST=1``).
FULL_MAX_CLASSES = 100
FULL_MAX_ATTRIBUTES = 40
WIDE_ENV = "TZSL_WIDE_PROPERTY_TEST"


def _run(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


def test_template_is_the_generic_study_with_every_feature_method():
    exp = load_experiment(TEMPLATE)
    assert exp.study == "zero-shot" and paper_protocol(exp.study, exp.config) == (False, "")
    assert set(exp.config.splits.kinds) == {"random", "challenging"} and exp.config.methods.gzsl
    from tzsl.models import DAP_METHOD, available_methods, get_method
    from tzsl.models.attribute_training import STUDY_DETECTOR
    from tzsl.studies.config import method_label, registered_method

    compared = [method_label(spec) for spec in exp.config.methods.method_specs()]
    expected = {m for m in available_methods() if get_method(m).input_kind == "features"} - {DAP_METHOD,
                                                                                              "multilabel-dap"}
    # the study's own DAP rows come from its DAP fits, of the generic study's detector family; the paper's
    # RBF-SVM DAP is compared beside it when that family is another one, and no other detector (issue 43)
    assert exp.config.svm.detector == STUDY_DETECTOR
    dap_rows = [label for label in compared if registered_method(label) == DAP_METHOD]
    assert dap_rows == (["dap-avg"] if STUDY_DETECTOR != "rbf-svm" else [])
    assert set(compared) - set(dap_rows) == expected


@settings(max_examples=3, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(n_classes=st.integers(8, MAX_CLASSES), n_attributes=st.integers(3, MAX_ATTRIBUTES), n_sensors=st.integers(1, 3),
       merged=st.integers(0, 3), seed=st.integers(0, 2**16), trials=st.integers(1, 3),
       pathology=st.sampled_from(PATHOLOGIES))
@example(n_classes=9, n_attributes=4, n_sensors=2, merged=1, seed=3, trials=1, pathology="separable")
def test_the_template_runs_any_small_dataset_to_the_end(tmp_path_factory, n_classes, n_attributes, n_sensors,
                                                         merged, seed, trials, pathology):
    """Issue 20: the template, paths changed only, exits 0 on a dataset of >= 8 classes and >= 3
    attributes (merged rows allowed), relaxing what it cannot honour; or, where no sound split
    exists, it fails with one line naming the file.

    The drawn sizes stop at :data:`MAX_CLASSES` classes and :data:`MAX_ATTRIBUTES` attributes: the
    template's full study (every method, attribute SVMs per attribute and sensor, GZSL) takes
    minutes per run on larger tables, more than the CI budget allows for three examples. Datasets may
    have one trial per class and a pathology of real recordings (:data:`PATHOLOGIES`).
    """
    _check_template_run(tmp_path_factory, n_classes, n_attributes, n_sensors, merged, seed, trials, pathology)


@pytest.mark.slow
@pytest.mark.skipif(not os.environ.get(WIDE_ENV), reason=f"minutes per example; set {WIDE_ENV}=1")
@settings(max_examples=2, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(n_classes=st.integers(8, FULL_MAX_CLASSES), n_attributes=st.integers(3, FULL_MAX_ATTRIBUTES),
       n_sensors=st.integers(1, 3), merged=st.integers(0, 3), seed=st.integers(0, 2**16), trials=st.integers(1, 3),
       pathology=st.sampled_from(PATHOLOGIES))
@example(n_classes=FULL_MAX_CLASSES, n_attributes=FULL_MAX_ATTRIBUTES, n_sensors=3, merged=3, seed=1, trials=3,
         pathology="none")
def test_the_template_runs_datasets_of_the_full_range(tmp_path_factory, n_classes, n_attributes, n_sensors,
                                                      merged, seed, trials, pathology):
    """The issue's full range (8-100 classes, 3-40 attributes, 1-3 sensors, merged rows), the top
    corner always: the same checks as the default test. One run at 100 x 40 x 3 takes many minutes
    on two cores, so this variant is opt-in (``TZSL_WIDE_PROPERTY_TEST=1``)."""
    _check_template_run(tmp_path_factory, n_classes, n_attributes, n_sensors, merged, seed, trials, pathology)


def _check_template_run(tmp_path_factory, n_classes: int, n_attributes: int, n_sensors: int, merged: int,
                        seed: int, trials: int = 3, pathology: str = "none") -> None:
    """Run the template (paths changed only) on a simulated dataset and check the outcome."""
    root = tmp_path_factory.mktemp("sim")
    dataset = simulated_dataset(root / "data", n_classes, n_attributes, n_sensors, seed=seed,
                                trials_per_class=trials, pathology=pathology)
    classes = pd.read_csv(dataset / "classes.csv", index_col=0)
    classes.iloc[:merged] = classes.iloc[merged:2 * merged].to_numpy()  # merged rows
    classes.to_csv(dataset / "classes.csv")
    path = template_for(root, dataset, root / "out")
    result = _run("run", path, "--n-jobs", 2, "--no-progress")
    if result.exit_code == 3:  # nothing sound: one line, naming the file
        lines = result.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith(f"tzsl: error: {path}: splits: ") and "sound" in lines[0]
        return
    assert result.exit_code == 0, result.output + result.stderr
    assert "Traceback" not in result.output
    out = root / "out"
    comparison = pd.read_csv(out / "method_comparison.csv")
    assert set(comparison["data"]) == {"sim-SIMULATED"} and set(comparison["study"]) == {"zero-shot"}
    # the default purpose of a reported study: confirmation splits, in the manifest and both method tables
    assert set(comparison["purpose"]) == {"confirm"}
    assert set(pd.read_csv(out / "methods_per_split.csv")["purpose"]) == {"confirm"}
    for table in out.glob("*.csv"):
        assert not [c for c in pd.read_csv(table, nrows=0).columns if c.startswith("paper")], table.name
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["config"]["purpose"] == "confirm" == manifest["config"]["study_settings"]["splits"]["purpose"]
    noted = [line for line in result.output.splitlines() if line.startswith("note: relaxed ")]
    assert len(noted) == len(manifest["config"]["relaxations"])
    # warnings: one line per kind, no source path, each one in the manifest; repeats counted in one closing line
    stderr = result.stderr.splitlines()
    assert not [line for line in stderr if ".py:" in line or not line.startswith("tzsl: ")], result.stderr
    shown = [line[len("tzsl: warning: "):] for line in stderr if line.startswith("tzsl: warning: ")]
    recorded = {re.sub(r" \(x\d+\)$", "", line) for line in manifest["warnings"]}
    closing = [line for line in shown if " more warnings of the kinds above " in line]
    assert set(shown) - set(closing) <= recorded and len(closing) <= 1
    from tzsl._warnings import warning_kind

    kinds = {warning_kind(line.split(" (")[0], UserWarning) for line in recorded}
    assert len(shown) <= len(recorded) and len(shown) - len(closing) <= max(len(kinds), 1) + 3, shown


def test_paper_preset_on_another_dataset_says_what_it_maps_to(tmp_path):
    dataset = simulated_dataset(tmp_path / "data", 20, 8, 2, seed=3)
    path = tmp_path / "old.toml"
    path.write_text(f'study = "phac2-dap"\n[dataset]\nplain = "{dataset}"\n[splits]\nn_splits = 2\nn_test = 5\n'
                    f'[svm]\ncv = 3\nn_C = 1\nn_gamma = 1\nn_draws = 1\n[compute]\nprogress = false\n'
                    f'[output]\nfolder = "{tmp_path / "out"}"\n')
    result = _run("run", path)
    assert result.exit_code == 0, result.output
    said = result.output.replace("\n    ", " ")  # a note is wrapped at 100 characters, its other lines indented
    notes = [line for line in said.splitlines() if line.startswith("note: study 'phac2-dap'")]
    assert len(notes) == 1 and "preset of study 'zero-shot'" in notes[0] and "plain folder" in notes[0]
    t1 = pd.read_csv(tmp_path / "out" / "table1_fusion.csv")
    assert not [c for c in t1.columns if c.startswith("paper")]


@pytest.mark.parametrize(("changes", "paper"), [
    ({}, True),
    ({"splits": {"n_test": 5}}, False),
    ({"dataset": {"builtin": "phac2-penn", "min_objects": 15}}, False),
    ({"dataset": {"builtin": "phac2-hold-mat"}}, False),
])
def test_paper_numbers_only_on_the_papers_dataset_and_protocol(changes, paper):
    from tzsl.studies.config import validate

    raw = {"study": "phac2-dap", "dataset": {"builtin": "phac2-penn"}}
    for key, value in changes.items():
        raw[key] = value
    exp = validate(raw, "t.toml", Path("."))
    applies, why = paper_protocol(exp.study, exp.config)
    assert applies is paper and (why == "") is paper
    zero_shot = validate({**raw, "study": "zero-shot"}, "t.toml", Path("."))
    assert paper_protocol(zero_shot.study, zero_shot.config) == (False, "")


def test_identical_rows_everywhere_fail_with_one_line(tmp_path):
    dataset = simulated_dataset(tmp_path / "data", 10, 3, 1, seed=1)
    classes = pd.read_csv(dataset / "classes.csv", index_col=0)
    classes.iloc[:] = [1, 0, 1]
    classes.iloc[0] = [0, 1, 0]  # two distinct rows among 10 classes: no attribute can be trained
    classes.to_csv(dataset / "classes.csv")
    path = template_for(tmp_path, dataset, tmp_path / "out")
    result = _run("run", path, "--check")
    assert result.exit_code == 3
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"tzsl: error: {path}: splits: ")


def test_recorded_warnings_are_one_line_and_counted():
    from tzsl._warnings import one_line, recorded_warnings

    assert one_line(RuntimeWarning("first\nsecond"), RuntimeWarning) == "tzsl: warning: first"
    assert one_line(DeprecationWarning("old"), DeprecationWarning) == "tzsl: warning: old (DeprecationWarning)"
    with warnings.catch_warnings():
        warnings.simplefilter("always")
        warnings.showwarning = lambda *args, **kwargs: None  # the command line's printer, silenced
        with recorded_warnings() as log:
            for _ in range(3):
                warnings.warn("edge of the grid", UserWarning, stacklevel=1)
            warnings.warn("other", RuntimeWarning, stacklevel=1)
    assert log.lines == ["edge of the grid (x3)", "other"]


def test_the_terminal_shows_each_kind_of_warning_once_then_counts_the_repeats():
    from tzsl._warnings import TerminalWarnings, warning_kind
    from tzsl.models import GridEdgeWarning

    printed: list[str] = []
    terminal = TerminalWarnings(printed.append)
    for n in range(20):  # one per attribute bank, each with its own numbers
        terminal.show(GridEdgeWarning(f"{n} hyper-parameter choices sit on a grid edge"), GridEdgeWarning, "x.py", 1)
    for name in ("hard", "soft"):
        terminal.show(UserWarning(f"attribute '{name}' is rare: 2 objects"), UserWarning, "x.py", 1)
    terminal.show(RuntimeWarning("overflow"), RuntimeWarning, "x.py", 1)
    assert printed == ["tzsl: warning: 0 hyper-parameter choices sit on a grid edge (GridEdgeWarning)",
                       "tzsl: warning: attribute 'hard' is rare: 2 objects", "tzsl: warning: overflow"]
    assert terminal.summary() == ("tzsl: warning: 20 more warnings of the kinds above (GridEdgeWarning: 19, "
                                  'UserWarning "attribute … is rare: # objects": 1); a run lists every one in '
                                  "its manifest.json")
    for _ in range(2):  # another kind of the same category is named by its own wording
        terminal.show(UserWarning("the solver did not converge in 100 iterations"), UserWarning, "x.py", 1)
    assert 'UserWarning "the solver did not converge in # iterations": 1' in terminal.summary()
    assert warning_kind("a 'x' 3", UserWarning) == warning_kind("a 'yy' 4.5", UserWarning)
    assert TerminalWarnings(printed.append).summary() is None


def test_the_command_line_prints_warnings_on_one_line(tmp_path, monkeypatch):
    """A warning raised inside a command reaches the user as one line, without a source path."""
    import tzsl.studies.zero_shot.runner as runners

    def warns(*args, **kwargs):
        warnings.warn("something to know\nwith a second line", RuntimeWarning, stacklevel=1)
        raise SystemExit(0)

    monkeypatch.setattr(runners, "prepare", warns)
    dataset = simulated_dataset(tmp_path / "data", 12, 4, 1, seed=2)
    result = _run("run", template_for(tmp_path, dataset, tmp_path / "out"), "--check")
    assert result.stderr.splitlines() == ["tzsl: warning: something to know"]
