"""Generalised zero-shot evaluation: hold-out, classes as attribute rows, calibrated stacking, no test leak."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from pydantic import ValidationError

from tests.study_settings import study_settings
from tzsl.datasets import FeatureSet
from tzsl.evaluation import Split, gzsl_scores
from tzsl.exceptions import ConfigError, SplitError
from tzsl.studies.config import ZeroShotSettings
from tzsl.studies.zero_shot.gzsl import (
    _pseudo_problem,
    choose_stacking_constant,
    gzsl_problem,
    gzsl_split,
    holdout_trials,
    run_gzsl,
    stacked_predict,
)
from tzsl.studies.zero_shot.study import make_splits

TINY_SVM = {"n_C": 1, "n_gamma": 1, "n_draws": 1, "cv": 3}


def synthetic_features(n_objects: int = 24, n_attributes: int = 6, trials: int = 5, seed: int = 0) -> FeatureSet:
    """Objects whose 2-sensor features encode their attribute rows; objects 0 and 1 share a row."""
    rng = np.random.default_rng(seed)
    bits = 1 << np.arange(n_attributes)
    special = set(bits) | {(1 << n_attributes) - 1 - b for b in bits}
    rest = rng.permutation([c for c in range(1 << n_attributes) if c not in special])
    codes = np.concatenate([bits, (1 << n_attributes) - 1 - bits, rest])[:n_objects]
    A = (codes[:, None] & bits[None, :] > 0).astype(int)  # distinct rows, every attribute +/-
    A[2 * n_attributes] = A[0]  # one duplicate attribute row
    names = [f"obj_{i:03d}" for i in range(n_objects)]
    W = rng.normal(size=(2, n_attributes, 5))
    X = np.repeat(np.einsum("om,smd->osd", A.astype(float), W), trials, axis=0)
    X += 0.3 * rng.normal(size=X.shape)
    table = pd.DataFrame({
        "trial_id": [f"{o}_{t + 1:02d}" for o in names for t in range(trials)],
        "object_id": np.repeat(np.arange(n_objects), trials),
        "object_name": np.repeat(names, trials),
        "trial_index": np.tile(np.arange(1, trials + 1), n_objects),
    })
    attrs = pd.DataFrame(A, index=pd.Index(names, name="object_name"), columns=[f"a{j}" for j in range(n_attributes)])
    return FeatureSet(X=X, trials=table, sensors=("s0", "s1"), feature_names=tuple(f"f{i}" for i in range(5)),
                      attributes=attrs, dataset="synthetic")


def _config(**kw) -> ZeroShotSettings:
    """Study settings for the GZSL tests (``[gzsl]`` keys as ``**{"gzsl.key": value}``)."""
    return study_settings(ZeroShotSettings, "phac2-dap", **{"n_splits": 2, "n_test": 5, "progress": False,
                                                            "cache": False, "svm_params": dict(TINY_SVM),
                                                            "multilabel": False, **kw})


def _split(features: FeatureSet, test: list[str]) -> Split:
    objects = list(features.attributes.index)
    return Split(name="random-1", train_objects=tuple(o for o in objects if o not in test), test_objects=tuple(test),
                 attributes=tuple(features.attributes.columns))


def test_holdout_takes_the_fraction_of_every_listed_object_only():
    objects = np.repeat(["a", "b", "c"], [10, 4, 10])
    mask = holdout_trials(objects, ["a", "b"], 0.3, np.random.default_rng(0))
    counts = pd.Series(mask).groupby(objects).sum()
    assert counts.to_dict() == {"a": 3, "b": 1, "c": 0}
    again = holdout_trials(objects, ["a", "b"], 0.3, np.random.default_rng(0))
    other = holdout_trials(objects, ["a", "b"], 0.3, np.random.default_rng(1))
    np.testing.assert_array_equal(mask, again)
    assert not np.array_equal(mask, other)
    # never every trial of an object, never none of an object with 2 or more; an object of 1 trial is kept whole
    assert holdout_trials(np.repeat(["a"], 2), ["a"], 0.99, np.random.default_rng(0)).sum() == 1
    single = holdout_trials(np.array(["a", "b", "b", "b"]), ["a", "b"], 0.3, np.random.default_rng(0))
    assert not single[0] and single[1:].sum() == 1


def test_classes_are_unique_attribute_rows_and_shared_rows_are_seen():
    features = synthetic_features()
    # obj_012 repeats obj_000's row: as a test object it belongs to a seen class
    split = _split(features, ["obj_012", "obj_003", "obj_020"])
    problem = gzsl_problem(features, split, 0.4, np.random.default_rng(0))
    n_rows = len(np.unique(features.attributes.to_numpy(), axis=0))
    assert len(problem.class_rows) == n_rows == features.n_objects - 1
    assert problem.info["n_test_objects_in_seen_classes"] == 1
    same = problem.trial_class[features.objects == "obj_012"]
    assert (same == problem.trial_class[features.objects == "obj_000"][0]).all()
    assert problem.seen[same[0]]
    assert (~problem.seen).sum() == 2
    # fitted trials: training objects only, never held-out ones
    assert not (problem.fit & problem.heldout).any() and not (problem.fit & problem.test).any()
    assert set(features.objects[problem.fit]) == set(split.train_objects)
    assert problem.heldout.sum() == 2 * len(split.train_objects)  # 0.4 * 5 trials


def test_split_without_unseen_class_is_refused():
    features = synthetic_features()
    with pytest.raises(SplitError, match="no unseen class"):
        gzsl_problem(features, _split(features, ["obj_012"]), 0.3, np.random.default_rng(0))


def test_pseudo_problem_stays_inside_training_objects():
    features = synthetic_features()
    split = _split(features, ["obj_003", "obj_020", "obj_021"])
    problem = gzsl_problem(features, split, 0.4, np.random.default_rng(0))
    pseudo, note = _pseudo_problem(features, problem, 2, 100, np.random.default_rng(0))
    assert note == ""  # the asked draw was possible: nothing relaxed
    used = set(features.objects[pseudo.fit | pseudo.evaluate])
    assert used <= set(split.train_objects)
    assert (~pseudo.seen).sum() == (~problem.seen).sum()
    assert not (pseudo.fit & problem.heldout).any()


def test_stacking_constant_maximises_harmonic_mean():
    rng = np.random.default_rng(3)
    n_classes, seen = 8, np.array([True] * 5 + [False] * 3)
    y = rng.integers(0, n_classes, size=300)
    scores = rng.normal(size=(300, n_classes))
    scores[np.arange(300), y] += 2.0
    scores[:, seen] += 1.5  # a bias towards seen classes
    gamma = choose_stacking_constant(scores, y, seen)

    def h(g):
        return gzsl_scores(y, stacked_predict(scores, seen, g), np.flatnonzero(seen), np.flatnonzero(~seen))["harmonic"]

    grid = np.linspace(-5, 5, 81)
    assert h(gamma) >= max(h(g) for g in grid) - 1e-12
    assert h(gamma) > h(0.0)
    assert gamma > 0


def test_stacked_predict_moves_predictions_to_unseen_classes():
    scores = np.array([[2.0, 1.0], [0.5, 1.0]])
    seen = np.array([True, False])
    np.testing.assert_array_equal(stacked_predict(scores, seen, 0.0), [0, 1])
    np.testing.assert_array_equal(stacked_predict(scores, seen, 1.5), [1, 1])


@pytest.mark.slow
def test_run_gzsl_table_layout_and_scores():
    features = synthetic_features()
    config = _config()
    splits, _ = make_splits(features, "random", config)
    table = run_gzsl(features, splits, config)
    per_split = table[~table["split"].isin(["mean", "std"])]
    assert len(per_split) == 2 * 2 * 2  # splits x methods x calibrated
    assert set(per_split["method"]) == {"dap-avg", "eszsl"}
    for col in ("seen", "unseen", "harmonic", "zsl"):
        assert per_split[col].between(0, 1).all()
    s, u = per_split["seen"], per_split["unseen"]
    np.testing.assert_allclose(per_split["harmonic"], np.where(s + u > 0, 2 * s * u / (s + u).where(s + u > 0, 1), 0))
    assert (per_split.loc[~per_split["calibrated"], "stacking_constant"] == 0).all()
    mean = table[table["split"] == "mean"].set_index(["method", "calibrated"])
    expected = per_split.groupby(["method", "calibrated"])["harmonic"].mean()
    np.testing.assert_allclose(mean["harmonic"].sort_index(), expected.sort_index())
    # a learnable synthetic problem: DAP recognises seen classes far above chance
    assert per_split.loc[per_split["method"] == "dap-avg", "seen"].mean() > 0.3
    # intervals beside every accuracy, on per-split and mean rows; the chances of the two protocols
    with_iv = table[table["split"] != "std"]
    for col in ("seen", "unseen", "zsl"):
        assert (with_iv[f"{col}_ci95_low"] <= with_iv[col] + 1e-9).all()
        assert (with_iv[col] <= with_iv[f"{col}_ci95_high"] + 1e-9).all()
    np.testing.assert_allclose(per_split["chance"], 1 / per_split["n_classes"])
    np.testing.assert_allclose(per_split["zsl_chance"], 1 / per_split["n_unseen_classes"])


def test_any_registered_feature_method_can_be_scored():
    """[gzsl] methods takes the registry's feature methods beside "dap", each a row; others are refused by name."""
    features = synthetic_features()
    config = _config(**{"gzsl.methods": ["dap", "sae"], "gzsl.calibrated_stacking": False})
    splits, _ = make_splits(features, "random", config)
    table = run_gzsl(features, splits[:1], config)
    per_split = table[~table["split"].isin(["mean", "std"])]
    assert set(per_split["method"]) == {"dap-avg", "sae"}
    assert per_split["harmonic"].between(0, 1).all()
    for bad, why in ((["dap", "hand-dap"], "takes grasps"), (["no-such-method"], "unknown method")):
        with pytest.raises(ValidationError, match=why):
            _config(**{"gzsl.methods": bad})


