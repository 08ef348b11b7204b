"""The zero-shot study's fits and tables over its splits: DAP's fusions and priors (Tables 1-3 of the DAP
paper, section 4, when the dataset is PHAC-2), the multi-label comparison, the attribute-count sweep and
the methods compared with DAP.

One call of :func:`run_zero_shot_tables` fits the attribute classifiers once per split and scores
every DAP variant from the same test posteriors, so MAXDAP/AVGDAP and the three priors are
compared on identical fits. The attribute-count sweep (section 4.7) reuses those posteriors.

Everything that is fitted (z-scoring, PCA, SVM hyper-parameters, under-sampling draw, Platt
sigmoid) sees training objects only. Splits are drawn from the class-attribute table (random)
or from an unsupervised 2-D map of all objects' features (challenging), as in the paper.
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Mapping

import numpy as np
import pandas as pd

from tzsl._profile import stage
from tzsl.datasets import FeatureSet
from tzsl.evaluation import Split, challenging_splits, random_object_splits
from tzsl.exceptions import ConfigError
from tzsl.models import (
    AttributeClassifierBank,
    AttributeSVM,
    MultiLabelAttributeClassifier,
)
from tzsl.models.dap import attribute_prior
from tzsl.studies.comparison.calibration import write_reliability_figure
from tzsl.studies.comparison.method_runs import split_masks
from tzsl.studies.config import ZeroShotSettings
from tzsl.studies.outputs.failures import ERROR_COLUMN, attempt
from tzsl.studies.papers.run_labels import StudyLabels
from tzsl.studies.zero_shot.deployment import dap_class_accuracy
from tzsl.studies.zero_shot.split_posteriors import SplitPosteriors
from tzsl.studies.zero_shot.spread import evidence_tables, model_seed
from tzsl.studies.zero_shot.tables import (
    attribute_accuracy_summary,
    attribute_accuracy_table,
    attribute_subsets,
    attribute_sweep,
    multilabel_table,
    split_label,
    table1_fusion,
    table2_priors,
    table3_challenging,
    table_titles,
)

#: Table (``failed_splits.csv``) of the splits whose DAP fit failed; written only when one did.
FAILED_SPLITS = "failed_splits"

#: Every split a study scored, in the format ``tzsl evaluate --splits`` reads back.
SPLITS_FILE = "splits.csv"


__all__ = [
    "SPLITS_FILE", "SplitPosteriors", "attribute_accuracy_summary",
    "attribute_accuracy_table", "attribute_bank", "attribute_estimator", "check_cv_folds", "detector_params",
    "attribute_subsets",
    "attribute_sweep", "compute_context", "fit_split", "fit_splits", "make_splits", "multilabel_table",
    "object_map_features", "run_zero_shot_tables", "solver_lines", "split_masks", "table1_fusion", "table2_priors",
    "table3_challenging",
]

# --------------------------------------------------------------------------- splits


def object_map_features(features: FeatureSet) -> pd.DataFrame:
    """Per-trial feature rows indexed by object, both sensors side by side (n_trials, s * d)."""
    n, s, d = features.X.shape
    return pd.DataFrame(features.X.reshape(n, s * d), index=pd.Index(features.objects, name="object_name"))


def make_splits(features: FeatureSet, kind: str, config: ZeroShotSettings) -> tuple[list[Split], pd.DataFrame | None]:
    """Random (F5) or challenging (F6) object splits of ``features``; the map for challenging."""
    if kind == "random":
        splits = random_object_splits(
            features.attributes, n_test=config.splits.n_test, n_splits=config.splits.n_splits,
            random_state=config.splits.seed, min_train_positives=config.splits.random_min_train_positives,
            min_train_negatives=config.splits.min_train_negatives, purpose=config.splits.purpose,
        )
        return splits, None
    if kind == "challenging":
        return challenging_splits(
            object_map_features(features), features.attributes,
            min_train_positives=config.splits.challenging_min_train_positives,
            min_train_negatives=config.splits.min_train_negatives,
        )
    raise ConfigError(f"unknown split kind {kind!r}; choose random or challenging")


# --------------------------------------------------------------------------- fitting


def check_cv_folds(cv, n_train_objects: int, where: str) -> None:
    """Refuse more object-grouped CV folds (``svm.cv`` / ``--cv``) than training objects, before any fit.

    ``cv``: an int (folds) or None / 0 (leave-one-object-out, always possible); ``where`` starts
    the message (the experiment file or ``command line``).
    """
    if cv and int(cv) > n_train_objects:
        raise ConfigError(f"{where}: svm.cv: {int(cv)} object-grouped folds, but a split has only "
                          f"{n_train_objects} training objects; use at most {n_train_objects} (0 = "
                          "leave-one-object-out)")


def attribute_estimator(config: ZeroShotSettings, seed: int) -> AttributeSVM:
    """The per-(attribute, sensor) SVM template of the study."""
    return AttributeSVM(undersampling=config.svm.undersampling, random_state=seed, **config.svm.estimator_params())


def detector_params(config: ZeroShotSettings, seed: int) -> dict:
    """``detector`` and ``estimator`` of the study's attribute models (``[svm] detector``): the SVM
    template of :func:`attribute_estimator` for the families that fit it (``rbf-svm``, ``auto``), else None."""
    detector = config.svm.detector
    svm = detector in ("rbf-svm", "auto")
    return {"detector": detector, "estimator": attribute_estimator(config, seed) if svm else None}


def _memory(config: ZeroShotSettings) -> str | bool:
    """The fit store of the study's attribute banks: the cache folder, or False (``compute.cache = false``:
    no store, even with ``TZSL_CACHE_DIR`` set)."""
    from tzsl.datasets import get_cache_dir  # noqa: PLC0415

    return str(get_cache_dir()) if config.compute.cache else False


def attribute_bank(config: ZeroShotSettings, attributes, seed: int) -> AttributeClassifierBank:
    """Independent per-(attribute, sensor) classifiers, parallel and cached."""
    return AttributeClassifierBank(
        **detector_params(config, seed), attribute_names=list(attributes), n_jobs=config.compute.n_jobs,
        backend=config.compute.backend, memory=_memory(config), progress=config.compute.progress, random_state=seed,
        solver=config.svm.solver, max_exact_trials=config.svm.max_exact_trials,
    )


def fit_split(features: FeatureSet, split: Split, config: ZeroShotSettings, index: int,
              multilabel: bool = False, refit: int = 0) -> SplitPosteriors:
    """Fit the attribute classifiers on the split's training objects; posteriors of its test trials.

    The model seed is :func:`~tzsl.studies.zero_shot.spread.model_seed` of the study's seed,
    ``index`` and ``refit`` (0: the study's fit; k > 0: its k-th refit with another seed).
    """
    attributes = split.kept_attributes
    train, test = split_masks(features, split)
    A = features.attributes.loc[features.objects, list(attributes)].to_numpy(dtype=int)
    groups = features.objects
    seed = model_seed(config.study_seed, index, refit)
    bank = attribute_bank(config, attributes, seed)
    start = time.perf_counter()
    bank.fit(features.X[train], A[train], groups[train])
    fit_seconds = time.perf_counter() - start
    P = bank.predict_proba(features.X[test])
    P_ml = None
    if multilabel:
        joint = MultiLabelAttributeClassifier(
            **detector_params(config, seed), attribute_names=list(attributes), n_jobs=config.compute.n_jobs,
            backend=config.compute.backend, memory=_memory(config), progress=config.compute.progress, random_state=seed,
        )
        joint.fit(features.X[train], A[train], groups[train])
        P_ml = joint.predict_proba(features.X[test])
    K = features.attributes.loc[list(split.test_objects), list(attributes)].to_numpy(dtype=int)
    y = pd.Index(split.test_objects).get_indexer(groups[test])
    prior = attribute_prior("train", train_attributes=A[train], groups=groups[train])
    return SplitPosteriors(split=split, attributes=tuple(attributes), P=P, K=K, y=y, train_prior=prior,
                           P_multilabel=P_ml, model=bank, fit_seconds=fit_seconds)


@contextlib.contextmanager
def compute_context(config: ZeroShotSettings):
    """A Dask client for ``backend="dask"`` (the scheduler's, or a local cluster); else nothing."""
    if config.compute.backend != "dask":
        yield None
        return
    try:
        from dask.distributed import Client, LocalCluster  # noqa: PLC0415
    except ImportError as exc:  # pragma: no cover - depends on the install
        raise ConfigError("--backend dask needs dask.distributed: pip install 'tzsl[dask]'") from exc
    from dask.distributed import default_client  # noqa: PLC0415

    try:  # nested use (a study calling fit_splits twice): keep the cluster that is already up
        yield default_client()
        return
    except ValueError:
        pass
    if config.compute.scheduler:
        with Client(config.compute.scheduler) as client:
            yield client
    else:
        from joblib import effective_n_jobs  # noqa: PLC0415

        workers = effective_n_jobs(config.compute.n_jobs)  # n_jobs means workers everywhere: -1 = every core
        with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                          dashboard_address=None) as cluster, Client(cluster) as client:
            yield client


def fit_splits(features: FeatureSet, splits: list[Split], config: ZeroShotSettings,
               multilabel: bool = False, offset: int = 0, failures: list[dict] | None = None) -> list[SplitPosteriors]:
    """:func:`fit_split` for every split (index ``offset + i`` seeds split ``i``).

    ``failures``: if a list, a split whose fit fails is left out and recorded there as
    ``{"split", "method": "dap", "error"}`` (the run goes on); if every split fails, the last
    split's error is raised. Without it, the first failure is raised.
    """
    if failures is None:
        with compute_context(config):
            return [fit_split(features, s, config, offset + i, multilabel=multilabel) for i, s in enumerate(splits)]
    results = []
    with compute_context(config):
        for i, s in enumerate(splits):
            done, error = attempt(fit_split, features, s, config, offset + i, multilabel=multilabel)
            if done is None:
                failures.append({"split": split_label(s), "method": "dap", ERROR_COLUMN: error})
            else:
                results.append(done)
        if splits and not results:  # nothing to tabulate: the error ends the run
            fit_split(features, splits[-1], config, offset + len(splits) - 1, multilabel=multilabel)
    return results


# --------------------------------------------------------------------------- the study


def _print(echo, title: str, table: pd.DataFrame) -> None:
    """Echo ``table`` for people: 3 decimals, whole-number columns (counts) without decimals."""
    if echo is None:
        return
    shown = table.copy()
    for column in shown.select_dtypes("number").columns:
        values = shown[column].dropna()
        if len(values) and np.all(np.isclose(values, np.round(values))):
            shown[column] = shown[column].map(lambda v: "-" if pd.isna(v) else f"{v:.0f}")
    echo(f"\n{title}")
    echo(shown.to_string(index=False, float_format=lambda v: f"{v:.3f}", na_rep="-"))


def run_zero_shot_tables(
    features: FeatureSet,
    out,
    config: ZeroShotSettings,
    *,
    splits: Mapping[str, tuple[list[Split], pd.DataFrame | None]] | None = None,
    echo=None,
    record: dict | None = None,
    labels: StudyLabels | None = None,
    per_class: dict[str, pd.DataFrame] | None = None,
) -> dict[str, pd.DataFrame]:
    """Fit and score DAP (and the compared methods) on the study's splits; write its tables and figures into ``out``.

    What runs is read from ``config``: the split kinds (``[splits] kinds``), the attribute-count sweep
    (``[methods] sweep``) and the methods compared with DAP (``[methods]``,
    :meth:`~tzsl.studies.config.ZeroShotMethods.method_specs`, on the kinds of ``compare_on``).

    Parameters
    ----------
    features : FeatureSet
        Per-trial, per-sensor features (e.g. ``dataset_features("phac2-penn")``).
    out : tzsl.studies.outputs.results_folder.ResultsDir
        Where tables (CSV) and figures (PNG) go; existing files need ``force``.
    config : ZeroShotSettings
        E.g. ``ZeroShotSettings()`` (the generic study) or ``ZeroShotSettings.of_preset("phac2-dap")``.
    splits : dict or None
        The splits the caller has drawn or read already, by kind (``"random"``, ``"challenging"``,
        ``"file"`` -> :func:`make_splits`'s ``(splits, object map or None)``; see
        :func:`tzsl.studies.zero_shot.runner.prepare`); a kind of ``config`` missing here is drawn here.
    echo : callable or None
        Receives human-readable tables (the CLI passes ``click.echo``).
    record : dict or None
        Filled with ``"attribute_solver"``: one :attr:`AttributeClassifierBank.solver_choice_`
        per fitted split (exact or approximate attribute models, and why), for the manifest.
    labels : StudyLabels or None
        How the tables name the run and whether the paper's numbers go beside
        (:func:`tzsl.studies.papers.run_labels.study_labels`); default: a generic run, no paper.
    per_class : dict or None
        Filled, by split kind, with every method's accuracy per (split, test class)
        (:func:`tzsl.studies.zero_shot.deployment.class_accuracy`; the DAP rows alone on the random or file
        splits when no method is compared on them): what the deploy choice reads.

    Returns
    -------
    dict of DataFrame
        Every table written, keyed by file stem.
    """
    from tzsl.studies.zero_shot._figures import (  # noqa: PLC0415
        attribute_accuracy_figure,
        attribute_sweep_figure,
        object_map_figure,
    )

    labels = labels or StudyLabels()
    kinds, drawn = config.splits.kinds, dict(splits or {})
    with stage("splits"):  # what the caller has not drawn (the challenging splits' unsupervised object map)
        for kind in kinds:
            if kind not in drawn:
                drawn[kind] = make_splits(features, kind, config)  # "file" cannot be drawn: given, or an error
    paper = labels.paper
    tables: dict[str, pd.DataFrame] = {}
    with compute_context(config):  # one Dask cluster for all the study's fits
        random_results: list[SplitPosteriors] = []
        failed: list[dict] = []  # splits whose DAP fit failed: failed_splits.csv, reported at the end
        scored = "file" if "file" in kinds else "random"
        if scored in kinds:
            random_results = fit_splits(features, drawn[scored][0], config, multilabel=config.methods.multilabel,
                                        failures=failed)
        if random_results:
            with stage("tables"):
                tables["table1_fusion"] = table1_fusion(random_results, paper=paper)
                tables["table2_priors"] = table2_priors(random_results, paper=paper)
                if config.methods.multilabel:
                    tables["multilabel"] = multilabel_table(random_results, paper=paper)
                per_split = attribute_accuracy_table(random_results, features.sensors)
                tables["attribute_accuracy_per_split"] = per_split
                tables["attribute_accuracy"] = attribute_accuracy_summary(per_split, random_results, paper=paper)
            out.write_figure("attribute_accuracy.png", attribute_accuracy_figure(tables["attribute_accuracy"]))
            if config.methods.sweep:
                with stage("sweep"):
                    tables["attribute_sweep"] = attribute_sweep(random_results, config.methods.sweep_min_attributes,
                                                                config.methods.sweep_max_subsets,
                                                                seed=config.study_seed)
                out.write_figure("attribute_sweep.png", attribute_sweep_figure(tables["attribute_sweep"]))
        used = [r.split for r in random_results]
        results: list[SplitPosteriors] = []
        if "challenging" in kinds:
            challenging, map_coords = drawn["challenging"]
            results = fit_splits(features, challenging, config, offset=100, failures=failed)
            used += [r.split for r in results]
            with stage("tables"):
                tables["table3_challenging"] = table3_challenging(results, map_coords, paper=paper)
            tables["object_map"] = map_coords
            out.write_figure("object_map.png", object_map_figure(map_coords, features.dataset))
        by_kind = {scored: (random_results, 0), "challenging": (results, 100)}
        with stage("tables"):
            evidence = evidence_tables(
            features, by_kind, seed=config.study_seed, labels=labels, compare_on=config.methods.compare_on,
            purpose=config.splits.purpose, n_jobs=config.compute.n_jobs,
            methods=config.methods.method_specs(),
            refit_seeds=config.splits.refit_seeds, refit_splits=config.splits.refit_splits,
            refit=lambda split, index, k: fit_split(features, split, config, index, refit=k), per_class=per_class)
        tables.update(evidence)
        if per_class is not None and random_results and scored not in per_class:
            per_class[scored] = dap_class_accuracy(random_results)
        write_reliability_figure(out, tables, labels.reliability_table, labels.comparison_table)
        if failed:
            tables[FAILED_SPLITS] = pd.DataFrame(failed)
    _record_solvers(random_results + results, echo, record)
    titles = table_titles(labels)
    if used:  # every split scored, readable by --splits; its classes go into the manifest too
        out.write_splits(SPLITS_FILE, used)
    for name, table in tables.items():
        out.write_csv(f"{name}.csv", table)
        if name in titles:
            _print(echo, titles[name], table)
    return tables


def solver_lines(choices: list[dict]) -> list[str]:
    """One line per distinct attribute-solver choice (``record["attribute_solver"]`` entries)."""
    return list(dict.fromkeys(f"attribute models: {c['solver']} ({c['reason']})" for c in choices))


def _record_solvers(results: list[SplitPosteriors], echo, record: dict | None) -> None:
    """Echo each distinct attribute-solver choice once; store every split's in ``record``."""
    choices = [{"split": r.split.name, **r.model.solver_choice_} for r in results
               if r.model is not None and hasattr(r.model, "solver_choice_")]
    if record is not None:
        record["attribute_solver"] = choices
    if echo is not None:
        for text in solver_lines(choices):
            echo(text)


