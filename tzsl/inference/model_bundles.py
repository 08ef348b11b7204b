"""Make the robot models the train commands save: ``tzsl train-attributes`` and ``tzsl train-hand``.

Each function fits a model on a dataset's training objects (with the study's settings: the
study code is imported when a model is trained, never when this module is imported) and writes
it as a ``"zero-shot"`` bundle (:mod:`tzsl.inference.zero_shot_bundles`: arrays for linear and
DAP models, skops for the others). What ``train-attributes`` fits is one *deployable entry*,
whoever asks for it (:func:`command_entry`: ``--method`` or the generic default; a zero-shot
study's ``deployment.json``: ``--from-results`` and ``[output] model = true``), built by
:func:`deployed_estimator` and fitted by :func:`train_attribute_bundle`. The per-EP (active touch) model is
:func:`tzsl.inference.predict_active.train_per_ep_bundle`; the deep model's bundle is
:mod:`tzsl.inference.deep_bundles`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

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
    "command_entry",
    "deployed_estimator",
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


def command_entry(config, method: str | None = None, fusion: str | None = None,
                  prior: str | None = None) -> dict:
    """The deployable entry ``tzsl train-attributes`` fits without ``--from-results``.

    ``method``: a registered method, fitted with its defaults (``svm`` None). None: the generic default
    :data:`tzsl.models.choices.DEFAULT_METHOD`, the method a zero-shot study keeps unless another beats it
    clearly; a DAP method is built from ``config``'s ``[svm]`` settings (the command's ``--cv``,
    ``--grid``, ``--undersampling``) and ``fusion`` / ``prior`` replace its rule's.

    Returns
    -------
    dict
        ``{"label", "method": {"name": ..., **parameters}, "svm": settings or None}``, as a study's
        ``deployment.json`` holds it.
    """
    from tzsl.models import DAP_METHOD  # noqa: PLC0415
    from tzsl.models.choices import DEFAULT_METHOD  # noqa: PLC0415
    from tzsl.studies.config import dap_settings, method_label  # noqa: PLC0415

    spec: dict[str, Any] = {"name": method or DEFAULT_METHOD}
    given = {k: v for k, v in (("fusion", fusion), ("prior", prior)) if v is not None}
    dap = dap_settings(spec)
    if method is not None or dap is None:
        if given:
            raise ConfigError(f"--{', --'.join(given)} set(s) the rule of the default DAP model; {spec['name']} "
                              "saves its own decision rule")
        return {"label": method_label(spec), "method": spec, "svm": None}
    if given:  # the default's detector, this rule
        spec = {"name": DAP_METHOD, **{**dap, **given}}
    return {"label": method_label(spec), "method": spec, "svm": config.svm.model_dump(mode="json")}


def deployed_estimator(entry: Mapping[str, Any], config, attributes: Sequence[str], seed: int):
    """The unfitted estimator of a deployable entry (:func:`command_entry`, a study's ``deployment.json``).

    ``svm`` None: the registry's method with the entry's parameters, seeded with ``seed``
    (:func:`tzsl.studies.comparison.method_runs.study_estimator`, as the study fitted it on each split).
    ``svm`` settings: the study's own DAP: per-(attribute, sensor) detectors of the entry's family built
    from those ``[svm]`` settings (:func:`tzsl.studies.zero_shot.study.attribute_bank`, ``config``'s
    ``[compute]``), the entry's fusion and prior, calibrated.
    """
    from tzsl.studies.comparison.method_runs import study_estimator  # noqa: PLC0415
    from tzsl.studies.config import SvmSettings, dap_settings  # noqa: PLC0415
    from tzsl.studies.zero_shot.study import attribute_bank  # noqa: PLC0415

    spec = dict(entry["method"])
    if entry.get("svm") is None:
        return study_estimator(spec, seed)
    dap = dap_settings(spec)
    if dap is None:
        raise ConfigError(f"method {spec['name']!r}: [svm] settings apply to DAP only")
    settings = config.model_copy(update={"svm": SvmSettings.model_validate({**entry["svm"],
                                                                            "detector": dap["detector"]})})
    model = ZeroShotClassifier(attribute_model=attribute_bank(settings, list(attributes), seed),
                               decision_rule=DAPRule(fusion=dap["fusion"], prior=dap["prior"]), random_state=seed)
    return CalibratedZeroShotClassifier(estimator=model, random_state=seed)  # its default calibration


def train_attribute_bundle(features: FeatureSet, config, save, *, entry: Mapping[str, Any], splits_file=None,
                           split_name: str | None = None, force: bool = False,
                           echo: Callable[[str], None] | None = None, **provenance) -> pd.DataFrame:
    """Fit a deployable entry (all objects, or one split's training objects) and save a bundle.

    Parameters
    ----------
    features : FeatureSet
    config : tzsl.studies.config.ZeroShotSettings
        ``[splits]`` (seed, which attributes a model can learn) and ``[compute]`` of the fit.
    save : path
    entry : dict
        What to fit (:func:`command_entry`, or a study's ``deployment.json``): ``label`` (the bundle's
        ``method``, shown by ``tzsl predict``), ``method`` (a registry entry) and ``svm``
        (:func:`deployed_estimator`); the bundle records ``method_entry`` and ``svm_settings``.
    splits_file, split_name
        Train on the training objects of this split only.
    force : bool
    echo : callable, optional
        Called with a ``note: ...`` line for each attribute left out (:func:`training_subset` with the
        study's rule; the bundle records them as ``left_out_attributes``), before the fit.
    **provenance
        More JSON metadata for the bundle (``deployment``: where the choice came from).

    Returns
    -------
    DataFrame
        DAP built from ``[svm]`` settings: one row per (attribute, sensor) with the chosen ``C``,
        ``gamma``, under-sampling draw and positive training objects; other methods: one row per
        attribute with its positive training objects.
    """
    from tzsl.models.protocol import attribute_rows  # noqa: PLC0415
    from tzsl.studies.comparison.method_runs import method_input  # noqa: PLC0415
    from tzsl.studies.zero_shot.relaxations import trainable_attribute_rule  # noqa: PLC0415
    from tzsl.studies.zero_shot.study import check_cv_folds, compute_context  # noqa: PLC0415

    spec = dict(entry["method"])
    registered = get_method(str(spec["name"]))
    if registered.estimator is not None:
        raise ConfigError(f"method {spec['name']!r} is a self-contained estimator; train-attributes saves attribute "
                          "model + decision rule methods (see 'tzsl methods')")
    sub, split_record, left_out = training_subset(features, splits_file, split_name,
                                                  **trainable_attribute_rule(config.splits))
    if echo is not None:
        for note in left_out_notes(left_out):
            echo(f"note: {note}")
    attributes = list(sub.attributes.columns)
    seed = config.splits.seed
    record = {"training_objects": sorted(set(sub.objects)), "split": split_record, "seed": seed,
              **training_record(sub, left_out), "method_entry": spec, "svm_settings": entry.get("svm"), **provenance}
    clf = deployed_estimator(entry, config, attributes, seed)
    svm = entry.get("svm")
    if svm is not None:
        check_cv_folds(svm.get("cv"), len(set(sub.objects)), "command line")
        with compute_context(config):
            clf.fit(sub.X, sub.trial_attributes(), sub.objects)
        save_zero_shot_bundle(save, clf, sub, method=str(entry["label"]), ndim=3, force=force,
                              undersampling=svm.get("undersampling"), **record)
        return pd.DataFrame([{"attribute": name, "sensor": sensor, "C": getattr(est, "C_", np.nan),
                              "gamma": getattr(est, "gamma_", np.nan), "draw": getattr(est, "draw_", -1),
                              "positive_objects": int(sub.attributes[name].sum())}
                             for j, name in enumerate(attributes)
                             for est, sensor in zip(clf.estimator_.attribute_model_.estimators_[j], sub.sensors,
                                                    strict=True)])
    objects = sub.objects
    class_rows = sub.attributes.loc[np.unique(objects), attributes].to_numpy(dtype=float)
    clf.fit(method_input(spec, sub.X), attribute_rows(objects, class_rows), objects)
    save_zero_shot_bundle(save, clf, sub, method=str(entry["label"]), ndim=registered.input_ndim, force=force,
                          **record)
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