def test_stacking_constant_never_depends_on_test_objects():
    features = synthetic_features()
    config = _config()
    split = _split(features, ["obj_003", "obj_020", "obj_021", "obj_015"])
    assert config.gzsl.methods == ["dap", "eszsl"]
    rows = gzsl_split(features, split, config, 0)
    changed = synthetic_features()
    test = np.isin(changed.objects, split.test_objects)
    changed.X[test] = np.random.default_rng(9).normal(size=changed.X[test].shape) * 5
    rows2 = gzsl_split(changed, split, config, 0)
    for a, b in zip(rows, rows2, strict=True):
        assert a["stacking_constant"] == b["stacking_constant"]
        assert a["seen"] == pytest.approx(b["seen"]) or a["calibrated"]  # seen trials unchanged when uncalibrated
    assert [r["unseen"] for r in rows] != [r["unseen"] for r in rows2]


def test_bad_settings_are_refused():
    """The schema refuses impossible [gzsl] settings before any fit; no split at all is a ConfigError."""
    for key, bad in (("holdout_fraction", 1.0), ("methods", ["svm"]), ("fusion", "min"), ("prior", "flat"),
                     ("max_draws", 0)):
        with pytest.raises(ValidationError, match=key):
            _config(**{f"gzsl.{key}": bad})
    with pytest.raises(ConfigError, match="at least one split"):
        run_gzsl(synthetic_features(), [], _config())


