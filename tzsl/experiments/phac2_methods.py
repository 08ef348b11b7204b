"""DAP vs ESZSL vs the fabric paper's embedding model on the same PHAC-2 splits (``phac2_methods.csv``)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from tzsl.datasets import FeatureSet
from tzsl.evaluation import Split, summarise_over_splits
from tzsl.experiments.phac2_tables import split_label
from tzsl.models import attribute_rows, build_method

if TYPE_CHECKING:
    from tzsl.experiments.phac2_dap import SplitPosteriors

__all__ = ["method_comparison"]


def _fit_predict_zsl(model, features: FeatureSet, split: Split) -> tuple[np.ndarray, np.ndarray]:
    """Fit a feature->attribute ZSL model on the split's training objects; predicted/true test rows."""
    from tzsl.experiments.phac2_dap import split_masks  # noqa: PLC0415 - phac2_dap re-exports this module

    attributes = list(split.kept_attributes)
    train, test = split_masks(features, split)
    n, s, d = features.X.shape
    X = features.X.reshape(n, s * d)
    objects = features.objects
    train_objects = np.unique(objects[train])
    class_rows = features.attributes.loc[train_objects, attributes].to_numpy(dtype=float)
    model.fit(X[train], attribute_rows(objects[train], class_rows), objects[train])
    K = features.attributes.loc[list(split.test_objects), attributes].to_numpy(dtype=float)
    y = pd.Index(split.test_objects).get_indexer(objects[test])
    return model.predict(X[test], K), y


def method_comparison(features: FeatureSet, results: list[SplitPosteriors], seed: int = 0,
                      embedding_lams: tuple = (0.1, 1.0), eszsl: bool = True) -> pd.DataFrame:
    """DAP, ESZSL and the fabric paper's embedding model on the same PHAC-2 splits (trial accuracy).

    ESZSL's two ridges are tuned by class(object)-grouped CV on training objects; the embedding
    model uses its documented defaults with class-grouped early stopping. Both see the two
    BioTacs' features side by side (one vector per trial), objects sharing an attribute row are
    merged into one training class. DAP numbers are AVGDAP / uni-prior from ``results``.
    ``eszsl=False`` leaves ESZSL out; ``embedding_lams=()`` the embedding model.
    """
    rows = []
    for i, r in enumerate(results):
        row = {"split": split_label(r.split), "chance": r.split.chance, "dap_avg_uni": r.accuracy("avg", "uni")}
        if eszsl:
            pred, y = _fit_predict_zsl(build_method("eszsl"), features, r.split)
            row["eszsl"] = float((pred == y).mean())
        for lam in embedding_lams:
            model = build_method("embedding", lam=lam, random_state=seed + i)
            pred, y = _fit_predict_zsl(model, features, r.split)
            row[f"embedding_lam_{lam:g}"] = float((pred == y).mean())
        rows.append(row)
    return summarise_over_splits(pd.DataFrame(rows)).reset_index()
