"""Deep fabric study: CNN + LSTM over 5-frame sequences with the F15 loss (F17, fabric paper §4.2).

Two sources of frame sequences:

* **Fabric depth images** (public, ``<data home>/fabric/depth224``): the GelSight press videos
  of the study are not public, so each fabric's 8-16 depth images, in capture order, stand in
  for its frame sequence. The 5 frames are **evenly spaced over the capture order** (first,
  last and 3 between, ``round(linspace(0, n - 1, 5))``). The paper's key-frame rule (F14:
  first frame as contact-free reference, start at the first frame over a threshold, end at the
  maximum difference) presumes a press video that starts without contact; separate depth
  captures have no such reference frame, so the rule has nothing to measure here. One sequence
  per fabric: 119 sequences.
* **User GelSight videos** (``--gelsight-root``, layout in :mod:`tzsl.datasets._fabric_videos`): the
  paper's 5 key frames of every press video (:class:`tzsl.features.KeyFrameSelector`, default
  settings). One sequence per video.

The zero-shot split is :func:`tzsl.datasets.fabric_zsl_split` (config 1 is the paper's: train
groups 1, 2, 3, 4, 6, test 0, 5, 7; 0-indexed) with the group attribute matrix of
:func:`tzsl.datasets.load_fabric`. Training groups that share an attribute vector (3 and 4 in
``a8``) are merged into one class for training (``duplicate_attributes="merge"``); training
accuracy is scored among the distinct training attribute vectors, test accuracy among the test
groups' vectors.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from tzsl.datasets import FabricData, FabricSplit, fabric_zsl_split, load_fabric, load_gelsight_fabric_videos
from tzsl.evaluation import Outcomes, add_trust_columns, per_class_mean_accuracy, summarise_over_splits, trial_accuracy
from tzsl.exceptions import ConfigError, DataFileError
from tzsl.models import DeepAttributeEmbedding
from tzsl.studies.config import FabricDeepStudy
from tzsl.studies.fabric.tables import PAPER_LAMBDAS, fabric_protocols, lambda_label

__all__ = [
    "PAPER_LAMBDAS",
    "DeepRunResult",
    "FrameSequences",
    "fabric_depth_sequences",
    "format_deep_result",
    "gelsight_video_sequences",
    "deep_table",
    "format_deep_table",
    "load_deep_sequences",
    "run_deep_fabric",
    "run_deep_fabric_study",
]


@dataclass(frozen=True)
class FrameSequences:
    """Frame sequences and their fabrics.

    Attributes
    ----------
    frames : ndarray of shape (n, T, H, W) or (n, T, H, W, C)
        Raw frames (depth values as uint16; video frames as uint8 RGB).
    table : DataFrame
        One row per sequence: fabric_id, fabric_name, group, and for videos condition, press,
        path; ``frame_index`` lists the chosen frame / capture indices.
    source : str
        ``"fabric-depth"`` or ``"gelsight-videos"``.
    """

    frames: np.ndarray
    table: pd.DataFrame
    source: str

    @property
    def groups(self) -> np.ndarray:
        """Group (class) of every sequence, shape (n,), int64."""
        return self.table["group"].to_numpy(dtype=np.int64)


def evenly_spaced(n_available: int, n_frames: int) -> np.ndarray:
    """``round(linspace(0, n_available - 1, n_frames))`` as int64 indices (n_frames,)."""
    return np.floor(np.linspace(0, n_available - 1, n_frames) + 0.5).astype(np.int64)


def fabric_depth_sequences(data: FabricData, n_frames: int = 5) -> FrameSequences:
    """One sequence per fabric: ``n_frames`` depth images evenly spaced in capture order.

    Parameters
    ----------
    data : FabricData
        From :func:`tzsl.datasets.load_fabric` (with its image table).
    n_frames : int, default=5

    Returns
    -------
    FrameSequences
        ``frames`` of shape (n_fabrics, n_frames, 224, 224), uint16 depth values.
    """
    images = data.images
    if images.empty:
        raise ConfigError("the fabric data was loaded without its image table (load_fabric(images=True))")
    counts = images.groupby("fabric_id", sort=True).size()
    short = counts[counts < n_frames]
    if len(short):
        raise DataFileError(data.root, f"fabrics {short.index.tolist()[:5]} have fewer than {n_frames} "
                            "depth images; cannot build a sequence")
    first = images.groupby("fabric_id", sort=True)["image_id"].min()
    # rows of the image table (ordered by fabric, capture time): first row + spaced offsets
    offsets = np.stack([evenly_spaced(int(c), n_frames) for c in counts.to_numpy()])
    rows = (first.to_numpy()[:, None] + offsets).ravel()
    imgs = data.read_images(rows)
    frames = imgs.reshape(len(counts), n_frames, *imgs.shape[1:])
    fabrics = images.iloc[first.to_numpy()][["fabric_id", "fabric_name", "group"]].reset_index(drop=True)
    fabrics["frame_index"] = [list(map(int, o)) for o in offsets]
    return FrameSequences(frames=frames, table=fabrics, source="fabric-depth")


def gelsight_video_sequences(root, conditions=None, *, selector=None, n_jobs: int = 1) -> FrameSequences:
    """The 5 key frames of every user-supplied GelSight press video.

    Parameters
    ----------
    root : str or path-like
        Layout of :func:`tzsl.datasets.load_gelsight_fabric_videos`.
    conditions : sequence of str or None
        Condition folders to use (None: all).
    selector : KeyFrameSelector or None
        Key-frame rule (default: ``KeyFrameSelector()``, the paper's).
    n_jobs : int, default=1
        Videos decoded in parallel (threads; decoding runs in ffmpeg subprocesses).

    Returns
    -------
    FrameSequences
        ``frames`` of shape (n_videos, 5, H, W, 3), uint8.
    """
    from joblib import Parallel, delayed  # noqa: PLC0415

    from tzsl.features import KeyFrameSelector  # noqa: PLC0415

    table = load_gelsight_fabric_videos(root, conditions)
    selector = KeyFrameSelector() if selector is None else selector
    picked = Parallel(n_jobs=n_jobs, prefer="threads")(delayed(selector.select_one)(p) for p in table["path"])
    shapes = {kf.frames.shape for kf in picked}
    if len(shapes) > 1:
        raise DataFileError(Path(root), f"videos have different frame shapes {sorted(shapes)}; "
                            "the deep model needs one frame size")
    table = table.copy()
    table["frame_index"] = [kf.indices.tolist() for kf in picked]
    return FrameSequences(frames=np.stack([kf.frames for kf in picked]), table=table, source="gelsight-videos")


@dataclass
class DeepRunResult:
    """Outcome of :func:`run_deep_fabric`.

    Attributes
    ----------
    model : DeepAttributeEmbedding
    config : int
    train_groups, test_groups : tuple of int
    train_accuracy, test_accuracy : float
        Per-sequence accuracy (train: among the distinct training attribute vectors; test: among
        the test groups' vectors).
    test_class_mean_accuracy : float
        Mean over test groups of each group's accuracy.
    n_train, n_test : int
        Sequences.
    seconds_per_epoch : float
        Mean wall time of an epoch.
    feature_seconds : float
        Time to compute the frozen CNN features (0 when cached).
    predictions : DataFrame
        The sequence table plus ``split`` ("train"/"test") and ``predicted_group``.
    """

    model: DeepAttributeEmbedding
    config: int
    train_groups: tuple[int, ...]
    test_groups: tuple[int, ...]
    train_accuracy: float
    test_accuracy: float
    test_class_mean_accuracy: float
    n_train: int
    n_test: int
    seconds_per_epoch: float
    feature_seconds: float
    predictions: pd.DataFrame = field(repr=False)


def run_deep_fabric(
    sequences: FrameSequences,
    attributes: pd.DataFrame | np.ndarray,
    *,
    config: int = 1,
    model: DeepAttributeEmbedding | None = None,
    split: FabricSplit | None = None,
) -> DeepRunResult:
    """Train the deep model on the training groups and score train and test groups.

    Parameters
    ----------
    sequences : FrameSequences
    attributes : DataFrame or ndarray of shape (8, L)
        Group x attribute matrix (``FabricData.attributes``).
    config : int, default=1
        Zero-shot split (:func:`tzsl.datasets.fabric_zsl_split`).
    model : DeepAttributeEmbedding or None
        Unfitted estimator (default: ``DeepAttributeEmbedding(random_state=0)``); its
        ``duplicate_attributes`` is set to ``"merge"``.
    split : FabricSplit or None
        A split to use instead of ``config``'s (e.g. its zero-shot variant,
        :func:`tzsl.studies.fabric.tables.fabric_protocols`).

    Returns
    -------
    DeepRunResult
    """
    A = np.asarray(attributes, dtype=np.float64)
    split = fabric_zsl_split(config, A) if split is None else split
    groups = sequences.groups
    is_train, is_test = split.is_train(groups), split.is_test(groups)
    for name, mask, wanted in (("training", is_train, split.train_groups), ("test", is_test, split.test_groups)):
        missing = sorted(set(wanted) - set(groups[mask]))
        if not mask.any():
            raise ConfigError(f"no {name} sequences (groups {list(wanted)}) in the {sequences.source} data")
        if missing and name == "training":
            raise ConfigError(f"{name} groups {missing} have no sequence in the {sequences.source} data")
    model = DeepAttributeEmbedding(random_state=0) if model is None else model
    model.set_params(duplicate_attributes="merge")
    train_groups_present = np.unique(groups[is_train])
    model.fit(sequences.frames[is_train], groups[is_train], A[train_groups_present])

    # training accuracy among the distinct training attribute vectors
    S_train, row_of_group = np.unique(A[train_groups_present], axis=0, return_inverse=True)
    true_row = row_of_group.ravel()[np.searchsorted(train_groups_present, groups[is_train])]
    pred_row = model.predict(sequences.frames[is_train], S_train)
    test_groups = np.asarray(split.test_groups)
    pred_test = test_groups[model.predict(sequences.frames[is_test], A[test_groups])]

    table = sequences.table.copy()
    table["split"] = np.where(is_train, "train", np.where(is_test, "test", "unused"))
    predicted = np.full(len(table), -1, dtype=np.int64)
    # a merged training prediction names the first group of its attribute vector
    first_group_of_row = np.array([train_groups_present[np.argmax(row_of_group.ravel() == r)]
                                   for r in range(S_train.shape[0])])
    predicted[is_train] = first_group_of_row[pred_row]
    predicted[is_test] = pred_test
    table["predicted_group"] = predicted
    times = model.epoch_times_
    return DeepRunResult(
        model=model,
        config=split.config,
        train_groups=split.train_groups,
        test_groups=split.test_groups,
        train_accuracy=float(np.mean(pred_row == true_row)),
        test_accuracy=trial_accuracy(groups[is_test], pred_test),
        test_class_mean_accuracy=per_class_mean_accuracy(groups[is_test], pred_test),
        n_train=int(is_train.sum()),
        n_test=int(is_test.sum()),
        seconds_per_epoch=float(np.mean(times)) if times else float("nan"),
        feature_seconds=float(getattr(model, "feature_time_", 0.0)),
        predictions=table,
    )


def format_deep_result(result: DeepRunResult, source: str = "") -> str:
    """A short human-readable summary of a run (several lines)."""
    m = result.model
    losses = m.loss_curve_
    lines = [
        f"deep model ({m.backbone}, finetune={m.finetune}, lam={m.lam}) on {source or 'fabric'}: "
        f"config {result.config}, train groups {list(result.train_groups)}, test groups {list(result.test_groups)}",
        f"sequences: {result.n_train} train, {result.n_test} test; epochs: {m.n_epochs_}",
        f"training loss: {losses[0]:.4f} (first epoch) -> {losses[-1]:.4f} (last)" if losses else "no epoch run",
        f"time: {result.seconds_per_epoch:.3f} s per epoch; CNN features {result.feature_seconds:.1f} s",
        f"train accuracy: {100 * result.train_accuracy:.2f} %",
        f"test accuracy:  {100 * result.test_accuracy:.2f} % "
        f"(per-group mean {100 * result.test_class_mean_accuracy:.2f} %)",
    ]
    return "\n".join(lines)


def load_deep_sequences(
    *, data_dir: str | os.PathLike | None = None, gelsight_root=None, conditions=None,
    attributes: str = "a8", n_jobs: int = 1,
) -> tuple[FrameSequences, pd.DataFrame]:
    """Frame sequences (fabric depth images, or user videos under ``gelsight_root``) and the
    group x attribute matrix ``attributes`` of the fabric data."""
    if gelsight_root is None:
        data = load_fabric(data_dir, attributes)
        return fabric_depth_sequences(data), data.attributes
    data = load_fabric(data_dir, attributes, images=False)
    return gelsight_video_sequences(gelsight_root, conditions, n_jobs=n_jobs), data.attributes


# ---------------------------------------------------------------------------------------------
# the study behind ``tzsl evaluate-fabric --model deep``
# ---------------------------------------------------------------------------------------------
DEEP_TABLE_FILE = "fabric_deep_table.csv"
DEEP_RUNS_FILE = "fabric_deep_runs.csv"


def run_deep_fabric_study(
    out,
    settings: FabricDeepStudy | None = None,
    *,
    data_dir=None,
    gelsight_root=None,
    cache_dir=None,
    save_model=None,
    record: dict | None = None,
) -> dict[str, pd.DataFrame]:
    """The deep model over the paper's lambda grid: fabric depth sequences (and user videos).

    Parameters
    ----------
    out : tzsl.studies.outputs.results_folder.ResultsDir
        Output folder; existing outputs are refused unless forced (checked first).
    settings : FabricDeepStudy or None
        The checked study file (:class:`~tzsl.studies.config.FabricDeepStudy`; default: the schema's
        defaults): ``[dataset] attributes``, ``[features] gelsight_conditions``, ``[methods]``
        (``embedding_lambdas``; ``model``: further :class:`~tzsl.models.DeepAttributeEmbedding`
        parameters), ``[splits]`` (``configs``; ``n_seeds`` seeds per (condition, config, lambda) from
        ``seed``) and ``[compute] progress``.
    data_dir, gelsight_root : str, path or None
        The data home with ``fabric/`` and your GelSight videos (one ``gelsight-<condition>`` row per
        condition folder), resolved (default: ``[dataset]``'s).
    cache_dir : str, path or None
        Frozen-feature cache (default ``<tzsl cache dir>/deep-features``).
    save_model : str, path or None
        Save the trained network as a model bundle here (one fit only: one condition, config,
        lambda and seed; only the config's zero-shot protocol is then run); refused when it
        exists unless ``out.force``.
    record : dict, optional
        Filled with what the run's one manifest records of the study (``tzsl run`` writes it into
        ``manifest.json``): ``"fabric_deep"`` (seeds, configs, lambdas, the model's parameters) and
        ``"data_files"``.

    Returns
    -------
    dict of str -> DataFrame
        ``"runs"`` (one row per fit) and ``"table"`` (mean and std over seeds per condition,
        config and lambda). Written as ``fabric_deep_runs.csv`` and ``fabric_deep_table.csv``.
    """
    import warnings  # noqa: PLC0415

    from tzsl.datasets import get_cache_dir  # noqa: PLC0415

    settings = FabricDeepStudy() if settings is None else settings
    seeds, configs, seed = settings.splits.n_seeds, [int(c) for c in settings.splits.configs], settings.splits.seed
    lams, attributes, progress = list(settings.methods.embedding_lambdas), settings.dataset.attributes, \
        settings.compute.progress
    gelsight_conditions, model_params = settings.features.gelsight_conditions, dict(settings.methods.model)
    data_dir = settings.dataset.data_dir if data_dir is None else data_dir
    gelsight_root = settings.dataset.gelsight_root if gelsight_root is None else gelsight_root
    labels = [lambda_label(lam) for lam in lams]
    params = model_params
    params.setdefault("verbose", progress)
    DeepAttributeEmbedding(**params)._check_params()  # bad settings fail before any work
    out.check_free([DEEP_TABLE_FILE, DEEP_RUNS_FILE])
    if save_model is not None and Path(save_model).exists() and not out.force:
        raise ConfigError(f"{save_model} already exists; use --force to overwrite it")
    cache = Path(cache_dir) if cache_dir is not None else Path(get_cache_dir()) / "deep-features"

    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="fabric attribute matrix", category=UserWarning)
        fabric = load_fabric(data_dir, attributes, images=gelsight_root is None)
    sources: list[tuple[str, FrameSequences]] = []
    if gelsight_root is None:
        sources.append(("depth-sequence", fabric_depth_sequences(fabric)))
    else:
        videos = load_gelsight_fabric_videos(gelsight_root, gelsight_conditions)
        for cond in videos["condition"].unique():
            sources.append((f"gelsight-{cond}", gelsight_video_sequences(gelsight_root, [cond])))

    if save_model is not None and len(sources) * len(configs) * len(labels) * int(seeds) != 1:
        raise ConfigError("saving a model needs exactly one fit (one condition, config, lambda and seed)")
    rows = []
    keys = ["condition", "config", "protocol", "method"]
    outcomes = Outcomes(split_column="seed", by=keys)
    protocols = fabric_protocols(configs, fabric.attributes)  # the paper's split and its zero-shot variant
    if save_model is not None:  # the saved model is the zero-shot (headline) protocol's fit
        protocols = [p for p in protocols if p.zero_shot]
    for condition, seqs in sources:
        for proto in protocols:
            config = proto.split.config
            for lam, label in zip(lams, labels, strict=True):
                for sd in range(int(seed), int(seed) + int(seeds)):
                    model = DeepAttributeEmbedding(**{**params, "lam": lam, "random_state": sd,
                                                      "cache_dir": params.get("cache_dir", cache)})
                    r = run_deep_fabric(seqs, fabric.attributes, config=config, model=model, split=proto.split)
                    test = (r.predictions["split"] == "test").to_numpy()
                    y_true, y_pred = seqs.groups[test], r.predictions["predicted_group"].to_numpy()[test]
                    key = {"condition": condition, "config": config, "protocol": proto.name, "method": f"lam_{label}"}
                    outcomes.add(sd, "accuracy", y_true, y_true == y_pred, **key)
                    outcomes.add(sd, "per_class_mean_accuracy", y_true, y_true == y_pred, metric="class_mean", **key)
                    rows.append({
                        **key, "zero_shot": proto.zero_shot, "test_groups": " ".join(map(str, proto.split.test_groups)),
                        "seed": sd,
                        "accuracy": r.test_accuracy, "per_class_mean_accuracy": r.test_class_mean_accuracy,
                        "train_accuracy": r.train_accuracy, "n_train": r.n_train, "n_test": r.n_test,
                        "epochs": r.model.n_epochs_, "early_stopping": bool(r.model.early_stopping),
                        "final_loss": r.model.loss_curve_[-1],
                        "seconds_per_epoch": r.seconds_per_epoch, "feature_seconds": r.feature_seconds,
                    })
                    if save_model is not None:
                        from tzsl.inference.deep_bundles import save_deep_bundle  # noqa: PLC0415

                        save_deep_bundle(r.model, save_model, force=out.force)
    runs = pd.DataFrame(rows)
    table = deep_table(runs, outcomes, ["zero_shot", "test_groups"])
    out.write_csv(DEEP_RUNS_FILE, runs)
    out.write_csv(DEEP_TABLE_FILE, table)
    data_files = sorted({Path(p) for _, seqs in sources if "path" in seqs.table for p in seqs.table["path"]})
    if gelsight_root is None:  # depth sequences: the images they were built from
        data_files = [Path(p) for p in fabric.images["path"]]
    if record is not None:  # the engine's manifest hashes every data file read
        record.update({"fabric_deep": {
            "study": "fabric-deep", "seeds": list(range(int(seed), int(seed) + int(seeds))), "configs": configs,
            "lams": [str(v) for v in lams], "attributes": attributes, "gelsight_root": str(gelsight_root or ""),
            "model_params": {k: str(v) for k, v in DeepAttributeEmbedding(**params).get_params().items()}},
            "data_files": list(data_files)})
    return {"runs": runs, "table": table}


def deep_table(runs: pd.DataFrame, outcomes: Outcomes, carried: list[str]) -> pd.DataFrame:
    """The deep study's table: mean and std over seeds of every (``outcomes.by``) row of ``runs``, with intervals.

    Parameters
    ----------
    runs : DataFrame
        One row per fit: ``seed``, the key columns ``outcomes.by`` (4 of them), ``carried``, ``accuracy``,
        ``per_class_mean_accuracy``, ``train_accuracy``, ``seconds_per_epoch``.
    outcomes : Outcomes
        The test trials of every fit (``split_column="seed"``; :func:`tzsl.evaluation.add_trust_columns`).
    carried : list of str
        Columns of ``runs`` constant within a key, carried to the table after the keys.

    Returns
    -------
    DataFrame
        One row per key: the keys, ``carried``, ``n_seeds``, the means, their ``<col>_ci95_low`` /
        ``<col>_ci95_high`` (bootstrap over seeds and test classes), ``<col>_std`` and ``chance``.
    """
    keys = list(outcomes.by)
    stats = ["accuracy", "per_class_mean_accuracy", "train_accuracy", "seconds_per_epoch"]
    summary = summarise_over_splits(runs[["seed", *keys, *stats]], split_column="seed", by=keys, ddof=0)
    mean = summary[summary["seed"] == "mean"].drop(columns="seed").reset_index(drop=True)
    std = summary.loc[summary["seed"] == "std", stats].fillna(0.0).reset_index(drop=True)
    table = pd.concat([mean, std.add_suffix("_std")], axis=1)
    table.insert(len(keys), "n_seeds", runs.groupby(keys, sort=False).size().to_numpy())
    firsts = runs.groupby(keys, sort=False)[carried].first().reset_index(drop=True)
    for i, column in enumerate(carried):
        table.insert(len(keys) + i, column, firsts[column].to_numpy())
    return add_trust_columns(table.assign(seed="mean"), outcomes, per_split_rows=False).drop(columns="seed")


def format_deep_table(table: pd.DataFrame) -> str:
    """The deep study's table as aligned text (accuracies in %)."""
    show = table[[c for c in ("condition", "config", "protocol", "method", "n_seeds") if c in table.columns]].copy()
    for col in ("accuracy", "per_class_mean_accuracy", "train_accuracy"):
        show[col] = [f"{100 * m:.2f} +- {100 * s:.2f}" for m, s in zip(table[col], table[f"{col}_std"], strict=True)]
    show["s/epoch"] = table["seconds_per_epoch"].map(lambda v: f"{v:.3f}")
    return show.to_string(index=False)
