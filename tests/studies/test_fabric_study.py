"""The fabric zero-shot study (F18): sample units, zero-shot honesty, table layout, GelSight path."""

from __future__ import annotations

import shutil
import warnings

import numpy as np
import pandas as pd
import pytest
from pydantic import ValidationError

from tests.study_settings import study_settings
from tzsl.datasets import fabric_zsl_split, load_fabric
from tzsl.evaluation import seen_test_classes
from tzsl.exceptions import ConfigError, DataFileError
from tzsl.models import ZSLInputError, build_method
from tzsl.models.protocol import attribute_rows
from tzsl.studies.config import FabricStudy
from tzsl.studies.fabric.study import (
    depth_image_descriptors,
    depth_samples,
    depth_sequence_rows,
    format_fabric_table,
    lambda_label,
    run_fabric_study,
    select_embedding_alpha,
    zero_shot_run,
)
from tzsl.studies.fabric.tables import fabric_protocols
from tzsl.studies.outputs.results_folder import ResultsDir
from tzsl.studies.papers.numbers import FABRIC_TABLE1

A8_LIKE = np.array(  # 8 groups x 4 attributes; groups 3, 4 and 5 share a row, like a8
    [[1, 0, 1, 0], [1, 0, 0, 1], [0, 1, 0, 0], [0, 1, 1, 1], [0, 1, 1, 1], [0, 1, 1, 1], [0, 0, 1, 0],
     [1, 1, 0, 0]],
    dtype=float,
)


def _synthetic(per_group=12, noise=0.3, seed=0):
    rng = np.random.default_rng(seed)
    groups = np.repeat(np.arange(8), per_group)
    mixing = rng.normal(size=(4, 10))
    X = A8_LIKE[groups] @ mixing + noise * rng.normal(size=(groups.size, 10))
    return X, groups


# ------------------------------------------------------------------------------------------
# units and helpers
# ------------------------------------------------------------------------------------------
def test_paper_table1_average_row_is_the_mean_of_its_rows():
    assert set(FABRIC_TABLE1) == {"Flat", "Fold", "Rand", "Average"}
    for col in ("0", "0.1", "1", "10", "inf", "ESZSL"):
        mean = np.mean([FABRIC_TABLE1[r][col] for r in ("Flat", "Fold", "Rand")])
        assert abs(mean - FABRIC_TABLE1["Average"][col]) < 2e-4, col
    assert FABRIC_TABLE1["Fold"]["0"] == 0.8941


def test_protocols_keep_the_paper_split_and_headline_a_zero_shot_variant():
    protocols = fabric_protocols((1, 2), pd.DataFrame(A8_LIKE))
    assert [(p.split.config, p.name, p.zero_shot) for p in protocols] == [
        (1, "paper", False), (1, "zero-shot-drop", True), (2, "paper", False), (2, "zero-shot-drop", True)]
    assert protocols[0].split.test_groups == (0, 5, 7) and "NOT zero-shot" in protocols[0].note
    assert protocols[1].split.test_groups == (0, 7) and protocols[1].split.train_groups == (1, 2, 3, 4, 6)
    for p in protocols:
        seen = seen_test_classes(pd.DataFrame(A8_LIKE), list(p.split.train_groups), list(p.split.test_groups))
        assert bool(seen) != p.zero_shot
    distinct = A8_LIKE.copy()
    distinct[5] = [1, 1, 1, 1]
    assert [p.name for p in fabric_protocols((1,), pd.DataFrame(distinct))] == ["paper"]


def test_lambda_labels():
    assert [lambda_label(v) for v in (0, 0.1, 1, 10, "inf", float("inf"))] == ["0", "0.1", "1", "10", "inf", "inf"]
    with pytest.raises(ConfigError):
        lambda_label(-1)


def test_depth_sequence_rows_are_evenly_spaced_in_capture_order():
    sizes = {3: 8, 1: 11, 2: 5}
    table = pd.DataFrame(
        [(fid, k) for fid, n in sizes.items() for k in range(n)], columns=["fabric_id", "capture_index"]
    ).sample(frac=1.0, random_state=0, ignore_index=True)  # order must not matter
    rows = depth_sequence_rows(table, 5)
    assert rows.shape == (3, 5)
    got = table["capture_index"].to_numpy()[rows]
    np.testing.assert_array_equal(table["fabric_id"].to_numpy()[rows], np.repeat([[1], [2], [3]], 5, axis=1))
    np.testing.assert_array_equal(got[0], [0, 3, 5, 8, 10])  # round(linspace(0, 10, 5))
    np.testing.assert_array_equal(got[1], [0, 1, 2, 3, 4])
    np.testing.assert_array_equal(got[2], [0, 2, 4, 5, 7])  # 0, 1.75, 3.5, 5.25, 7
    with pytest.raises(DataFileError, match=r"fabric\(s\) \[2\] have fewer than 6"):
        depth_sequence_rows(table, 6)


