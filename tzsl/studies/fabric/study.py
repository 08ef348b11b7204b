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
  "C only", which would repeat the lambda = 0 column (see :mod:`tzsl.models.embedding._embedding`). Its
  weight decay ``alpha`` is chosen per fit by class-grouped cross-validation on the training
  groups (:func:`select_embedding_alpha`: held-out groups are recognised among themselves, as
  :class:`~tzsl.models.ESZSLCV` tunes ESZSL), then the model is refitted on all training
  groups without early stopping. (The model's own early stopping holds out ONE training class
  and stops when its loss rises; on this data that happens at the first L-BFGS iterations for
  lambda >= 1, leaving an essentially untrained model, so it is not used.) Repeated for
  ``seeds`` seeds (weight initialisation).
* ``ESZSL``: :class:`~tzsl.models.ESZSLCV`, both regularisers chosen by class-grouped CV on the
  training groups. Deterministic, fitted once; its ``_std`` columns are 0.
* Groups sharing one attribute vector (a8: groups 3, 4, 5) are merged in training. So the
  paper's split tests group 5 on a row seen in training: it is kept as a ``protocol=paper``
  reproduction row (``zero_shot`` False), and the headline is its ``zero-shot-drop`` variant
  (:func:`~tzsl.studies.fabric.tables.fabric_protocols`; per-class mean accuracy). The two
  protocols train on the same groups, so each fit is done once and scored on both
  (:func:`~tzsl.studies.fabric.methods.zero_shot_runs`).
* Prediction: nearest attribute vector among the TEST groups only (zero-shot); accuracy over
  test samples and per-class mean accuracy over test groups.

