"""Make the robot models the train commands save: ``tzsl train-attributes`` and ``tzsl train-hand``.

Each function fits a model on a dataset's training objects (with the study's settings: the
study code is imported when a model is trained, never when this module is imported) and writes
it as a ``"zero-shot"`` bundle (:mod:`tzsl.inference.zero_shot_bundles`: arrays for linear and
DAP models, skops for the others). The per-EP (active touch) model is
:func:`tzsl.inference.predict_active.train_per_ep_bundle`; the deep model's bundle is
:mod:`tzsl.inference.deep_bundles`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from tzsl.datasets import FeatureSet, HandTable, read_grasps
from tzsl.exceptions import ConfigError
from tzsl.inference.zero_shot_bundles import save_model_bundle, save_zero_shot_bundle
from tzsl.models import (
    CalibratedZeroShotClassifier,
    DAPRule,
    HandDAPClassifier,
    ZeroShotClassifier,
    get_method,
)

__all__ = [
    "left_out_notes",
    "train_attribute_bundle",
    "train_hand_bundle",
    "training_record",
    "training_subset",
]



# ---------------------------------------------------------------------------- training commands
def training_subset(features: FeatureSet, splits_file=None, split_name: str | None = None, *,
                    min_train_positives: int = 1, min_train_negatives: int = 1
                    ) -> tuple[FeatureSet, str | None, list[dict]]:
    """Features of the training objects (one split's, or every object) with the attributes they can teach.

    An attribute with fewer than ``min_train_positives`` positive or ``min_train_negatives``
    negative training objects is left out, as a zero-shot split leaves it out
    (:func:`tzsl.evaluation.attribute_exclusions`, with the study's rule:
    :func:`~tzsl.studies.zero_shot.relaxations.trainable_attribute_rule`); so is an
    attribute the dataset's ``min_objects`` filter dropped (``features.info["dropped_attributes"]``).

    Parameters
    ----------
    features : FeatureSet
    splits_file, split_name
        Train on the training objects of this split of a split CSV (default: its first split);
        None: on every object.
    min_train_positives, min_train_negatives : int
        Least positive / negative training objects of a kept attribute.

    Returns
    -------
    features : FeatureSet
        The training objects' trials, attribute columns: the kept ones, in table order.
    split : str or None
        The split's name (None without ``splits_file``).
    left_out : list of dict
        ``{"attribute": name, "reason": why}`` of every attribute left out, the filter's first
        (recorded in the bundle's metadata as ``left_out_attributes``).

    Raises
    ------
    ConfigError
        No such split, or every attribute is left out.
    """
    from tzsl.evaluation import Split, attribute_exclusions, read_splits_csv  # noqa: PLC0415

    rule = {"min_train_positives": min_train_positives, "min_train_negatives": min_train_negatives}
    A = features.attributes
    if splits_file is None:
        with_trials = set(features.objects)
        objects = tuple(str(o) for o in A.index if o in with_trials)
        chosen = Split("all objects", objects, (), tuple(map(str, A.columns)),
                       attribute_exclusions(A.loc[list(objects)].to_numpy(dtype=bool), list(A.columns), **rule))
    else:
        splits = read_splits_csv(splits_file, A, **rule)
        named = splits[0] if split_name is None else next((s for s in splits if s.name == split_name), None)
        if named is None:
            raise ConfigError(f"{splits_file}: no split named {split_name!r}; have {[s.name for s in splits]}")
        chosen = named
    info = features.info or {}
    filtered = (f"present in fewer than {info['min_objects']} objects (min_objects = {info['min_objects']})"
                if "min_objects" in info else "dropped by the dataset's attribute filter")
    left_out = [{"attribute": str(a), "reason": filtered} for a in info.get("dropped_attributes", [])]
    left_out += [{"attribute": a, "reason": why} for a, why in chosen.excluded_attributes]
    if not chosen.kept_attributes:
        raise ConfigError(f"{features.dataset}: no attribute can be learned from {len(chosen.train_objects)} training "
                          f"objects: each has fewer than {min_train_positives} positive or {min_train_negatives} "
                          "negative training objects")
    sub = features.subset(np.isin(features.objects, chosen.train_objects))
    sub.attributes = sub.attributes[list(chosen.kept_attributes)]
    return sub, None if splits_file is None else chosen.name, left_out


def left_out_notes(left_out: Sequence[dict]) -> list[str]:
    """``note:`` lines (without the prefix) of the attributes a training command left out, one per attribute."""
    return [f"attribute {r['attribute']!r} left out of the model: {r['reason']}" for r in left_out]


def training_record(features: FeatureSet, left_out: list[dict]) -> dict:
    """What a bundle records of its attributes: the dataset filter's ``min_objects`` (None: none applied)
    and ``left_out_attributes`` (from :func:`training_subset`)."""
    min_objects = (features.info or {}).get("min_objects")
    return {"min_objects": None if min_objects is None else int(min_objects), "left_out_attributes": list(left_out)}


def train_attribute_bundle(features: FeatureSet, config, save, *, method: str | None = None, splits_file=None,
                           split_name: str | None = None, fusion: str = "avg", prior: str = "uni",
                           force: bool = False, echo: Callable[[str], None] | None = None) -> pd.DataFrame:
    """Fit a zero-shot model (all objects, or one split's training objects) and save a bundle.

    Parameters
    ----------
    features : FeatureSet
    config : tzsl.studies.config.ZeroShotSettings
        The study's attribute-SVM settings (used when ``method`` is None).
    save : path
    method : str, optional
        A registered attribute model + decision rule method (``tzsl methods``), fitted with its
        defaults and ``config.splits.seed``. None: the DAP study's tuned per-(attribute, sensor) SVMs
        with ``fusion`` and ``prior``.
    splits_file, split_name
        Train on the training objects of this split only.
    fusion : {"avg", "max"}
    prior : {"uni", "train", "test"}
    force : bool
    echo : callable, optional
        Called with a ``note: ...`` line for each attribute left out (:func:`training_subset` with the
        study's rule; the bundle records them as ``left_out_attributes``), before the fit.

    Returns
    -------
    DataFrame
        DAP: one row per (attribute, sensor) with the chosen ``C``, ``gamma``, under-sampling
        draw and positive training objects; other methods: one row per attribute with its
        positive training objects.
    """
    from tzsl.models.protocol import attribute_rows  # noqa: PLC0415
    from tzsl.studies.comparison.method_runs import method_input, study_estimator  # noqa: PLC0415
    from tzsl.studies.zero_shot.relaxations import trainable_attribute_rule  # noqa: PLC0415
    from tzsl.studies.zero_shot.study import attribute_bank, check_cv_folds, compute_context  # noqa: PLC0415

    sub, split_record, left_out = training_subset(features, splits_file, split_name,
                                                  **trainable_attribute_rule(config.splits))
    if echo is not None:
        for note in left_out_notes(left_out):
            echo(f"note: {note}")
    attributes = list(sub.attributes.columns)
    A = sub.trial_attributes()
    provenance = {"training_objects": sorted(set(sub.objects)), "split": split_record, "seed": config.splits.seed,
                  **training_record(sub, left_out)}
    if method is None:
        check_cv_folds(config.svm.estimator_params().get("cv"), len(set(sub.objects)), "command line")
        dap = ZeroShotClassifier(attribute_model=attribute_bank(config, attributes, config.splits.seed),
                                 decision_rule=DAPRule(fusion=fusion, prior=prior), random_state=config.splits.seed)
        clf = CalibratedZeroShotClassifier(estimator=dap, random_state=config.splits.seed)  # its default calibration
        with compute_context(config):
            clf.fit(sub.X, A, sub.objects)
        save_zero_shot_bundle(save, clf, sub, method=f"dap-{fusion}", ndim=3, force=force,
                              undersampling=config.svm.undersampling, **provenance)
        rows = [{"attribute": name, "sensor": sensor, "C": getattr(est, "C_", np.nan),
                 "gamma": getattr(est, "gamma_", np.nan), "draw": getattr(est, "draw_", -1),
                 "positive_objects": int(sub.attributes[name].sum())}
                for j, name in enumerate(attributes)
                for est, sensor in zip(clf.estimator_.attribute_model_.estimators_[j], sub.sensors, strict=True)]
        return pd.DataFrame(rows)
    spec = {"name": method}
    registered = get_method(method)
    if registered.estimator is not None:
        raise ConfigError(f"method {method!r} is a self-contained estimator; train-attributes saves attribute "
                          "model + decision rule methods (see 'tzsl methods')")
    clf = study_estimator(spec, config.splits.seed)
    objects = sub.objects
    class_rows = sub.attributes.loc[np.unique(objects), attributes].to_numpy(dtype=float)
    clf.fit(method_input(spec, sub.X), attribute_rows(objects, class_rows), objects)
    save_zero_shot_bundle(save, clf, sub, method=method, ndim=registered.input_ndim, force=force, **provenance)
    return pd.DataFrame({"attribute": attributes,
                         "positive_objects": [int(sub.attributes[a].sum()) for a in attributes]})


def train_hand_bundle(grasps_dir: str | Path, table: HandTable, save: str | Path, *, fusion: str = "ldap",
                      seed: int = 0, config=None, force: bool = False) -> tuple[HandDAPClassifier, dict]:
    """Fit the hand model on the training objects' grasps of a grasp folder and save a bundle.

    The bundle holds the HandDAPClassifier (attribute scores: its fused posteriors) and a
    :class:`~tzsl.models.DAPRule` with the model's constant attribute prior; the input schema is
    ``{"format": "hand-grasps", "feature_params": ...}``.

    Returns
    -------
    model : HandDAPClassifier
    metadata : dict
        As saved, plus ``n_training_grasps`` and ``n_ignored_grasps`` (grasps of other objects);
        ``left_out_attributes`` (attributes the grasps cannot teach, with the reason) and
        ``relaxations`` (calibrations with fewer folds), as the model found them.
    """
    from tzsl.studies.config import HandSettings  # noqa: PLC0415
    from tzsl.studies.hand.study import feature_params, fit_hand_model, hand_features  # noqa: PLC0415

    config = HandSettings() if config is None else config
    save = Path(save)
    if save.exists() and not force:
        raise ConfigError(f"{save} already exists; use --force to overwrite it")
    features = hand_features(read_grasps(grasps_dir), table, config)
    model = fit_hand_model(features, table, config, seed, fusion=fusion)
    n_train = int(np.isin(features.objects, table.train_objects).sum())
    names = [str(a) for a in model.K_.columns]
    rule = DAPRule(prior=[float(model.prior)] * len(names)).fit(model.K_.to_numpy(dtype=int))
    left_out = [{"attribute": a, "reason": why} for a, why in model.left_out_attributes_.items()]
    metadata = {
        "material_attributes": list(model.material_attributes_), "shape_attributes": list(model.shape_attributes_),
        "training_objects": [str(c) for c in model.classes_], "fusion": model.fusion, "prior": float(model.prior),
        "class_table": table.source, "grasps": str(grasps_dir), "seed": int(seed),
        "n_training_grasps": n_train, "n_ignored_grasps": len(features) - n_train,
        "left_out_attributes": left_out, "relaxations": list(model.relaxations_),
    }
    schema = {"format": "hand-grasps", "feature_params": dict(feature_params(config))}
    save_model_bundle(save, model, rule, method="hand-dap", attribute_names=names, input_schema=schema, force=force,
                      **metadata)
    return model, {"method": "hand-dap", "attribute_names": names, "input": schema, **metadata}