def test_zero_shot_run_fits_on_training_groups_only():
    X, groups = _synthetic()
    split = fabric_zsl_split(1, A8_LIKE)
    seen = {}

    def fit_model(X_tr, y_tr, S_tr):
        seen.update(X=X_tr, y=y_tr, S=S_tr)
        return build_method("embedding", lam=1, early_stopping=False, random_state=0, calibration="none").fit(
            X_tr, attribute_rows(y_tr, S_tr), y_tr
        )

    run = zero_shot_run(fit_model, X, groups, A8_LIKE, split)
    assert np.unique(seen["y"]).tolist() == [1, 2, 3, 4, 6] == run.train_classes.tolist()
    np.testing.assert_array_equal(seen["X"], X[np.isin(groups, [1, 2, 3, 4, 6])])
    np.testing.assert_array_equal(seen["S"], A8_LIKE[[1, 2, 3, 4, 6]])
    assert run.model.attribute_model_.class_attributes_.shape[0] == len(np.unique(A8_LIKE[[1, 2, 3, 4, 6]], axis=0))
    assert set(run.y_true) == {0, 5, 7} and set(run.y_pred) <= {0, 5, 7}
    assert run.y_true.size == 36
    # attributes are linear in the features: recognition of unseen groups is well above chance
    assert run.accuracy > 0.6
    assert 0.0 <= run.per_class_mean_accuracy <= 1.0


def test_splits_with_the_same_training_groups_share_one_fit():
    from tzsl.studies.fabric.methods import zero_shot_runs

    X, groups = _synthetic()
    paper, headline = fabric_protocols([1], pd.DataFrame(A8_LIKE))
    fits = []

    def fit_model(X_tr, y_tr, S_tr):
        fits.append(y_tr)
        return build_method("embedding", lam=1, early_stopping=False, random_state=0, calibration="none").fit(
            X_tr, attribute_rows(y_tr, S_tr), y_tr
        )

    both = zero_shot_runs(fit_model, X, groups, A8_LIKE, [paper.split, headline.split])
    assert len(fits) == 1 and both[0].model is both[1].model  # one fit for the two protocols
    for run, split in zip(both, (paper.split, headline.split), strict=True):  # each scored as if fitted alone
        alone = zero_shot_run(fit_model, X, groups, A8_LIKE, split)
        assert set(run.y_true) == set(split.test_groups)
        np.testing.assert_array_equal(run.y_pred, alone.y_pred)
    with pytest.raises(ConfigError, match="one set of training groups"):
        zero_shot_runs(fit_model, X, groups, A8_LIKE, [fabric_zsl_split(1), fabric_zsl_split(2)])


def test_zero_shot_run_needs_both_sides():
    X, groups = _synthetic()
    keep = np.isin(groups, [1, 2, 3, 4, 6])
    with pytest.raises(ConfigError, match="0 test samples"):
        zero_shot_run(lambda *a: None, X[keep], groups[keep], A8_LIKE, fabric_zsl_split(1))


def test_select_embedding_alpha_uses_held_out_classes():
    X, groups = _synthetic(per_group=8)
    train = np.isin(groups, [1, 2, 3, 4, 6])
    S = A8_LIKE[[1, 2, 3, 4, 6]]
    alpha, scores = select_embedding_alpha(X[train], groups[train], S, lam=0.1, alphas=(1.0, 0.01), random_state=0)
    assert alpha in (1.0, 0.01)
    assert scores.shape == (2, 2)  # 4 distinct rows (3 and 4 merged) -> 2 folds
    assert ((scores >= 0) & (scores <= 1)).all()  # held-out accuracy, the default
    assert alpha == (1.0, 0.01)[int(np.argmax(scores.mean(axis=1)))]  # ties: the first, the strongest
    smooth, losses = select_embedding_alpha(X[train], groups[train], S, lam=0.1, alphas=(1.0, 0.01),
                                            random_state=0, scoring="neg_log_loss")
    assert ((losses >= -np.log(2) - 1e-12) & (losses <= 0)).all()  # minus a log-loss over 2 held-out classes
    mean = losses.mean(axis=1)
    assert smooth == max(a for a, m in zip((1.0, 0.01), mean, strict=True) if m >= mean.max() - 1e-6)
    assert select_embedding_alpha(X[train], groups[train], S, lam=0, alphas=(0.5,)) == (0.5, None)
    few = np.isin(groups, [1, 2, 3])
    with pytest.raises(ZSLInputError, match="at least 4 training classes"):
        select_embedding_alpha(X[few], groups[few], A8_LIKE[[1, 2, 3]], lam=0)
    with pytest.raises(ConfigError, match="alphas"):
        select_embedding_alpha(X[train], groups[train], S, lam=0, alphas=())