def test_a_failing_split_is_recorded_and_the_other_splits_complete():
    from tzsl.studies.outputs.failures import table_failures

    features = synthetic_features()
    config = _config()
    good = make_splits(features, "random", config)[0][0]
    bad = Split(name="random-9", train_objects=good.train_objects, test_objects=("no_such_object", "obj_003"),
                attributes=good.attributes)
    table = run_gzsl(features, [bad, good], _config(**{"gzsl.calibrated_stacking": False}))
    per_split = table[~table["split"].isin(["mean", "std"])]
    failed = per_split[per_split["error"].fillna("") != ""]
    assert set(failed["method"]) == {"dap-avg", "eszsl"} and failed["harmonic"].isna().all()
    assert failed["error"].str.startswith("SplitError: ").all() and failed["error"].str.contains("without trials").all()
    done = per_split[per_split["error"].fillna("") == ""]
    assert len(done) == 2 and done["harmonic"].between(0, 1).all()
    lines = table_failures({"gzsl": table})
    assert len(lines) == 2 and all(line.startswith("gzsl: split=") and "SplitError" in line for line in lines)


def test_a_split_without_an_unseen_class_is_left_out_with_a_note():
    """Merged attribute rows can leave a split no unseen class: a note, not a failure (issue 20)."""
    from tzsl.studies.outputs.failures import table_failures
    from tzsl.studies.zero_shot.gzsl import RELAXED_COLUMN

    features = synthetic_features()
    config = _config()
    good = make_splits(features, "random", config)[0][0]
    bad = _split(features, ["obj_012"])  # its row is a training object's: no unseen class
    table = run_gzsl(features, [bad, good], _config(**{"gzsl.calibrated_stacking": False}))
    assert table_failures({"gzsl": table}) == []
    left_out = table[table[RELAXED_COLUMN].fillna("").str.contains("no unseen class")]
    assert set(left_out["split"]) == {"1"} and left_out["harmonic"].isna().all()
    # every split left out (fabric-depth: each test fabric's group row is a training fabric's): a table of notes
    only = run_gzsl(features, [bad], _config(**{"gzsl.calibrated_stacking": False}))
    assert table_failures({"gzsl": only}) == [] and only["harmonic"].isna().all()
    assert only[RELAXED_COLUMN].fillna("").str.contains("no unseen class").any()


