"""The fabric zero-shot study (F18): the fabric paper's Table 1 and Fig. 6 on the data we have.

The paper (``../shared/papers/fabric_zsl_gelsight.txt``, section 5) classifies GelSight press
videos (samples) of 119 fabrics into 8 fabric groups (classes) by way of 8 binary group
attributes: train on groups {1, 2, 3, 4, 6} (0-indexed), recognise groups {0, 5, 7} from their
attribute vectors alone. Its Table 1 reports the accuracy of the embedding trained with the loss
``C + lambda R`` for lambda in {0, 0.1, 1, 10, inf} and of ESZSL, on three capture conditions
(Flat, Fold, Rand).

Data conditions (rows of ``fabric_table1.csv``)
-----------------------------------------------
The GelSight videos are not public. What is public (``<data home>/fabric``) are the same fabrics'
groups, the group x attribute matrices and 1300 real 16-bit depth images (8-16 per fabric,
224 x 224, taken about 10 s apart). Two honest uses of them:

``depth-sequence`` (one sample per fabric, 119 samples)
    The images of a fabric in capture order stand in for the frame sequence of a press video.
    The paper's key-frame rule (section 4.1: first frame as the contact-free reference, start =
    first frame over a threshold, end = maximum difference) needs a press inside one video; the
    depth images are independent captures, the first one is not contact-free, and the mean
    depth of a fabric's images varies only by capture noise (within-fabric std 2-7 of ~1075
    units), so :class:`~tzsl.features.KeyFrameSelector` would pick its start and end frames by
    noise. Instead the 5 "key frames" are 5 evenly spaced images of the sequence (positions
    ``round(linspace(0, n - 1, 5))``, always the first and the last), and their
    :class:`~tzsl.features.TextureDescriptor` vectors are concatenated in time order
    (5 x 99 = 495 features), as the paper feeds 5 key frames to its CNN+LSTM.
``depth-image`` (one sample per image, 1300 samples)
    Every depth image is a sample (99 features); a group's accuracy counts images.

``gelsight-<condition>`` (only with ``gelsight_root``)
    User-supplied GelSight press videos in the layout of
    :func:`tzsl.datasets.load_gelsight_fabric_videos` (``<root>/<condition>/<fabric>/<press>.avi``);
    one sample per video: the paper's 5 key frames (``KeyFrameSelector(as_gray=True)``, paper
    defaults), each shrunk so its longer side is at most ``max_side`` pixels (bounds the
    descriptor cost; the paper used 224 x 224 CNN inputs), descriptors concatenated. These rows
    get the paper's row of the same name (Flat / Fold / Rand) beside them.

The paper's numbers belong to GelSight videos and a CNN+LSTM; beside the depth rows the table
puts the paper's Average row for orientation only (the ``note`` column says so). The paper
reports its split (config 1) only; config 2 rows have no paper numbers.

Methods and model selection (training groups only)
--------------------------------------------------
* ``lam_<lambda>``: :class:`~tzsl.models.EmbeddingZSL` (``f = sigmoid(W x + b)`` on z-scored
  features, the paper's last layer on our descriptors) with ``lam`` in ``lams``. ``lam="inf"``
  is the regression term R alone - a documented deviation: the paper's caption literally says
  "C only", which would repeat the lambda = 0 column (see :mod:`tzsl.models._embedding`). Its
  weight decay ``alpha`` is chosen per fit by class-grouped cross-validation on the training
  groups (:func:`select_embedding_alpha`: held-out groups are recognised among themselves, as
  :class:`~tzsl.models.ESZSLCV` tunes ESZSL), then the model is refitted on all training
  groups without early stopping. (The model's own early stopping holds out ONE training class
  and stops when its loss rises; on this data that happens at the first L-BFGS iterations for
  lambda >= 1, leaving an essentially untrained model, so it is not used.) Repeated for
  ``seeds`` seeds (weight initialisation).
* ``ESZSL``: :class:`~tzsl.models.ESZSLCV`, both regularisers chosen by class-grouped CV on the
  training groups. Deterministic, fitted once; its ``_std`` columns are 0.
* Groups sharing one attribute vector (a8: groups 3, 4, 5) are merged in training
  (``duplicate_attributes="merge"``); test groups must have distinct vectors
  (:func:`tzsl.datasets.fabric_zsl_split`).
* Prediction: nearest attribute vector among the TEST groups only (zero-shot); accuracy over
  test samples and per-class mean accuracy over test groups.

Outputs (through :class:`~tzsl.experiments._outputs.ResultsDir`)
----------------------------------------------------------------
``fabric_table1.csv`` (:func:`fabric_table`), ``fabric_runs.csv`` (one row per fit),
``fabric_lambda.png`` (accuracy vs lambda, ours and the paper's: Fig. 6) and
``fabric_manifest.json``.

Caching: the texture descriptors (about 20-40 s for the 1300 images on 2 cores) are cached with
:class:`joblib.Memory` under :func:`tzsl.datasets.get_cache_dir`, keyed on the sha256 of the
image (or video) files and the descriptor parameters; a re-run only refits the models.
"""

from __future__ import annotations

import hashlib
import os
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import joblib
import numpy as np
import pandas as pd
from joblib import Parallel, delayed
from sklearn.exceptions import ConvergenceWarning
from threadpoolctl import threadpool_limits