# ------------------------------------------------------------------------------------------
# the study on the real depth images (reduced: 1 seed, 2 lambdas, small alpha grid)
# ------------------------------------------------------------------------------------------
REDUCED = dict(seeds=1, lams=(0, "inf"), alphas=(0.1, 0.01), progress=False, n_jobs=2)


def _settings(seeds=None, lams=None, partitions=None, **flat) -> FabricStudy:
    """A checked fabric study file from the keywords these tests use (``seeds``: ``[splits] n_seeds``,
    ``lams``: ``[methods] embedding_lambdas``, ``partitions``: an enabled ``[partitions]`` table)."""
    flat.update({k: v for k, v in (("n_seeds", seeds), ("embedding_lambdas", lams)) if v is not None})
    if partitions is not None:
        flat.update({"partitions.enabled": True, **{f"partitions.{k}": v for k, v in partitions.items()}})
    return study_settings(FabricStudy, **flat)


@pytest.fixture(scope="module")
def real_study(data_dir, tmp_path_factory, shared_cache):
    out = tmp_path_factory.mktemp("fabric_results")
    # a module fixture runs before the autouse cache isolation of conftest: use the same folder
    cache = shared_cache
    record: dict = {}  # what the run's one manifest.json records of the study (the engine writes it)
    result = run_fabric_study(ResultsDir(out), _settings(configs=(1, 2), **REDUCED), data_dir=data_dir, cache_dir=cache,
                              record=record)
    return out, result, record


@pytest.mark.slow
def test_real_study_table_layout(real_study):
    out, result, _ = real_study
    table, runs = result["table1"], result["runs"]
    assert {p.name for p in out.iterdir()} >= {"fabric_table1.csv", "fabric_runs.csv", "fabric_lambda.png"}
    assert not list(out.glob("*manifest.json"))  # the run's one manifest is the engine's
    on_disk = pd.read_csv(out / "fabric_table1.csv")
    assert on_disk.shape == table.shape
    assert table[["condition", "config", "protocol"]].values.tolist() == [
        [c, cfg, p] for c in ("depth-sequence", "depth-image") for cfg in (1, 2) for p in ("paper", "zero-shot-drop")
    ]
    methods = ["lam_0", "lam_inf", "ESZSL"]
    for m in methods:
        for col in (m, f"{m}_std", f"{m}_pcma", f"{m}_pcma_std", f"paper_{m}", f"{m}_ci95_low", f"{m}_ci95_high",
                    f"{m}_pcma_ci95_low", f"{m}_pcma_ci95_high"):
            assert col in table.columns, col
        assert table[m].between(0, 1).all() and table[f"{m}_pcma"].between(0, 1).all()
        assert (table[f"{m}_ci95_low"] <= table[m] + 1e-9).all() and (table[m] <= table[f"{m}_ci95_high"] + 1e-9).all()
    assert "lam_1" not in table.columns  # only the lambdas asked for
    # unequal test classes: the majority baseline is there and above chance somewhere
    assert (table["majority"] >= table["chance"] - 1e-12).all() and (table["majority"] > table["chance"]).any()
    # the paper's Average row beside the paper-protocol config-1 depth rows only
    cfg1 = (table["config"] == 1) & (table["protocol"] == "paper")
    assert (table.loc[cfg1, "paper_lam_0"] == FABRIC_TABLE1["Average"]["0"]).all()
    assert (table.loc[cfg1, "paper_ESZSL"] == FABRIC_TABLE1["Average"]["ESZSL"]).all()
    assert table.loc[~cfg1, ["paper_lam_0", "paper_lam_inf", "paper_ESZSL"]].isna().all().all()
    assert (table.loc[cfg1, "paper_row"] == "Average").all()
    assert table["note"].str.contains("not the paper's GelSight videos").all()
    assert table["note"].str.contains("regression term R only").all()
    assert table.loc[table["config"] == 2, "note"].str.contains("config 1 only").all()
    assert table.loc[table["protocol"] == "paper", "note"].str.contains("NOT zero-shot").all()
    # sample counts: 27 / 30 test fabrics; 282 / 312 test images (groups 0 + 5 + 7, 0 + 4 + 7); variants 0 + 7
    n_test = table.set_index(["condition", "config", "protocol"])["n_test"]
    assert ([n_test[(c, cfg, "paper")] for c in ("depth-sequence", "depth-image") for cfg in (1, 2)]
            == [27, 30, 282, 312])
    assert (table.loc[table["protocol"] == "zero-shot-drop", "test_groups"] == "0 7").all()
    assert table["n_seeds"].eq(1).all() and table["lam_0_std"].isna().all() and table["ESZSL_std"].eq(0).all()
    assert len(runs) == 8 * 3
    assert ({"accuracy_ci95_low", "accuracy_ci95_high", "per_class_mean_accuracy_ci95_low", "chance"}
            <= set(runs.columns))
    assert ((runs["accuracy_ci95_low"] <= runs["accuracy"] + 1e-9)
            & (runs["accuracy"] <= runs["accuracy_ci95_high"] + 1e-9)).all()
    text = format_fabric_table(table)
    assert "depth-sequence" in text and "[75.45]" in text  # paper Average, lambda = 0


