"""The hand study's data and model steps: grasp features and the fitted hand DAP model.

Shared by the study (:mod:`tzsl.studies.hand.study`), the saved hand bundles
(:mod:`tzsl.inference.model_bundles`) and active touch on the hand
(:mod:`tzsl.studies.active_touch.hand`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from tzsl.datasets import Grasp, HandTable
from tzsl.exceptions import DataFileError, SplitError
from tzsl.features import GraspFeatures, grasp_features
from tzsl.fit_store import fit_cached
from tzsl.models import HandDAPClassifier

if TYPE_CHECKING:
    from tzsl.studies.config import HandSettings

__all__ = ["feature_params", "fit_hand_model", "hand_features"]


def feature_params(config: HandSettings) -> dict:
    """Keyword arguments of :func:`tzsl.features.grasp_features` taken from ``config``."""
    return {
        "contact_threshold": float(config.features.contact_threshold),
        "baseline_rows": int(config.features.baseline_rows),
        "hold_fraction": float(config.features.hold_fraction),
        "end_rows": int(config.features.end_rows),
    }


def hand_features(grasps: Sequence[Grasp], table: HandTable, config: HandSettings) -> GraspFeatures:
    """Features of labelled grasps, checking every grasp's object is a row of the table.

    Raises
    ------
    DataFileError
        A grasp without object label, or of an object missing from the table (naming both).
    """
    grasps = list(grasps)
    if not grasps:
        raise DataFileError(None, "no grasps to evaluate")
    unlabelled = [g.grasp_id for g in grasps if not g.object_name]
    if unlabelled:
        raise DataFileError(grasps[0].source or None, f"grasp(s) without object label: {unlabelled[:5]}")
    unknown = sorted({g.object_name for g in grasps} - set(table.K.index))
    if unknown:
        raise DataFileError(table.source, f"object(s) {unknown} of the grasps have no row in the class-attribute table")
    return grasp_features(grasps, **feature_params(config))


def fit_hand_model(
    features: GraspFeatures, table: HandTable, config: HandSettings, seed: int, **overrides
) -> HandDAPClassifier:
    """Fit the hand DAP model on the grasps of the table's training objects only (through the fit store).

    Parameters
    ----------
    features : GraspFeatures
        Any grasps; only those of ``table.train_objects`` are used.
    table : HandTable
    config : HandSettings
    seed : int
        ``random_state`` of the model.
    **overrides
        Extra :class:`~tzsl.models.HandDAPClassifier` parameters (e.g. ``fusion``).

    Raises
    ------
    SplitError
        No grasp of any training object.
    """
    train = np.isin(features.objects, table.train_objects)
    if not train.any():
        raise SplitError(f"no grasp of a training object ({table.train_objects}) to fit the attribute classifiers on")
    tr = features.subset(train)
    params = {**config.methods.model, **overrides}
    model = HandDAPClassifier(
        material_attributes=tuple(table.material_attributes),
        random_state=seed,
        n_jobs=config.compute.n_jobs,
        **params,
    )
    return fit_cached(model, tr.to_array(), tr.objects, table.K)