from tzsl._io import file_sha256
from tzsl.datasets import (
    FABRIC_ATTRIBUTE_SETS,
    FabricData,
    FabricSplit,
    fabric_zsl_split,
    get_cache_dir,
    load_fabric,
    load_gelsight_fabric_videos,
    read_depth_images,
)
from tzsl.evaluation import (
    DEFAULT_ALPHAS,
    per_class_mean_accuracy,
    select_embedding_alpha,
    summarise_over_splits,
    trial_accuracy,
)
from tzsl.exceptions import ConfigError, DataFileError
from tzsl.experiments._outputs import ResultsDir
from tzsl.experiments.paper_numbers import FABRIC_TABLE1
from tzsl.features import KeyFrameSelector, TextureDescriptor
from tzsl.models import ESZSLCV, EmbeddingZSL
from tzsl.models._embedding import loss_weights

__all__ = [
    "DEFAULT_ALPHAS",
    "DEPTH_CONDITIONS",
    "PAPER_LAMBDAS",
    "FabricSamples",
    "ZeroShotRun",
    "depth_image_descriptors",
    "depth_samples",
    "depth_sequence_rows",
    "fabric_lambda_figure",
    "fabric_table",
    "format_fabric_table",
    "gelsight_samples",
    "lambda_label",
    "run_fabric_study",
    "select_embedding_alpha",
    "zero_shot_run",
]

#: The paper's lambda grid (Table 1); "inf" = regression term only (see the module docstring).
PAPER_LAMBDAS: tuple = (0, 0.1, 1, 10, "inf")
#: Data conditions built from the public depth images.
DEPTH_CONDITIONS: tuple[str, ...] = ("depth-sequence", "depth-image")
#: Key frames per sample (the paper's 5).
N_KEY_FRAMES = 5

TABLE_FILE = "fabric_table1.csv"
RUNS_FILE = "fabric_runs.csv"
FIGURE_FILE = "fabric_lambda.png"
MANIFEST_FILE = "fabric_manifest.json"
ESZSL_METHOD = "ESZSL"
_PAPER_ROWS = ("Flat", "Fold", "Rand")
_PAPER_CONFIG = 1


# ---------------------------------------------------------------------------------------------
# samples
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class FabricSamples:
    """Samples of one data condition.

    Attributes
    ----------
    condition : str
        Row name in the table (``depth-sequence``, ``depth-image``, ``gelsight-<folder>``).
    unit : str
        What one sample is (recorded in the table).
    X : ndarray of shape (n_samples, n_features), float64
        Descriptors (dimensionless texture statistics; see :class:`TextureDescriptor`).
    groups : ndarray of shape (n_samples,), int64
        Fabric group (class) of each sample, 0..7.
    samples : DataFrame
        One row per sample: fabric_id, fabric_name, group and the source (image ids or video).
    paper_row : str or None
        Row of the paper's Table 1 printed beside this condition.
    """

    condition: str
    unit: str
    X: np.ndarray
    groups: np.ndarray
    samples: pd.DataFrame
    paper_row: str | None


def lambda_label(lam) -> str:
    """Column label of a paper lambda: ``0 -> "0"``, ``0.1 -> "0.1"``, ``"inf" -> "inf"``."""
    w_c, _ = loss_weights(lam)
    if w_c == 0.0:
        return "inf"
    return f"{float(lam):g}"


def _method_names(lams: Sequence) -> list[str]:
    return [f"lam_{lambda_label(lam)}" for lam in lams] + [ESZSL_METHOD]


def _paper_key(method: str) -> str:
    return ESZSL_METHOD if method == ESZSL_METHOD else method[len("lam_"):]


def depth_sequence_rows(images: pd.DataFrame, n_frames: int = N_KEY_FRAMES) -> np.ndarray:
    """Positions of ``n_frames`` evenly spaced images of every fabric, in capture order.

    Parameters
    ----------
    images : DataFrame
        :attr:`tzsl.datasets.FabricData.images` (columns fabric_id, capture_index).
    n_frames : int
        Images per fabric (the paper's 5 key frames).

    Returns
    -------
    ndarray of shape (n_fabrics, n_frames), int64
        Row positions in ``images``; fabrics in ascending fabric_id, images at capture
        positions ``round(linspace(0, n - 1, n_frames))`` of a fabric's n images.

    Raises
    ------
    DataFileError
        A fabric has fewer than ``n_frames`` images.
    """
    order = np.lexsort((images["capture_index"].to_numpy(), images["fabric_id"].to_numpy()))
    fab = images["fabric_id"].to_numpy()[order]
    ids, starts, sizes = np.unique(fab, return_index=True, return_counts=True)
    short = ids[sizes < n_frames]
    if short.size:
        raise DataFileError(
            None,
            f"fabric(s) {short[:10].tolist()} have fewer than {n_frames} depth images; a "
            f"depth sequence needs {n_frames}",
        )
    frac = np.linspace(0.0, 1.0, n_frames)
    local = np.floor(frac[None, :] * (sizes[:, None] - 1) + 0.5).astype(np.int64)
    return order[starts[:, None] + local]