@pytest.mark.slow
def test_real_headline_rows_have_no_test_group_seen_in_training(real_study, data_dir):
    _, result, _ = real_study
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        attributes = load_fabric(data_dir, images=False).attributes.reset_index(drop=True)
    table = result["table1"]
    headline = table[table["zero_shot"]]
    assert len(headline) == 4
    for _, row in headline.iterrows():
        train = [int(g) for g in row["train_groups"].split()]
        test = [int(g) for g in row["test_groups"].split()]
        assert seen_test_classes(attributes, train, test) == {}, row["protocol"]
    paper = table[table["protocol"] == "paper"].iloc[0]
    assert seen_test_classes(attributes, [int(g) for g in paper["train_groups"].split()],
                             [int(g) for g in paper["test_groups"].split()]) == {5: (3, 4)}


@pytest.mark.slow
def test_real_study_never_fits_on_test_groups(real_study):
    _, result, _ = real_study
    runs = result["runs"][result["runs"]["protocol"] == "paper"]
    for config, train in ((1, "1 2 3 4 6"), (2, "1 2 3 5 6")):
        sub = runs[runs["config"] == config]
        assert (sub["train_classes"] == train).all()
        test = {int(g) for g in fabric_zsl_split(config).test_groups}
        for counts in sub["predicted_counts"]:
            assert {int(kv.split(":")[0]) for kv in counts.split()} == test
    emb = runs[runs["method"] != "ESZSL"]
    assert emb["alpha"].isin([0.1, 0.01]).all() and emb["cv_score"].between(0, 1).all()


@pytest.mark.slow
def test_real_descriptors_cached_and_fit_on_training_groups(real_study, data_dir):
    # the study filled the cache: this call reads it; the depth samples use capture order
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        fabric = load_fabric(data_dir)
    desc = depth_image_descriptors(fabric)
    assert desc.shape == (1300, 99) and np.isfinite(desc).all()
    seq, img = depth_samples(fabric, desc)
    assert seq.X.shape == (119, 495) and img.X.shape == (1300, 99)
    first = seq.samples["image_ids"].str.split().str[0].astype(int)
    assert (fabric.images.loc[first, "capture_index"] == 0).all()
    A = fabric.attributes.to_numpy(float)
    split = fabric_zsl_split(1, A)
    run = zero_shot_run(
        lambda X, y, S: build_method("embedding", lam=0.1, alpha=0.1, early_stopping=False,
                                     random_state=0).fit(X, attribute_rows(y, S), y),
        seq.X, seq.groups, A, split,
    )
    assert run.train_classes.tolist() == [1, 2, 3, 4, 6]
    assert set(run.y_pred) <= {0, 5, 7} and run.y_true.size == 27


