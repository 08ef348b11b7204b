"""The fabric paper's CNN + LSTM (F17) on PhysiCLeAR's GelSight videos of unseen objects.

``study = "fabric-deep"`` with ``[dataset] builtin = "physiclear"`` (``tzsl train-deep --dataset physiclear``):

* **Sequences**: every registered video of the class table's objects gives one sequence of its 5 contact key
  frames, each as its *imprint*, the grey key frame minus the grey first frame
  (:func:`tzsl.datasets.physiclear_key_frames`: the same key frames and imprints the texture descriptors of the
  built-in ``physiclear`` dataset are computed from; the imprint removes the sensor's own illumination
  pattern, which every video shares). Frames of shape (5, 240, 320), float32 in [-1, 1]; the model resizes
  them to its ``image_size`` and repeats the grey channel for a pretrained backbone. A video without a contact
  to take key frames from is left out with one warning line, as the conversion does.
* **Attributes**: the shipped class-attribute table in its default encoding
  (:func:`tzsl.datasets.read_physiclear_attributes`, ``"levels"``: one 0/1 attribute per rank level, plus the
  materials of at least 3 objects), restricted to the attributes the zero-shot study's default rule keeps for
  the training objects (:func:`tzsl.datasets.physiclear_kept_attributes`: at least 3 positive and
  one negative training object).
* **Split**: the paper's object split (:func:`tzsl.datasets.physiclear_split_roles`). The network is fitted on
  the *training* objects only, in two protocols: ``validation`` scores the validation objects (for choosing
  lambda: the ``chosen_on_validation`` column marks the lambda of the best validation per-class mean accuracy)
  and ``test`` scores the test objects, the unseen classes reported. (The split file's ``physiclear-test``
  split of the zero-shot study trains on training and validation objects; here the validation objects are
  never fitted.) A test object whose attribute row repeats an earlier one's is left out
  (:func:`tzsl.datasets.physiclear_distinct_objects`); training objects that share a row are one class
  (``duplicate_attributes="merge"``).

The tables are the fabric-deep study's (``fabric_deep_runs.csv``, ``fabric_deep_table.csv``), one row per
protocol and lambda, condition ``physiclear-keyframes``: trial and per-class mean accuracy on the protocol's
objects with the bootstrap 95% interval over seeds and test objects (each with all its videos) and ``chance``
= 1 / number of test objects (:func:`tzsl.evaluation.add_trust_columns`).
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from tzsl.datasets import PhysiclearTable, read_physiclear_attributes
from tzsl.evaluation import Outcomes, per_class_mean_accuracy, trial_accuracy
from tzsl.exceptions import ConfigError, DataFileError
from tzsl.models import DeepAttributeEmbedding
from tzsl.studies.config import FabricDeepStudy
from tzsl.studies.fabric.deep import DEEP_RUNS_FILE, DEEP_TABLE_FILE, FrameSequences, deep_table
from tzsl.studies.fabric.tables import lambda_label

__all__ = ["PHYSICLEAR_CONDITION", "PhysiclearFit", "PhysiclearProtocol", "format_physiclear_deep_table",
           "physiclear_protocols", "physiclear_sequences", "run_deep_physiclear", "run_deep_physiclear_study"]

#: The ``condition`` of the study's rows.
PHYSICLEAR_CONDITION = "physiclear-keyframes"


def physiclear_sequences(data_dir: str | os.PathLike | None = None, *, table: PhysiclearTable | None = None,
                         progress: bool = False) -> FrameSequences:
    """The key-frame imprints of every registered video of the table's objects (module docstring).

    Parameters
    ----------
    data_dir : path-like, optional
        Data home holding the videos (``tzsl data fetch physiclear``).
    table : PhysiclearTable, optional
        Default: the shipped one (:func:`tzsl.datasets.read_physiclear_attributes`).
    progress : bool, default False
        A progress bar over the videos.

    Returns
    -------
    FrameSequences
        ``frames`` of shape (n_videos, 5, H, W), float32; ``table`` with ``trial_id``, ``object``, ``take``,
        ``path`` and ``frame_index`` (the key frames' 0-based indices); ``source`` ``"physiclear"``.

    Raises
    ------
    DataMissingError, ChecksumError
        A registered video missing from the data home or whose sha256 differs (one line).
    DataFileError
        A video that cannot be decoded, no video with a contact, or videos of different frame sizes.
    """
    from tzsl._progress import progress_bar  # noqa: PLC0415
    from tzsl.datasets import each_contact_video, fetch, physiclear_key_frames, physiclear_videos  # noqa: PLC0415

    videos = physiclear_videos(table or read_physiclear_attributes())
    paths = [fetch(r, data_dir) for r in videos["relpath"]]
    read, kept = each_contact_video(physiclear_key_frames, progress_bar(paths, show=progress, desc="key frames",
                                                                        unit="video", leave=False))
    frames = [images.astype(np.float32) for images, _ in read]
    keys = [index.tolist() for _, index in read]
    shapes = sorted({f.shape for f in frames})
    if len(shapes) > 1:
        raise DataFileError(None, f"physiclear videos have different frame shapes {shapes}; the deep model needs one")
    out = videos.iloc[kept].drop(columns="relpath").reset_index(drop=True)
    out["path"] = [str(paths[i]) for i in kept]
    out["frame_index"] = keys
    return FrameSequences(frames=np.stack(frames), table=out, source="physiclear")


@dataclass(frozen=True)
class PhysiclearProtocol:
    """One protocol of the study: fit on ``train``, score ``test`` among their rows over ``attributes``.

    Attributes
    ----------
    name : str
        ``"validation"`` or ``"test"``.
    train, test : tuple of str
        Objects.
    attributes : tuple of str
        Columns of the class-attribute table the network predicts.
    """

    name: str
    train: tuple[str, ...]
    test: tuple[str, ...]
    attributes: tuple[str, ...]


def physiclear_protocols(classes: pd.DataFrame, objects, roles: dict[str, list[str]] | None = None
                         ) -> list[PhysiclearProtocol]:
    """The ``validation`` and ``test`` protocols of the paper's split (module docstring).

    Parameters
    ----------
    classes : DataFrame (n_objects, n_attributes) of 0/1
        The class-attribute table, indexed by object.
    objects : array-like of str
        The objects that have sequences (others of the split are left out).
    roles : dict, optional
        ``train``, ``validation``, ``test`` -> objects (default: :func:`tzsl.datasets.physiclear_split_roles`).

    Returns
    -------
    list of PhysiclearProtocol
        ``validation`` then ``test``.

    Raises
    ------
    ConfigError
        No training object, fewer than 2 objects to score in a protocol, or no attribute kept.
    """
    from tzsl.datasets import (  # noqa: PLC0415
        physiclear_distinct_objects,
        physiclear_kept_attributes,
        physiclear_split_roles,
    )

    present = set(np.asarray(objects).tolist())
    roles = physiclear_split_roles() if roles is None else roles
    roles = {role: [o for o in objs if o in present and o in classes.index] for role, objs in roles.items()}
    train = roles["train"]
    attributes = physiclear_kept_attributes(classes, train) if train else []
    if not attributes:
        raise ConfigError(f"physiclear: {len(train)} training object(s) with videos keep no attribute "
                          "(each needs 3 positive and 1 negative training objects)")
    protocols = []
    for name in ("validation", "test"):
        test = physiclear_distinct_objects(classes, train, roles[name])
        if len(test) < 2:
            raise ConfigError(f"physiclear: {len(test)} {name} object(s) with videos and distinct attribute rows; "
                              "zero-shot scoring needs at least 2")
        protocols.append(PhysiclearProtocol(name, tuple(train), tuple(test), tuple(attributes)))
    return protocols


@dataclass
class PhysiclearFit:
    """One fit of :func:`run_deep_physiclear`.

    Attributes
    ----------
    model : DeepAttributeEmbedding
        Fitted.
    y_true, y_pred : ndarray of shape (n_test,), str
        True and predicted object of every scored video.
    train_accuracy : float
        Share of training videos whose predicted row, among the distinct training attribute rows, is their own.
    n_train : int
        Training videos.
    cpu_seconds, wall_seconds : float
        Process CPU time and wall time of the fit and the predictions.
    """

    model: DeepAttributeEmbedding
    y_true: np.ndarray
    y_pred: np.ndarray
    train_accuracy: float
    n_train: int
    cpu_seconds: float
    wall_seconds: float


def run_deep_physiclear(sequences: FrameSequences, classes: pd.DataFrame, protocol: PhysiclearProtocol,
                        model: DeepAttributeEmbedding) -> PhysiclearFit:
    """Fit ``model`` on the protocol's training videos and predict its test videos among the test objects.

    Parameters
    ----------
    sequences : FrameSequences
        From :func:`physiclear_sequences` (``table["object"]`` names each sequence's object).
    classes : DataFrame (n_objects, n_attributes)
        The class-attribute table.
    protocol : PhysiclearProtocol
    model : DeepAttributeEmbedding
        Unfitted; its ``duplicate_attributes`` is set to ``"merge"``.

    Returns
    -------
    PhysiclearFit
    """
    cpu, wall = time.process_time(), time.perf_counter()
    objects = sequences.table["object"].to_numpy(dtype=str)
    is_train, is_test = np.isin(objects, protocol.train), np.isin(objects, protocol.test)
    A = classes.loc[:, list(protocol.attributes)].astype(np.float64)
    train_objects = np.unique(objects[is_train])  # the model's classes_ order
    model.set_params(duplicate_attributes="merge")
    X_train = sequences.frames[is_train]
    model.fit(X_train, objects[is_train], A.loc[train_objects].to_numpy())
    S_train, row_of_object = np.unique(A.loc[train_objects].to_numpy(), axis=0, return_inverse=True)
    true_row = row_of_object.ravel()[np.searchsorted(train_objects, objects[is_train])]
    train_accuracy = float(np.mean(model.predict(X_train, S_train) == true_row))
    test_objects = np.asarray(protocol.test, dtype=str)
    y_pred = test_objects[model.predict(sequences.frames[is_test], A.loc[list(test_objects)].to_numpy())]
    return PhysiclearFit(model, objects[is_test], y_pred, train_accuracy, int(is_train.sum()),
                         time.process_time() - cpu, time.perf_counter() - wall)


def run_deep_physiclear_study(out, settings: FabricDeepStudy, *, data_dir=None, cache_dir=None, save_model=None,
                              record: dict | None = None) -> dict[str, pd.DataFrame]:
    """The deep model over the lambda grid on PhysiCLeAR (module docstring); the fabric-deep study's tables.

    Parameters
    ----------
    out : tzsl.studies.outputs.results_folder.ResultsDir
        Output folder; existing outputs are refused unless forced (checked first).
    settings : FabricDeepStudy
        ``[dataset] builtin = "physiclear"``; ``[methods]`` (``embedding_lambdas``, ``model``), ``[splits]``
        (``n_seeds`` seeds from ``seed``; ``configs`` is the fabric's and is not read), ``[compute] progress``.
    data_dir : str, path or None
        The data home holding ``physiclear/`` (default: ``[dataset] data_dir``).
    cache_dir : str, path or None
        Frozen-feature cache (default ``<tzsl cache dir>/deep-features``).
    save_model : str, path or None
        Save the network of the one fit (one lambda and seed; only the ``test`` protocol then runs) as a model
        bundle; refused when it exists unless ``out.force``.
    record : dict, optional
        Filled with the manifest's ``"fabric_deep"`` entry and ``"data_files"`` (the videos read).

    Returns
    -------
    dict of str -> DataFrame
        ``"runs"`` (one row per protocol, lambda and seed) and ``"table"`` (per protocol and lambda: means,
        ``*_ci95_low`` / ``*_ci95_high``, ``*_std``, ``chance``, ``chosen_on_validation``), written as
        ``fabric_deep_runs.csv`` and ``fabric_deep_table.csv``.
    """
    from tzsl.datasets import get_cache_dir  # noqa: PLC0415

    seeds = list(range(int(settings.splits.seed), int(settings.splits.seed) + int(settings.splits.n_seeds)))
    lams = list(settings.methods.embedding_lambdas)
    params = dict(settings.methods.model)
    params.setdefault("verbose", settings.compute.progress)
    DeepAttributeEmbedding(**params)._check_params()  # bad settings fail before any work
    out.check_free([DEEP_TABLE_FILE, DEEP_RUNS_FILE])
    if save_model is not None and Path(save_model).exists() and not out.force:
        raise ConfigError(f"{save_model} already exists; use --force to overwrite it")
    if save_model is not None and len(lams) * len(seeds) != 1:
        raise ConfigError("saving a model needs exactly one fit (one lambda and seed)")
    cache = Path(cache_dir) if cache_dir is not None else Path(get_cache_dir()) / "deep-features"
    data_dir = settings.dataset.data_dir if data_dir is None else data_dir

    table = read_physiclear_attributes()
    sequences = physiclear_sequences(data_dir, table=table, progress=settings.compute.progress)
    protocols = physiclear_protocols(table.classes, sequences.table["object"])
    if save_model is not None:  # the saved model is the test protocol's fit
        protocols = [p for p in protocols if p.name == "test"]
    keys = ["condition", "config", "protocol", "method"]
    outcomes = Outcomes(split_column="seed", by=keys)
    rows = []
    for proto in protocols:
        for lam in lams:
            for sd in seeds:
                model = DeepAttributeEmbedding(**{**params, "lam": lam, "random_state": sd,
                                                  "cache_dir": params.get("cache_dir", cache)})
                fit = run_deep_physiclear(sequences, table.classes, proto, model)
                key = {"condition": PHYSICLEAR_CONDITION, "config": "paper", "protocol": proto.name,
                       "method": f"lam_{lambda_label(lam)}"}
                correct = fit.y_true == fit.y_pred
                outcomes.add(sd, "accuracy", fit.y_true, correct, **key)
                outcomes.add(sd, "per_class_mean_accuracy", fit.y_true, correct, metric="class_mean", **key)
                m = fit.model
                rows.append({
                    **key, "zero_shot": True, "test_objects": " ".join(proto.test), "seed": sd,
                    "accuracy": trial_accuracy(fit.y_true, fit.y_pred),
                    "per_class_mean_accuracy": per_class_mean_accuracy(fit.y_true, fit.y_pred),
                    "train_accuracy": fit.train_accuracy, "n_train": fit.n_train, "n_test": len(fit.y_true),
                    "n_train_objects": len(proto.train), "n_test_objects": len(proto.test),
                    "n_attributes": len(proto.attributes), "epochs": m.n_epochs_,
                    "early_stopping": bool(m.early_stopping), "final_loss": m.loss_curve_[-1],
                    "seconds_per_epoch": float(np.mean(m.epoch_times_)) if m.epoch_times_ else float("nan"),
                    "feature_seconds": float(getattr(m, "feature_time_", 0.0)),
                    "cpu_seconds": fit.cpu_seconds, "wall_seconds": fit.wall_seconds,
                })
                if save_model is not None:
                    from tzsl.inference.deep_bundles import save_deep_bundle  # noqa: PLC0415

                    save_deep_bundle(m, save_model, force=out.force)
    runs = pd.DataFrame(rows)
    summary = deep_table(runs, outcomes, ["zero_shot", "test_objects"])
    summary["chosen_on_validation"] = summary["method"] == chosen_lambda(summary)
    out.write_csv(DEEP_RUNS_FILE, runs)
    out.write_csv(DEEP_TABLE_FILE, summary)
    if record is not None:  # the engine's manifest hashes every data file read
        record.update({"fabric_deep": {
            "study": "fabric-deep", "dataset": "physiclear", "seeds": seeds, "lams": [str(v) for v in lams],
            "protocols": {p.name: {"train": list(p.train), "test": list(p.test), "attributes": list(p.attributes)}
                          for p in protocols},
            "model_params": {k: str(v) for k, v in DeepAttributeEmbedding(**params).get_params().items()}},
            "data_files": [Path(p) for p in sequences.table["path"]]})
    return {"runs": runs, "table": summary}


def chosen_lambda(table: pd.DataFrame) -> str | None:
    """The ``method`` (lambda) of the best ``validation`` per-class mean accuracy (ties: the higher trial
    accuracy, then the first in the grid); None without validation rows."""
    validation = table[table["protocol"] == "validation"]
    if validation.empty:
        return None
    best = validation.sort_values(["per_class_mean_accuracy", "accuracy"], ascending=False, kind="stable")
    return str(best["method"].iloc[0])


def format_physiclear_deep_table(table: pd.DataFrame) -> str:
    """The study's table as aligned text: accuracies in % with their 95% intervals, chance beside."""

    def cell(col: str) -> list[str]:
        return [f"{100 * m:.1f} [{100 * lo:.1f}, {100 * hi:.1f}]" for m, lo, hi in
                zip(table[col], table[f"{col}_ci95_low"], table[f"{col}_ci95_high"], strict=True)]

    show = table[["protocol", "method", "n_seeds"]].copy()
    show["per-class mean %"] = cell("per_class_mean_accuracy")
    show["trial %"] = cell("accuracy")
    show["chance %"] = [f"{100 * c:.1f}" for c in table["chance"]]
    show["train %"] = [f"{100 * v:.1f}" for v in table["train_accuracy"]]
    show["chosen"] = np.where(table["chosen_on_validation"], "*", "")
    return show.to_string(index=False)