def _files_digest(paths: Sequence[str | os.PathLike]) -> str:
    """sha256 over every file's name and content sha256, in order (the cache key of the data)."""
    digest = hashlib.sha256()
    for p in paths:
        digest.update(Path(p).name.encode())
        digest.update(file_sha256(p).encode())
    return digest.hexdigest()


def _descriptor_params(descriptor: TextureDescriptor) -> dict:
    return {k: v for k, v in descriptor.get_params().items() if k != "n_jobs"}


def _describe_depth_files(digest: str, paths: list[str], params: dict, n_jobs: int | None) -> np.ndarray:
    """Descriptors of depth PNGs (the cached unit; ``paths`` and ``n_jobs`` are not in the key)."""
    images = read_depth_images(paths)
    desc = TextureDescriptor(**params, n_jobs=n_jobs).fit(images[:1])
    return desc.transform(images)


def _memory(cache_dir) -> joblib.Memory:
    return joblib.Memory(str(get_cache_dir(cache_dir)), verbose=0)


def depth_image_descriptors(
    fabric: FabricData,
    descriptor: TextureDescriptor | None = None,
    *,
    cache_dir=None,
    n_jobs: int | None = 1,
    progress: bool = False,
) -> np.ndarray:
    """Texture descriptors of every depth image, cached on disk.

    Parameters
    ----------
    fabric : FabricData
        From :func:`tzsl.datasets.load_fabric` (with images).
    descriptor : TextureDescriptor or None
        Descriptor parameters (default: ``TextureDescriptor()``); its ``n_jobs`` is ignored.
    cache_dir : str, path or None
        Cache folder (default :func:`tzsl.datasets.get_cache_dir`).
    n_jobs : int or None
        joblib workers for a cold computation.
    progress : bool
        Say on stderr when the descriptors are computed rather than read from the cache.

    Returns
    -------
    ndarray of shape (n_images, d), float64
        Rows in the order of ``fabric.images``; ``d = 99`` for the default descriptor.
    """
    params = _descriptor_params(descriptor if descriptor is not None else TextureDescriptor())
    paths = fabric.images["path"].tolist()
    if not paths:
        raise ConfigError("the fabric data has no image table; load it with images=True")
    digest = _files_digest(paths)
    cached = _memory(cache_dir).cache(_describe_depth_files, ignore=["paths", "n_jobs"])
    if progress and not cached.check_call_in_cache(digest, paths, params, n_jobs):
        from tqdm.auto import tqdm

        tqdm.write(f"computing texture descriptors of {len(paths)} depth images (cached afterwards)")
    return cached(digest, paths, params, n_jobs)


def depth_samples(
    fabric: FabricData, descriptors: np.ndarray, n_frames: int = N_KEY_FRAMES
) -> tuple[FabricSamples, FabricSamples]:
    """The ``depth-sequence`` and ``depth-image`` samples (see the module docstring).

    Parameters
    ----------
    fabric : FabricData
    descriptors : ndarray of shape (n_images, d)
        :func:`depth_image_descriptors` (rows in ``fabric.images`` order).
    n_frames : int
        Images per sequence sample.

    Returns
    -------
    (sequence, image) : tuple of FabricSamples
        ``sequence.X`` has shape (n_fabrics, n_frames * d), ``image.X`` (n_images, d).
    """
    images = fabric.images
    descriptors = np.asarray(descriptors, dtype=np.float64)
    if descriptors.ndim != 2 or descriptors.shape[0] != len(images):
        raise ConfigError(
            f"descriptors must have shape ({len(images)}, d) (one row per depth image); "
            f"got {descriptors.shape}"
        )
    groups = images["group"].to_numpy(dtype=np.int64)
    rows = depth_sequence_rows(images, n_frames)
    first = images.iloc[rows[:, 0]]
    image_ids = images["image_id"].to_numpy()[rows]
    seq_table = pd.DataFrame(
        {
            "fabric_id": first["fabric_id"].to_numpy(),
            "fabric_name": first["fabric_name"].to_numpy(),
            "group": first["group"].to_numpy(),
            "image_ids": [" ".join(map(str, r)) for r in image_ids],
        }
    )
    sequence = FabricSamples(
        condition="depth-sequence",
        unit=f"fabric: {n_frames} evenly spaced depth images in capture order, descriptors concatenated",
        X=descriptors[rows].reshape(rows.shape[0], -1),
        groups=groups[rows[:, 0]],
        samples=seq_table,
        paper_row="Average",
    )
    image = FabricSamples(
        condition="depth-image",
        unit="depth image",
        X=descriptors,
        groups=groups,
        samples=images[["image_id", "fabric_id", "fabric_name", "group"]].reset_index(drop=True),
        paper_row="Average",
    )
    return sequence, image


def _shrink(frames: np.ndarray, max_side: int | None) -> np.ndarray:
    """(k, H, W) -> (k, h, w) with ``max(h, w) <= max_side`` (anti-aliased resize)."""
    if max_side is None or max(frames.shape[1:]) <= max_side:
        return frames
    from skimage.transform import resize

    scale = max_side / max(frames.shape[1:])
    shape = tuple(max(2, round(s * scale)) for s in frames.shape[1:])
    return np.stack([resize(f, shape, anti_aliasing=True, preserve_range=True) for f in frames])