@pytest.mark.slow
def test_real_study_refuses_to_overwrite(real_study, data_dir):
    out, _, record = real_study
    before = (out / "fabric_table1.csv").read_bytes()
    with pytest.raises(ConfigError, match="already exists; use --force"):
        run_fabric_study(ResultsDir(out), _settings(configs=(1,), **REDUCED), data_dir=data_dir)
    assert (out / "fabric_table1.csv").read_bytes() == before
    assert record["fabric"]["lams"] == ["0", "inf"] and record["fabric"]["seeds"] == [0]
    assert len(record["depth_images_sha256"]) == 64 and len(record["data_files"]) > 1300


def test_impossible_settings_are_refused_by_the_schema():
    """The study takes a checked file: what cannot run is refused before any data is read."""
    for bad, match in (({"seeds": 0}, "n_seeds"), ({"conditions": ("depth-video",)}, "conditions"),
                       ({"conditions": ()}, "conditions"), ({"lams": (0, 0.0)}, "embedding_lambdas")):
        with pytest.raises(ValidationError, match=match):
            _settings(**bad)


# ------------------------------------------------------------------------------------------
# the GelSight path on a synthetic folder in the documented layout
# ------------------------------------------------------------------------------------------
def _press_video(group: int, press: int, n=24, h=48, w=64) -> np.ndarray:
    """Grey MJPG-friendly press: flat until frame 4, a group-specific texture rising to frame 16."""
    rng = np.random.default_rng(100 * group + press)
    yy, xx = np.mgrid[0:h, 0:w]
    freq = 0.08 + 0.035 * group
    texture = np.sin(2 * np.pi * freq * (xx + 0.5 * group * yy)) * (1 + 0.1 * rng.normal(size=(h, w)))
    weight = np.clip((np.arange(n) - 4) / 12.0, 0, 1)
    frames = 90 + weight[:, None, None] * (60 + 50 * texture[None])
    frames = np.clip(frames, 0, 255).astype(np.uint8)
    return np.repeat(frames[..., None], 3, axis=-1)


@pytest.fixture(scope="module")
def gelsight_root(tmp_path_factory):
    import imageio.v3 as iio

    root = tmp_path_factory.mktemp("gelsight")
    names = [f"F{g + 1:04d}" for g in range(8)]
    pd.DataFrame({"fabric_id": range(1, 9), "fabric_name": names, "group": range(8)}).to_csv(
        root / "fabric_groups.csv", index=False
    )
    for g, name in enumerate(names):
        folder = root / "Flat" / name
        folder.mkdir(parents=True)
        for press in range(2):
            iio.imwrite(folder / f"{press + 1}.avi", _press_video(g, press), plugin="FFMPEG", fps=30,
                        codec="mjpeg", quality=10, macro_block_size=16)
    shutil.copytree(root / "Flat", root / "Mine")  # a condition the paper does not have
    return root


@pytest.mark.slow
def test_gelsight_layout_runs_through_the_study(gelsight_root, data_dir, tmp_path):
    record: dict = {}
    result = run_fabric_study(
        ResultsDir(tmp_path), _settings(configs=(1,), conditions=(), seeds=1, lams=(0,), alphas=(0.1,), progress=False,
                                        gelsight_root=str(gelsight_root)),
        data_dir=data_dir, gelsight_root=gelsight_root, record=record,
    )
    assert result["table1"]["protocol"].tolist() == ["paper", "zero-shot-drop"] * 2
    table = result["table1"][result["table1"]["protocol"] == "paper"].reset_index(drop=True)
    assert table["condition"].tolist() == ["gelsight-Flat", "gelsight-Mine"]
    assert table["n_test"].tolist() == [6, 6] and table["n_train"].tolist() == [10, 10]
    flat, mine = table.iloc[0], table.iloc[1]
    assert flat["paper_row"] == "Flat" and flat["paper_lam_0"] == FABRIC_TABLE1["Flat"]["0"]
    assert flat["paper_ESZSL"] == FABRIC_TABLE1["Flat"]["ESZSL"]
    assert mine["paper_row"] == "" and np.isnan(mine["paper_lam_0"])
    assert table[["lam_0", "ESZSL"]].stack().between(0, 1).all()
    # identical videos in both folders give identical results (and share the cache)
    assert flat["lam_0"] == mine["lam_0"] and flat["ESZSL"] == mine["ESZSL"]
    assert record["fabric"]["n_features"]["gelsight-Flat"] == 5 * 99
    assert len(record["gelsight_videos_sha256"]) == 64


