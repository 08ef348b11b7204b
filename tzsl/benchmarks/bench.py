"""``make bench-fit`` (``tzsl bench``): time one full random PHAC-2 split three ways (issue: speed of the
attribute fits).

1. **literal**: what a user would write from the paper's text (section 4.4): per attribute and
   BioTac, z-score + PCA(95%), under-sample class 0 once at random to balance, then
   ``GridSearchCV(SVC(probability=True), {C: 1..100, gamma: 0.01..1}, cv=LeaveOneOut())``
   - no object grouping, no caching, one fit after another;
2. **tzsl, n_jobs=1** and 3. **tzsl, n_jobs=2**: :class:`tzsl.models.AttributeClassifierBank`
   with the study's defaults and the cache disabled (a cold run).

Each way is scored with the same DAP (AVGDAP, uni-prior) on the split's test objects. This is a
benchmark, not a test: numbers depend on the machine; the closing note of the issue records them.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Callable

import numpy as np
import pandas as pd
from sklearn.decomposition import PCA
from sklearn.model_selection import GridSearchCV, LeaveOneOut
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler
from sklearn.svm import SVC

from tzsl.datasets import FeatureSet
from tzsl.models.dap import attribute_prior
from tzsl.studies.config import ZeroShotSettings
from tzsl.studies.zero_shot.study import SplitPosteriors, fit_split, make_splits, split_masks


def literal_posteriors(features: FeatureSet, train: np.ndarray, test: np.ndarray, attributes: list[str],
                       seed: int = 0, progress: Callable[[str], None] | None = None) -> np.ndarray:
    """The paper's recipe taken literally; returns test posteriors (n_test, n_sensors, m)."""
    rng = np.random.default_rng(seed)
    A = features.attributes.loc[features.objects, attributes].to_numpy(dtype=int)
    grid = {"svc__C": [1.0, 10.0, 100.0], "svc__gamma": [0.01, 0.1, 1.0]}
    P = np.zeros((int(test.sum()), len(features.sensors), len(attributes)))
    train_idx = np.flatnonzero(train)
    for j, name in enumerate(attributes):
        for s in range(len(features.sensors)):
            y = A[train_idx, j]
            pos, neg = train_idx[y == 1], train_idx[y == 0]
            keep = np.concatenate([pos, rng.choice(neg, size=min(len(pos), len(neg)), replace=False)])
            model = make_pipeline(StandardScaler(), PCA(n_components=0.95),
                                  SVC(kernel="rbf", probability=True, random_state=seed))
            search = GridSearchCV(model, grid, cv=LeaveOneOut(), n_jobs=1)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                search.fit(features.X[keep, s], A[keep, j])
                P[:, s, j] = search.predict_proba(features.X[test, s])[:, 1]
            if progress:
                progress(f"  literal: {name} / {features.sensors[s]} done")
    return P


def run_bench(features: FeatureSet, config: ZeroShotSettings | None = None, split_index: int = 0,
              skip_literal: bool = False, echo: Callable[[str], None] | None = None) -> pd.DataFrame:
    """Time and score the three ways on one random split; one row per way."""
    config = (config or ZeroShotSettings.of_preset("phac2-dap")).model_copy(deep=True)
    config.compute.cache, config.compute.progress, config.methods.multilabel = False, False, False
    splits, _ = make_splits(features, "random", config)
    split = splits[split_index]
    rows = []
    template: SplitPosteriors | None = None
    for n_jobs in (1, 2):
        start = time.perf_counter()
        config.compute.n_jobs = n_jobs
        result = fit_split(features, split, config, split_index)
        elapsed = time.perf_counter() - start
        template = result
        rows.append({"method": f"tzsl n_jobs={n_jobs}", "seconds": elapsed,
                     "avgdap_accuracy": result.accuracy("avg", "uni")})
        if echo:
            echo(f"tzsl n_jobs={n_jobs}: {elapsed:.1f} s, AVGDAP accuracy {rows[-1]['avgdap_accuracy']:.3f}")
    assert template is not None  # the loop above ran (n_jobs 1 and 2)
    if not skip_literal:
        train, test = split_masks(features, split)
        start = time.perf_counter()
        P = literal_posteriors(features, train, test, list(split.kept_attributes), seed=config.splits.seed,
                               progress=echo)
        elapsed = time.perf_counter() - start
        literal = SplitPosteriors(split=split, attributes=template.attributes, P=P, K=template.K, y=template.y,
                                  train_prior=attribute_prior("uni", class_attributes=template.K))
        rows.insert(0, {"method": "literal GridSearchCV(SVC(probability=True), cv=LeaveOneOut())",
                        "seconds": elapsed, "avgdap_accuracy": literal.accuracy("avg", "uni")})
    table = pd.DataFrame(rows)
    if not skip_literal:
        table["speedup_vs_literal"] = table["seconds"].iloc[0] / table["seconds"]
    table.insert(1, "split", split.name)
    return table