def _describe_video(
    digest: str, path: str, selector_params: dict, descriptor_params: dict, max_side: int | None
) -> tuple[np.ndarray, np.ndarray]:
    """Key-frame indices (5,) and concatenated descriptors (5 d,) of one video (cached unit)."""
    key = KeyFrameSelector(**selector_params).select_one(path)
    frames = _shrink(key.frames, max_side)
    desc = TextureDescriptor(**descriptor_params).fit(frames[None])
    return key.indices, desc.transform(frames[None])[0]


def gelsight_samples(
    root: str | os.PathLike,
    *,
    conditions: Sequence[str] | None = None,
    n_groups: int = 8,
    selector: KeyFrameSelector | None = None,
    descriptor: TextureDescriptor | None = None,
    max_side: int | None = 224,
    cache_dir=None,
    n_jobs: int | None = 1,
    progress: bool = False,
) -> list[FabricSamples]:
    """One :class:`FabricSamples` per condition folder of user-supplied GelSight videos.

    Parameters
    ----------
    root : str or path-like
        Layout of :func:`tzsl.datasets.load_gelsight_fabric_videos`.
    conditions : sequence of str or None
        Condition folders (None: all).
    n_groups : int
        Groups in ``root/fabric_groups.csv`` must lie in ``0 .. n_groups - 1`` (the rows of
        the attribute matrix).
    selector : KeyFrameSelector or None
        Key-frame parameters (default: the paper's, ``KeyFrameSelector()``); ``as_gray`` is
        always set.
    descriptor : TextureDescriptor or None
        Descriptor parameters (default ``TextureDescriptor()``).
    max_side : int or None
        Key frames are resized so their longer side is at most this many pixels (None: keep).
    cache_dir, n_jobs, progress
        As in :func:`depth_image_descriptors`; videos are spread over ``n_jobs`` workers.

    Returns
    -------
    list of FabricSamples
        ``X`` of shape (n_videos, 5 d); ``samples`` lists each video's path and key-frame
        indices.

    Raises
    ------
    DataFileError
        Groups outside ``0 .. n_groups - 1``; a video without a detectable press or too short.
    """
    videos = load_gelsight_fabric_videos(root, conditions)
    bad = sorted(set(videos.loc[(videos["group"] < 0) | (videos["group"] >= n_groups), "group"]))
    if bad:
        raise DataFileError(
            Path(root) / "fabric_groups.csv",
            f"groups {bad[:10]} are outside 0..{n_groups - 1}, the rows of the attribute matrix",
        )
    sel = selector if selector is not None else KeyFrameSelector()
    sel_params = {**sel.get_params(), "as_gray": True}
    desc_params = _descriptor_params(descriptor if descriptor is not None else TextureDescriptor())
    cached = _memory(cache_dir).cache(_describe_video, ignore=["path"])
    paths = videos["path"].tolist()
    if progress:
        from tqdm.auto import tqdm

        tqdm.write(f"key frames and descriptors of {len(paths)} GelSight videos (cached afterwards)")
    results = Parallel(n_jobs=n_jobs)(
        delayed(cached)(file_sha256(p), p, sel_params, desc_params, max_side) for p in paths
    )
    lengths = {r[1].shape[0] for r in results}
    if len(lengths) > 1:
        raise DataFileError(Path(root), f"videos give descriptors of different lengths {sorted(lengths)}")
    table = videos.assign(key_frames=[" ".join(map(str, r[0])) for r in results])
    X_all = np.stack([r[1] for r in results])
    out = []
    for cond, rows in table.groupby("condition", sort=False):
        pos = rows.index.to_numpy()
        out.append(
            FabricSamples(
                condition=f"gelsight-{cond}",
                unit="GelSight press video: 5 key frames (paper's rule), descriptors concatenated",
                X=X_all[pos],
                groups=rows["group"].to_numpy(dtype=np.int64),
                samples=rows.reset_index(drop=True),
                paper_row=cond if cond in _PAPER_ROWS else None,
            )
        )
    return out


# ---------------------------------------------------------------------------------------------
# fitting
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class ZeroShotRun:
    """One zero-shot fit and its predictions.

    Attributes
    ----------
    model : object
        The fitted model (``predict(X, class_attributes)`` -> row indices).
    train_classes : ndarray (k_train,)
        Groups whose samples and attribute rows were given to ``fit`` (sorted).
    test_classes : ndarray (k_test,)
        Candidate groups at prediction time (the split's test groups).
    y_true, y_pred : ndarray (n_test,)
        True and predicted group of every test sample.
    """

    model: object
    train_classes: np.ndarray
    test_classes: np.ndarray
    y_true: np.ndarray
    y_pred: np.ndarray

    @property
    def accuracy(self) -> float:
        """Fraction of test samples recognised."""
        return trial_accuracy(self.y_true, self.y_pred)

    @property
    def per_class_mean_accuracy(self) -> float:
        """Mean over test groups of each group's accuracy."""
        return per_class_mean_accuracy(self.y_true, self.y_pred)