Outputs (through :class:`~tzsl.studies.outputs.results_folder.ResultsDir`)
---------------------------------------------------------------------------
``fabric_table1.csv`` (:func:`fabric_table`), ``fabric_runs.csv`` (one row per fit),
``fabric_lambda.png`` (accuracy vs lambda, ours and the paper's: Fig. 6),
``fabric_partitions.csv`` (with ``partitions``: ESZSL over repeated group partitions with >= 4
test groups, interval, chance and a majority baseline: :mod:`tzsl.studies.fabric.partitions`),
``fabric_method_comparison.csv`` (every method on the same test samples, intervals and paired
differences to the embedding model at the paper's lambda 0.1:
:func:`tzsl.studies.fabric.methods.fabric_comparison`); what the run's manifest records of the study
is filled into ``record`` (``tzsl run`` writes the one ``manifest.json``).

Caching: the texture descriptors (the costly step for the 1300 images) are cached with
:class:`joblib.Memory` under :func:`tzsl.datasets.get_cache_dir`, keyed on the sha256 of the
image (or video) files and the descriptor parameters; a re-run only refits the models.
"""

from __future__ import annotations

import os
import warnings
from pathlib import Path
from typing import Any, cast

import numpy as np
import pandas as pd
from joblib import Parallel, delayed

from tzsl._parallel import reissued, relayed
from tzsl._profile import stage
from tzsl._progress import progress_bar
from tzsl.datasets import FABRIC_ATTRIBUTE_SETS, load_fabric
from tzsl.evaluation import DEFAULT_ALPHAS, add_trust_columns, select_embedding_alpha
from tzsl.features import TextureDescriptor
from tzsl.fit_store import count_fits
from tzsl.studies.comparison.method_runs import method_label, takes_seed
from tzsl.studies.config import FabricStudy
from tzsl.studies.fabric.methods import (
    COMPARISON_TABLE,
    ZeroShotRun,
    fabric_comparison,
    run_job,
    zero_shot_run,
)
from tzsl.studies.fabric.partitions import run_partitions
from tzsl.studies.fabric.samples import (
    N_KEY_FRAMES,
    FabricSamples,
    depth_image_descriptors,
    depth_samples,
    depth_sequence_rows,
    descriptor_params,
    files_digest,
    gelsight_samples,
)
from tzsl.studies.fabric.tables import (
    ESZSL_METHOD,
    PAPER_LAMBDAS,
    fabric_lambda_figure,
    fabric_note,
    fabric_outcomes,
    fabric_protocols,
    fabric_table,
    format_fabric_table,
    lambda_label,
)
from tzsl.studies.outputs.results_folder import ResultsDir

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

#: Data conditions built from the public depth images.
DEPTH_CONDITIONS: tuple[str, ...] = ("depth-sequence", "depth-image")

TABLE_FILE = "fabric_table1.csv"
RUNS_FILE = "fabric_runs.csv"
FIGURE_FILE = "fabric_lambda.png"
PARTITIONS_FILE = "fabric_partitions.csv"


# ---------------------------------------------------------------------------------------------
# the study
# ---------------------------------------------------------------------------------------------
def run_fabric_study(
    out: ResultsDir,
    settings: FabricStudy | None = None,
    *,
    data_dir=None,
    gelsight_root=None,
    cache_dir=None,
    record: dict | None = None,
) -> dict[str, pd.DataFrame]:
    """Run the fabric study and write its table, runs and figure.

    Parameters
    ----------
    out : ResultsDir
        Output folder; existing outputs are refused unless ``out.force`` (checked before
        any computation).
    settings : FabricStudy or None
        The checked study file (:class:`~tzsl.studies.config.FabricStudy`; default: the schema's
        defaults): ``[dataset] attributes``, ``[features] conditions`` / ``gelsight_conditions``,
        ``[methods]`` (lambda grid ``embedding_lambdas``, weight-decay grid ``alphas`` chosen by
        :func:`select_embedding_alpha`, ``max_iter``, registry methods ``compare`` run beside ESZSL,
        one row per seed if random), ``[splits]`` (``configs`` of
        :func:`tzsl.datasets.fabric_zsl_split`, ``n_seeds`` embedding seeds from ``seed``),
        ``[partitions]`` (the repeated group partitions of
        :func:`~tzsl.studies.fabric.partitions.run_partitions`, when ``enabled``) and ``[compute]``.
        From Python, e.g. ``FabricStudy(splits={"configs": [1]}, methods={"embedding_lambdas": [0]})``.
    data_dir, gelsight_root : str, path or None
        The data home with ``fabric/`` and your GelSight videos, resolved (default: ``[dataset]``'s).
    cache_dir : str, path or None
        Descriptor cache (default :func:`tzsl.datasets.get_cache_dir`).
    record : dict, optional
        Filled with what the run's one manifest records of the study (``tzsl run`` and :func:`tzsl.run`
        write it into ``manifest.json``): ``"fabric"`` (protocols, conditions, grids, seeds, ...), the
        data's digests (``depth_images_sha256``, ``gelsight_videos_sha256``) and ``"data_files"``.

    Returns
    -------
    dict of str -> DataFrame
        ``"table1"`` (:func:`fabric_table`) and ``"runs"`` (one row per fit: condition,
        config, method, seed, accuracy, per_class_mean_accuracy, chosen hyper-parameters,
        predicted counts per test group); with ``partitions`` also ``"partitions"``.
    """
    settings = FabricStudy() if settings is None else settings
    sp, me, fe = settings.splits, settings.methods, settings.features
    seeds, configs, seed = sp.n_seeds, [int(c) for c in sp.configs], sp.seed
    attributes, lams, alphas, max_iter = settings.dataset.attributes, list(me.embedding_lambdas), me.alphas, me.max_iter
    # the compare validator (methods_ok) made every entry a dict
    methods = cast("list[dict[str, Any]]", me.compare)
    conditions, gelsight_conditions = list(fe.conditions), fe.gelsight_conditions
    n_jobs, progress = settings.compute.n_jobs, settings.compute.progress
    partitions = settings.partitions.model_dump(exclude={"enabled"}) if settings.partitions.enabled else None
    data_dir = settings.dataset.data_dir if data_dir is None else data_dir
    gelsight_root = settings.dataset.gelsight_root if gelsight_root is None else gelsight_root
    labels = [lambda_label(lam) for lam in lams]
    out.check_free([TABLE_FILE, RUNS_FILE, FIGURE_FILE, f"{COMPARISON_TABLE}.csv"]
                   + ([PARTITIONS_FILE] if partitions is not None else []))

    with warnings.catch_warnings(), stage("load"):
        # duplicate attribute vectors are expected (a8: groups 3, 4, 5); recorded in the note
        warnings.filterwarnings("ignore", message="fabric attribute matrix", category=UserWarning)
        fabric = load_fabric(data_dir, attributes, images=bool(conditions))
        A = fabric.attributes.to_numpy(dtype=np.float64)
        protocols = fabric_protocols(configs, fabric.attributes)  # the paper's split and its zero-shot variant

    samples: list[FabricSamples] = []
    digests: dict[str, str] = {}
    gel: list[FabricSamples] = []
    if gelsight_root is not None:  # first: a wrong folder fails before the depth descriptors
        gel = gelsight_samples(
            gelsight_root, conditions=gelsight_conditions, n_groups=A.shape[0],
            cache_dir=cache_dir, n_jobs=n_jobs, progress=progress,
        )
        digests["gelsight_videos_sha256"] = files_digest(
            [p for s in gel for p in s.samples["path"].tolist()]
        )
    if conditions:
        with stage("features"):  # the depth images' descriptors, in joblib workers (cached)
            desc = depth_image_descriptors(fabric, cache_dir=cache_dir, n_jobs=n_jobs, progress=progress)
            digests["depth_images_sha256"] = files_digest(fabric.images["path"].tolist())
            seq, img = depth_samples(fabric, desc)
        samples += [s for s in (seq, img) if s.condition in conditions]
    samples += gel

    seed_list = list(range(int(seed), int(seed) + seeds))
    # the fits of one data condition: (method, lam, seed, alphas, registry spec), in the runs table's order
    fits: list[tuple[str, float | str | None, int | None, tuple[float, ...], dict[str, Any] | None]] = [
        (f"lam_{label}", lam, sd, tuple(alphas), None)
        for lam, label in zip(lams, labels, strict=True) for sd in seed_list
    ]
    fits.append((ESZSL_METHOD, None, None, (), None))
    fits += [(method_label(spec), None, sd, (), spec)  # registry methods: every seed if random, else once
             for spec in methods for sd in (seed_list if takes_seed(spec) else [None])]
    # protocols with the same training groups (the paper's split and its zero-shot variant) share
    # every fit: one job fits once and scores each of them
    families: dict[tuple[int, ...], list[int]] = {}
    for p, proto in enumerate(protocols):
        families.setdefault(tuple(proto.split.train_groups), []).append(p)
    jobs: list[Any] = []
    first_job: dict[tuple[int, tuple[int, ...]], int] = {}  # (sample index, family) -> its first job; one job per fit
    for i, s in enumerate(samples):
        for family in families.values():
            first_job[i, tuple(family)] = len(jobs)
            splits = [protocols[p].split for p in family]
            jobs += [delayed(relayed(run_job))(s.X, s.groups, A, splits, method, lam, sd, alphas_, max_iter, spec)
                     for method, lam, sd, alphas_, spec in fits]

    with stage("fit"):  # the embedding and ESZSL fits, in joblib workers
        results = map(reissued, Parallel(n_jobs=n_jobs, return_as="generator")(jobs))
        job_rows = list(progress_bar(results, show=progress, total=len(jobs), desc="fabric fits"))
    for first, *_ in job_rows:  # the fit-store events of jobs run in workers, into this run's profile
        pid, counts = first.pop("_fit_store")
        for name, n in counts.items() if pid != os.getpid() else ():  # in this process: counted already
            count_fits(name, n)
    rows = []  # one per (condition, protocol, fit)
    for i, s in enumerate(samples):
        for p, proto in enumerate(protocols):
            split, config = proto.split, proto.split.config
            row_meta = {
                "condition": s.condition, "config": config, "protocol": proto.name, "zero_shot": proto.zero_shot,
                "unit": s.unit, "test_groups": " ".join(map(str, split.test_groups)),
                "train_groups": " ".join(map(str, split.train_groups)), "paper_row": s.paper_row or "",
                "note": f"{proto.note}; {fabric_note(s, config, fabric.duplicate_groups, attributes)}",
            }
            family = families[tuple(split.train_groups)]
            start, at = first_job[i, tuple(family)], family.index(p)
            rows += [{**row_meta, **job_rows[start + f][at]} for f in range(len(fits))]
    with stage("tables"):  # runs and Table 1 with their intervals (the bootstrap is a stage of its own)
        outcomes, per_run = fabric_outcomes(rows)  # per-sample outcomes -> intervals in the table and the runs
        correct = [row.pop("correct", None) for row in rows]  # per test sample: the comparison's trials
        runs = pd.DataFrame(rows)
        seeds_ = runs["seed"].astype("Int64")
        runs = add_trust_columns(runs.assign(seed=seeds_.astype(object).where(seeds_.notna(), "None")), per_run)
        runs["seed"] = seeds_
        for col in ("alpha", "gamma", "eszsl_lam", "cv_score", "n_iter", "converged"):
            if col not in runs.columns:
                runs[col] = np.nan
        table = fabric_table(runs, lams, outcomes)

    out.write_csv(TABLE_FILE, table)
    out.write_csv(RUNS_FILE, runs)
    # the comparison runs on each config's zero-shot protocol (the headline), fits that completed
    headline = {p.split.config: p for p in protocols if p.zero_shot}
    with stage("tables"):  # the method comparison: paired intervals (its bootstrap is a stage of its own)
        keep = np.flatnonzero([c is not None and r["protocol"] == headline[int(r["config"])].name
                               for c, (_, r) in zip(correct, runs.iterrows(), strict=True)])
        comparison = fabric_comparison(runs.iloc[keep].reset_index(drop=True), [correct[i] for i in keep], samples,
                                       {c: p.split for c, p in headline.items()}, seed_list, labels)
    out.write_csv(f"{COMPARISON_TABLE}.csv", comparison)
    out.write_figure(FIGURE_FILE, fabric_lambda_figure(table, lams))
    extra_tables: dict[str, pd.DataFrame] = {}
    if partitions is not None:
        part_key = partitions.get("attributes") or attributes
        rules = {k: v for k, v in partitions.items() if k != "attributes"}  # min_test, both_signs, max_partitions
        with warnings.catch_warnings(), stage("partitions"):
            warnings.filterwarnings("ignore", message="fabric attribute matrix", category=UserWarning)
            A_part = load_fabric(data_dir, part_key, images=False).attributes.to_numpy(dtype=np.float64)
            summary, parts = run_partitions(samples, A_part, **rules, random_state=seed, max_iter=max_iter,
                                            n_jobs=n_jobs)
        if not parts:
            warnings.warn(f"fabric partitions: no valid partition of the {part_key} groups under {rules}; "
                          "fabric_partitions.csv is empty", UserWarning, stacklevel=2)
        out.write_csv(PARTITIONS_FILE, summary.assign(attributes=part_key))
        extra_tables["partitions"] = summary
    config = {
        "study": "fabric zero-shot (F18)",
        "attributes": attributes,
        "configs": {f"{p.split.config}/{p.name}": {"train": list(p.split.train_groups),
                                                   "test": list(p.split.test_groups),
                                                   "zero_shot": p.zero_shot, "note": p.note} for p in protocols},
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
        "methods": [dict(spec) for spec in methods],
        "descriptor": descriptor_params(TextureDescriptor()),
        "key_frames": N_KEY_FRAMES,
        "gelsight_root": None if gelsight_root is None else str(gelsight_root),
        "duplicate_groups": [list(d) for d in fabric.duplicate_groups],
        "n_jobs": n_jobs,
        "partitions": None if partitions is None else dict(partitions),
    }
    data_files = [fabric.root / "fabric_groups.csv", fabric.root / FABRIC_ATTRIBUTE_SETS[attributes][0]]
    data_files += [Path(p) for p in (fabric.images["path"] if conditions else [])]
    data_files += [Path(p) for s in gel for p in s.samples["path"]]
    if record is not None:  # the engine's manifest hashes every data file read
        record.update({"fabric": config, **digests, "data_files": [p for p in data_files if p.is_file()]})
    return {"table1": table, "runs": runs, COMPARISON_TABLE: comparison, **extra_tables}