def test_training_objects_with_one_trial_are_kept_whole_with_a_note():
    """One trial per object, as a lab may record (issue 31): GZSL holds out seen-class trials of the
    objects that have two; with none, the split is left out with a note, not a failed fit."""
    from tzsl.studies.outputs.failures import table_failures
    from tzsl.studies.zero_shot.gzsl import RELAXED_COLUMN

    features = synthetic_features(trials=2)
    split = make_splits(features, "random", _config())[0][0]
    first = features.trials.groupby("object_name").head(1).index.to_numpy()
    singles = list(split.train_objects[:4])
    keep = np.ones(len(features.objects), dtype=bool)
    keep[[i for i in first if features.objects[i] in singles]] = False
    some_single = features.subset(keep)
    table = run_gzsl(some_single, [split], _config(**{"gzsl.calibrated_stacking": False}))
    assert table_failures({"gzsl": table}) == [] and table["harmonic"].notna().any()
    assert table[RELAXED_COLUMN].fillna("").str.contains("single trial are kept whole").any()
    all_single = features.subset(np.isin(np.arange(len(features.objects)), first))
    table = run_gzsl(all_single, [split], _config(**{"gzsl.calibrated_stacking": False}))
    assert table_failures({"gzsl": table}) == [] and table["harmonic"].isna().all()
    assert table[RELAXED_COLUMN].fillna("").str.contains("no training object has 2 trials").any()


def test_pseudo_problem_relaxes_then_skips_with_a_note():
    """Too few training classes for the asked pseudo-unseen draw: fewer classes, then none (issue 20)."""
    features = synthetic_features()
    objects = list(features.attributes.index)
    split = _split(features, objects[:4])  # 4 unseen classes asked of the training objects
    problem = gzsl_problem(features, split, 0.4, np.random.default_rng(0))
    rows = features.attributes.loc[list(split.train_objects)].drop_duplicates()
    pseudo, note = _pseudo_problem(features, problem, len(rows), 10, np.random.default_rng(0))
    assert pseudo is None and "calibrated stacking skipped" in note and split.name in note


def test_relaxation_notes_say_each_reason_once_with_its_splits():
    """A 9-class run printed the same GZSL relaxation once per split and once more inside a joined cell."""
    from tzsl.studies.zero_shot.gzsl import relaxation_notes

    cells = pd.Series(["split random-3: stacking of dap skipped: E: absent in 1 object(s); need 2",
                       "split random-3: stacking of dap skipped: E: absent in 1 object(s); need 2; "
                       "split random-3: stacking of eszsl skipped: Z", None, "-",
                       "split random-4: stacking of dap skipped: E: absent in 1 object(s); need 2"])
    assert relaxation_notes(cells) == [
        "splits random-3, random-4: stacking of dap skipped: E: absent in 1 object(s); need 2",
        "split random-3: stacking of eszsl skipped: Z"]
    # a reason ending "; split left out" is not a split of its own (it printed an empty 'note: relaxed gzsl')
    left_out = "split random-2: every test object shares its attribute row with a training object; split left out"
    assert relaxation_notes(pd.Series([left_out, left_out.replace("random-2", "random-5")])) == [
        "splits random-2, random-5: every test object shares its attribute row with a training object; split left out"]