def zero_shot_run(
    fit_model: Callable[[np.ndarray, np.ndarray, np.ndarray], object],
    X: np.ndarray,
    groups: np.ndarray,
    attribute_matrix: np.ndarray,
    split: FabricSplit,
) -> ZeroShotRun:
    """Fit on the training groups of ``split`` only; recognise test samples among the test groups.

    Parameters
    ----------
    fit_model : callable
        ``fit_model(X_train, y_train, S_train) -> fitted model``: ``X_train`` (n_train, d) and
        ``y_train`` (n_train,) are the training-group samples, ``S_train`` (k_train, m) the
        attribute rows of ``np.unique(y_train)``. Test samples and test attribute rows are never
        passed to it.
    X : ndarray of shape (n_samples, d)
    groups : ndarray of shape (n_samples,), int
        Group of every sample.
    attribute_matrix : ndarray of shape (n_groups, m)
        Group x attribute matrix (row g = group g).
    split : FabricSplit

    Returns
    -------
    ZeroShotRun

    Raises
    ------
    ConfigError
        No training or no test sample.
    """
    X = np.asarray(X)
    groups = np.asarray(groups)
    A = np.asarray(attribute_matrix, dtype=np.float64)
    train, test = split.is_train(groups), split.is_test(groups)
    if not train.any() or not test.any():
        raise ConfigError(
            f"fabric config {split.config}: {int(train.sum())} training and {int(test.sum())} test "
            f"samples (train groups {list(split.train_groups)}, test groups {list(split.test_groups)}); "
            "both must be non-empty"
        )
    train_classes = np.unique(groups[train])
    model = fit_model(X[train], groups[train], A[train_classes])
    test_classes = np.asarray(split.test_groups)
    rows = model.predict(X[test], A[test_classes])
    return ZeroShotRun(
        model=model,
        train_classes=train_classes,
        test_classes=test_classes,
        y_true=groups[test],
        y_pred=test_classes[np.asarray(rows)],
    )


def _run_job(
    samples_X: np.ndarray,
    groups: np.ndarray,
    A: np.ndarray,
    split: FabricSplit,
    method: str,
    lam,
    seed: int | None,
    alphas: tuple[float, ...],
    max_iter: int,
) -> dict:
    """One fit (method x seed) on one condition and split; returns a row of the runs table."""
    info: dict = {}

    def fit_embedding(X_tr, y_tr, S_tr):
        alpha, scores = select_embedding_alpha(
            X_tr, y_tr, S_tr, lam=lam, alphas=alphas, random_state=seed, max_iter=max_iter
        )
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", ConvergenceWarning)
            model = EmbeddingZSL(
                lam=lam, alpha=alpha, early_stopping=False, max_iter=max_iter,
                duplicate_attributes="merge", random_state=seed,
            ).fit(X_tr, y_tr, S_tr)
        info.update(
            alpha=alpha,
            cv_score=np.nan if scores is None else float(scores.mean(axis=1).max()),
            n_iter=model.n_iter_,
            converged=not any(issubclass(w.category, ConvergenceWarning) for w in caught),
        )
        return model

    def fit_eszsl(X_tr, y_tr, S_tr):
        model = ESZSLCV(duplicate_attributes="merge").fit(X_tr, y_tr, S_tr)
        info.update(gamma=model.best_gamma_, eszsl_lam=model.best_lam_, cv_score=model.best_score_)
        return model

    with threadpool_limits(limits=1):  # many small fits: one BLAS thread each, parallel over fits
        run = zero_shot_run(
            fit_eszsl if method == ESZSL_METHOD else fit_embedding, samples_X, groups, A, split
        )
    pred = pd.Series(run.y_pred).value_counts().reindex(run.test_classes, fill_value=0)
    return {
        "method": method,
        "seed": seed,
        "accuracy": run.accuracy,
        "per_class_mean_accuracy": run.per_class_mean_accuracy,
        "n_train": int(split.is_train(groups).sum()),
        "n_test": int(run.y_true.size),
        "train_classes": " ".join(map(str, run.train_classes)),
        "predicted_counts": " ".join(f"{g}:{c}" for g, c in pred.items()),
        **info,
    }


# ---------------------------------------------------------------------------------------------
# table, figure, text
# ---------------------------------------------------------------------------------------------
def _note(samples: FabricSamples, config: int, duplicates: list[tuple[int, ...]], attributes: str) -> str:
    parts = []
    if samples.condition.startswith("depth"):
        parts.append("public depth images, not the paper's GelSight videos")
    if config != _PAPER_CONFIG:
        parts.append(f"the paper reports config {_PAPER_CONFIG} only: no paper numbers")
    elif samples.paper_row == "Average":
        parts.append("paper columns = the paper's Average row over its GelSight Flat/Fold/Rand videos "
                     "(CNN+LSTM), for orientation only")
    elif samples.paper_row is not None:
        parts.append(f"paper columns = the paper's {samples.paper_row} row")
    else:
        parts.append("no paper row of this name")
    parts.append("lam_inf = regression term R only (the paper's caption says C only; see EmbeddingZSL)")
    if duplicates:
        dup = "; ".join(",".join(map(str, d)) for d in duplicates)
        parts.append(f"{attributes}: groups {dup} share one attribute vector (merged in training)")
    return "; ".join(parts)