def test_each_fit_is_done_and_counted_once(gelsight_root, data_dir, tmp_path):
    from tzsl._profile import profiling

    with profiling("fabric") as profile:  # in this process (n_jobs=1): the jobs' events are counted once
        result = run_fabric_study(
            ResultsDir(tmp_path), _settings(configs=(1,), conditions=(), seeds=1, lams=(0,), alphas=(0.1,),
                                            progress=False, n_jobs=1, gelsight_root=str(gelsight_root)),
            data_dir=data_dir, gelsight_root=gelsight_root,
        )
    counts = {r["stage"]: r["calls"] for r in profile.rows() if r["stage"].startswith("fit_store.")}
    # 2 conditions x (lam 0 + ESZSL), each fitted once for both protocols (paper, zero-shot-drop)
    assert sum(counts[k] for k in counts if k != "fit_store.repeat") == 4, counts
    assert len(result["runs"]) == 2 * 2 * 2


@pytest.mark.slow
def test_partitions_add_a_table_and_leave_the_others_unchanged(gelsight_root, data_dir, tmp_path):
    flat = dict(configs=(1,), gelsight_root=str(gelsight_root), gelsight_conditions=["Flat"], conditions=(), seeds=1,
                lams=(0,), alphas=(0.1,), progress=False)
    paths = dict(data_dir=data_dir, gelsight_root=gelsight_root)
    plain = run_fabric_study(ResultsDir(tmp_path / "plain"), _settings(**flat), **paths)
    parts = {"attributes": "a12", "min_test": 4, "both_signs": False, "max_partitions": 3}
    both = run_fabric_study(ResultsDir(tmp_path / "both"), _settings(partitions=parts, **flat), **paths)
    assert ((tmp_path / "plain" / "fabric_table1.csv").read_bytes()
            == (tmp_path / "both" / "fabric_table1.csv").read_bytes())
    comparisons = [pd.read_csv(tmp_path / d / "fabric_method_comparison.csv").drop(columns="fit_seconds")
                   for d in ("plain", "both")]  # fit_seconds is a timing
    pd.testing.assert_frame_equal(*comparisons)
    assert not (tmp_path / "plain" / "fabric_partitions.csv").exists()
    table = pd.read_csv(tmp_path / "both" / "fabric_partitions.csv")
    assert table["n_partitions"].eq(3).all() and table["attributes"].eq("a12").all()
    assert table["chance"].eq(0.25).all() and set(table["metric"]) == {"class_mean", "trial"}
    assert both["partitions"].shape[0] == 2 and "partitions" not in plain
    with pytest.warns(UserWarning, match="no valid partition of the a8 groups"):
        run_fabric_study(ResultsDir(tmp_path / "a8"), _settings(partitions={"min_test": 4}, **flat), **paths)
    assert pd.read_csv(tmp_path / "a8" / "fabric_partitions.csv").empty


def test_gelsight_groups_must_index_the_attribute_matrix(gelsight_root, data_dir, tmp_path):
    root = tmp_path / "bad"
    shutil.copytree(gelsight_root / "Flat", root / "Flat")
    table = pd.read_csv(gelsight_root / "fabric_groups.csv")
    table.loc[0, "group"] = 9
    table.to_csv(root / "fabric_groups.csv", index=False)
    with pytest.raises(DataFileError, match=r"groups \[9\] are outside 0..7"):
        run_fabric_study(ResultsDir(tmp_path / "out"), _settings(conditions=(), progress=False,
                                                                 gelsight_root=str(root)),
                         data_dir=data_dir, gelsight_root=root)


def test_a_failing_fit_is_a_row_with_nan_and_its_error():
    from tzsl.studies.fabric.methods import run_job as _run_job
    from tzsl.studies.fabric.study import ESZSL_METHOD

    X, groups = _synthetic()
    split = fabric_zsl_split(1)
    [ok] = _run_job(X, groups, A8_LIKE, [split], ESZSL_METHOD, None, None, (), 50)
    assert ok["error"] == "" and 0 <= ok["accuracy"] <= 1
    X_bad = X.copy()
    X_bad[0, 0] = np.nan  # ESZSL refuses non-finite features
    [row] = _run_job(X_bad, groups, A8_LIKE, [split], ESZSL_METHOD, None, None, (), 50)
    assert np.isnan(row["accuracy"]) and np.isnan(row["per_class_mean_accuracy"])
    assert row["error"].startswith("ZSLInputError: ") and "\n" not in row["error"]
    assert row["n_test"] == ok["n_test"] and row["method"] == ESZSL_METHOD