def fabric_table(runs: pd.DataFrame, lams: Sequence = PAPER_LAMBDAS) -> pd.DataFrame:
    """Aggregate the runs into the Table 1 analogue.

    Parameters
    ----------
    runs : DataFrame
        ``fabric_runs.csv`` (one row per fit) with the per-row columns condition, config,
        unit, test_groups, paper_row, note, n_train, n_test, method, seed, accuracy,
        per_class_mean_accuracy.
    lams : sequence
        The lambdas run (column order).

    Returns
    -------
    DataFrame
        One row per (condition, config), in run order. Columns: condition, config, unit,
        test_groups, n_train, n_test, chance (1 / number of test groups), n_seeds; for each
        method M in ``lam_<lambda>...`` and ``ESZSL``: ``M`` (mean accuracy over seeds),
        ``M_std`` (sample std over seeds, ddof=1; NaN for one seed; 0 for the deterministic
        ESZSL), ``M_pcma`` and ``M_pcma_std`` (per-class mean accuracy); ``paper_M`` (the
        paper's Table 1 number for ``paper_row``, NaN where it has none); paper_row, note.
        Accuracies are fractions in [0, 1].
    """
    methods = _method_names(lams)
    keys = ["condition", "config"]
    rows = []
    for (cond, config), sub in runs.groupby(keys, sort=False):
        first = sub.iloc[0]
        n_test_groups = len(str(first["test_groups"]).split())
        row = {
            "condition": cond,
            "config": int(config),
            "unit": first["unit"],
            "test_groups": first["test_groups"],
            "n_train": int(first["n_train"]),
            "n_test": int(first["n_test"]),
            "chance": 1.0 / n_test_groups,
            "n_seeds": int(sub.loc[sub["method"] != ESZSL_METHOD, "seed"].nunique()),
        }
        stats = {}
        for m in methods:
            got = sub.loc[sub["method"] == m, ["accuracy", "per_class_mean_accuracy"]].reset_index(drop=True)
            summary = summarise_over_splits(got) if len(got) else None  # rows mean, std over seeds
            for metric, suffix in (("accuracy", ""), ("per_class_mean_accuracy", "_pcma")):
                stats[f"{m}{suffix}"] = np.nan if summary is None else float(summary.loc["mean", metric])
                if m == ESZSL_METHOD:
                    std = 0.0 if len(got) else np.nan  # deterministic: identical for every seed
                else:
                    std = float(summary.loc["std", metric]) if len(got) > 1 else np.nan
                stats[f"{m}{suffix}_std"] = std
        for m in methods:
            row[m] = stats[m]
        for m in methods:
            row[f"{m}_std"] = stats[f"{m}_std"]
        for m in methods:
            row[f"{m}_pcma"] = stats[f"{m}_pcma"]
        for m in methods:
            row[f"{m}_pcma_std"] = stats[f"{m}_pcma_std"]
        paper_row = first["paper_row"] if isinstance(first["paper_row"], str) and first["paper_row"] else None
        for m in methods:
            value = np.nan
            if paper_row is not None and int(config) == _PAPER_CONFIG:
                value = FABRIC_TABLE1[paper_row].get(_paper_key(m), np.nan)
            row[f"paper_{m}"] = value
        row["paper_row"] = paper_row if (paper_row and int(config) == _PAPER_CONFIG) else ""
        row["note"] = first["note"]
        rows.append(row)
    return pd.DataFrame(rows)


def format_fabric_table(table: pd.DataFrame) -> str:
    """Plain-text table: per method ``mean±std [paper]`` (accuracy in percent)."""
    methods = [c for c in table.columns if f"paper_{c}" in table.columns]
    n_seeds = int(table["n_seeds"].max()) if len(table) else 0
    head = ["condition", "cfg", "test", "n_test", "chance"] + [
        "ESZSL" if m == ESZSL_METHOD else f"lam={m[len('lam_'):]}" for m in methods
    ]
    lines = []
    for _, r in table.iterrows():
        cells = [str(r["condition"]), str(r["config"]), str(r["test_groups"]).replace(" ", ","),
                 str(r["n_test"]), f"{100 * r['chance']:.1f}"]
        for m in methods:
            mean, std, paper = r[m], r[f"{m}_std"], r[f"paper_{m}"]
            cell = f"{100 * mean:.1f}" + ("" if pd.isna(std) else f"±{100 * std:.1f}")
            if not pd.isna(paper):
                cell += f" [{100 * paper:.2f}]"  # the paper prints two decimals
            cells.append(cell)
        lines.append(cells)
    widths = [max(len(h), *(len(c[i]) for c in lines)) for i, h in enumerate(head)] if lines else [len(h) for h in head]
    fmt = lambda cells: "  ".join(c.ljust(w) for c, w in zip(cells, widths))  # noqa: E731
    out = [
        f"Fabric zero-shot accuracy (%) on unseen groups: ours mean±std over {n_seeds} seed(s), "
        "[paper Table 1] beside (GelSight videos; Average row beside depth rows)",
        fmt(head),
        fmt(["-" * w for w in widths]),
    ]
    out += [fmt(c) for c in lines]
    out.append("lam=inf: regression term R only (documented deviation from the paper's caption). "
               "Per-class mean accuracy and notes: fabric_table1.csv.")
    return "\n".join(out)


def fabric_lambda_figure(table: pd.DataFrame, lams: Sequence = PAPER_LAMBDAS):
    """Accuracy vs lambda, ours (mean ± std over seeds) and the paper's (its Fig. 6).

    One panel per split config; ESZSL as a separate point right of the lambda axis; the
    paper's Flat / Fold / Rand / Average rows (config 1 panel only) as dashed lines.

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    methods = _method_names(lams)
    labels = [lambda_label(lam) for lam in lams]
    x = np.arange(len(lams))
    x_es = len(lams) + 0.5
    configs = list(dict.fromkeys(table["config"].tolist()))
    fig, axes = plt.subplots(1, len(configs), figsize=(6 * len(configs), 4.5), sharey=True, squeeze=False)
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for ax, config in zip(axes[0], configs):
        sub = table[table["config"] == config]
        for i, (_, r) in enumerate(sub.iterrows()):
            c = colours[i % len(colours)]
            mean = r[methods[:-1]].to_numpy(dtype=float)
            std = np.nan_to_num(r[[f"{m}_std" for m in methods[:-1]]].to_numpy(dtype=float))
            ax.errorbar(x, mean, yerr=std, color=c, marker="o", capsize=3, label=f"{r['condition']} (ours)")
            ax.plot([x_es], [r[ESZSL_METHOD]], color=c, marker="s", ls="none")
        if config == _PAPER_CONFIG:
            greys = {"Flat": "0.25", "Fold": "0.45", "Rand": "0.6", "Average": "0.0"}
            for row, grey in greys.items():
                vals = [FABRIC_TABLE1[row][_paper_key(m)] for m in methods]
                ax.plot(x, vals[:-1], color=grey, ls="--", marker="x", label=f"paper {row}")
                ax.plot([x_es], [vals[-1]], color=grey, marker="x", ls="none")
        chance = sub["chance"].iloc[0]
        ax.axhline(chance, color="red", lw=0.8, ls=":", label=f"chance ({chance:.2f})")
        ax.set_xticks(list(x) + [x_es], labels + ["ESZSL"])
        ax.set_xlabel("lambda (loss C + lambda R; inf = R only)")
        test = str(sub["test_groups"].iloc[0]).replace(" ", ", ")
        ax.set_title(f"config {config}: test groups {test}")
        ax.set_ylim(0, 1)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=3)
    axes[0][0].set_ylabel("zero-shot accuracy on unseen groups")
    fig.tight_layout()
    return fig


# ---------------------------------------------------------------------------------------------
# the study
# ---------------------------------------------------------------------------------------------
def _check_seeds(seeds) -> int:
    if isinstance(seeds, bool) or not isinstance(seeds, (int, np.integer)) or seeds < 1:
        raise ConfigError(f"seeds must be an integer >= 1; got {seeds!r}")
    return int(seeds)


def run_fabric_study(
    out: ResultsDir,
    data_dir=None,
    seeds: int = 5,
    configs: Sequence[int] = (1, 2),
    gelsight_root=None,
    attributes: str = "a8",
    progress: bool = True,
    *,
    lams: Sequence = PAPER_LAMBDAS,
    alphas: Sequence[float] = DEFAULT_ALPHAS,
    conditions: Sequence[str] = DEPTH_CONDITIONS,
    gelsight_conditions: Sequence[str] | None = None,
    seed: int = 0,
    max_iter: int = 500,
    n_jobs: int | None = 1,
    cache_dir=None,
) -> dict[str, pd.DataFrame]:
    """Run the fabric study and write its table, runs, figure and manifest.

    Parameters
    ----------
    out : ResultsDir
        Output folder; existing outputs are refused unless ``out.force`` (checked before
        any computation).
    data_dir : str, path or None
        Data home with ``fabric/`` (see :func:`tzsl.datasets.get_data_home`).
    seeds : int
        Seeds of the embedding model: ``seed, seed + 1, ..., seed + seeds - 1``.
    configs : sequence of {1, 2}
        Zero-shot splits (:func:`tzsl.datasets.fabric_zsl_split`).
    gelsight_root : str, path or None
        User GelSight videos (adds ``gelsight-<condition>`` rows).
    attributes : str
        Group x attribute matrix (key of :data:`tzsl.datasets.FABRIC_ATTRIBUTE_SETS`).
    progress : bool
        Progress bar and messages on stderr.
    lams : sequence
        Lambdas of the embedding model (default the paper's five).
    alphas : sequence of float
        Weight-decay grid of the embedding model (see :func:`select_embedding_alpha`).
    conditions : sequence of str
        Depth conditions to run, a subset of :data:`DEPTH_CONDITIONS` (may be empty with
        ``gelsight_root``).
    gelsight_conditions : sequence of str or None
        Condition folders of ``gelsight_root`` (None: all).
    seed : int
        First seed.
    max_iter : int
        L-BFGS iterations of each embedding fit.
    n_jobs : int or None
        joblib workers (descriptors and fits).
    cache_dir : str, path or None
        Descriptor cache (default :func:`tzsl.datasets.get_cache_dir`).

    Returns
    -------
    dict of str -> DataFrame
        ``"table1"`` (:func:`fabric_table`) and ``"runs"`` (one row per fit: condition,
        config, method, seed, accuracy, per_class_mean_accuracy, chosen hyper-parameters,
        predicted counts per test group).
    """
    seeds = _check_seeds(seeds)
    configs = [int(c) for c in configs]
    if not configs:
        raise ConfigError("configs is empty; choose from 1, 2")
    lams = list(lams)
    if not lams:
        raise ConfigError("lams is empty; choose from 0, 0.1, 1, 10, inf")
    labels = [lambda_label(lam) for lam in lams]  # validates
    if len(set(labels)) != len(labels):
        raise ConfigError(f"lams has repeated values: {lams}")
    conditions = list(conditions)
    unknown = [c for c in conditions if c not in DEPTH_CONDITIONS]
    if unknown:
        raise ConfigError(f"unknown depth condition(s) {unknown}; choose from {list(DEPTH_CONDITIONS)}")
    if not conditions and gelsight_root is None:
        raise ConfigError("nothing to run: no depth condition and no --gelsight-root")
    out.check_free([TABLE_FILE, RUNS_FILE, FIGURE_FILE, MANIFEST_FILE])

    with warnings.catch_warnings():
        # duplicate attribute vectors are expected (a8: groups 3, 4, 5); recorded in the note
        warnings.filterwarnings("ignore", message="fabric attribute matrix", category=UserWarning)
        fabric = load_fabric(data_dir, attributes, images=bool(conditions))
    A = fabric.attributes.to_numpy(dtype=np.float64)
    splits = {c: fabric_zsl_split(c, A) for c in configs}

    samples: list[FabricSamples] = []
    digests: dict[str, str] = {}
    gel: list[FabricSamples] = []
    if gelsight_root is not None:  # first: a wrong folder fails before the depth descriptors
        gel = gelsight_samples(
            gelsight_root, conditions=gelsight_conditions, n_groups=A.shape[0],
            cache_dir=cache_dir, n_jobs=n_jobs, progress=progress,
        )
        digests["gelsight_videos_sha256"] = _files_digest(
            [p for s in gel for p in s.samples["path"].tolist()]
        )
    if conditions:
        desc = depth_image_descriptors(fabric, cache_dir=cache_dir, n_jobs=n_jobs, progress=progress)
        digests["depth_images_sha256"] = _files_digest(fabric.images["path"].tolist())
        seq, img = depth_samples(fabric, desc)
        samples += [s for s in (seq, img) if s.condition in conditions]
    samples += gel

    seed_list = list(range(int(seed), int(seed) + seeds))
    jobs, meta = [], []
    for s in samples:
        for config in configs:
            split = splits[config]
            row_meta = {
                "condition": s.condition,
                "config": config,
                "unit": s.unit,
                "test_groups": " ".join(map(str, split.test_groups)),
                "paper_row": s.paper_row or "",
                "note": _note(s, config, fabric.duplicate_groups, attributes),
            }
            for lam, label in zip(lams, labels):
                for sd in seed_list:
                    jobs.append(delayed(_run_job)(s.X, s.groups, A, split, f"lam_{label}", lam, sd,
                                                  tuple(alphas), max_iter))
                    meta.append(row_meta)
            jobs.append(delayed(_run_job)(s.X, s.groups, A, split, ESZSL_METHOD, None, None, (), max_iter))
            meta.append(row_meta)

    from tqdm.auto import tqdm

    results = Parallel(n_jobs=n_jobs, return_as="generator")(jobs)
    rows = [
        {**m, **r}
        for m, r in zip(meta, tqdm(results, total=len(jobs), desc="fabric fits", disable=not progress))
    ]
    runs = pd.DataFrame(rows)
    runs["seed"] = runs["seed"].astype("Int64")
    for col in ("alpha", "gamma", "eszsl_lam", "cv_score", "n_iter", "converged"):
        if col not in runs.columns:
            runs[col] = np.nan
    table = fabric_table(runs, lams)

    out.write_csv(TABLE_FILE, table)
    out.write_csv(RUNS_FILE, runs)
    out.write_figure(FIGURE_FILE, fabric_lambda_figure(table, lams))
    config = {
        "study": "fabric zero-shot (F18)",
        "attributes": attributes,
        "configs": {c: {"train": list(splits[c].train_groups), "test": list(splits[c].test_groups)} for c in configs},
        "conditions": [s.condition for s in samples],
        "units": {s.condition: s.unit for s in samples},
        "n_samples": {s.condition: int(s.X.shape[0]) for s in samples},
        "n_features": {s.condition: int(s.X.shape[1]) for s in samples},
        "lams": labels,
        "alphas": [float(a) for a in alphas],
        "seeds": seed_list,
        "max_iter": max_iter,
        "embedding": "EmbeddingZSL(hidden_units=None, early_stopping=False, duplicate_attributes='merge'), "
                     "alpha by class-grouped CV on training groups",
        "eszsl": "ESZSLCV(default grids 1e-3..1e3, class-grouped CV, duplicate_attributes='merge')",
        "descriptor": _descriptor_params(TextureDescriptor()),
        "key_frames": N_KEY_FRAMES,
        "gelsight_root": None if gelsight_root is None else str(gelsight_root),
        "duplicate_groups": [list(d) for d in fabric.duplicate_groups],
        "n_jobs": n_jobs,
    }
    data_files = [fabric.root / "fabric_groups.csv", fabric.root / FABRIC_ATTRIBUTE_SETS[attributes][0]]
    out.write_manifest(config, [p for p in data_files if p.is_file()], name=MANIFEST_FILE, extra=digests)
    return {"table1": table, "runs": runs}
