"""Active touch for a robot: save a per-EP model, then ask what is known and which EP to do next.

``tzsl train-attributes --per-ep`` fits a :class:`tzsl.models.PerEPAttributeModel` (one
attribute-classifier bank per exploratory procedure, and the EPs' confusion by grouped CV on the
training objects only) and saves it as a bundle of kind :data:`PER_EP_KIND`: the skops payload is
the fitted model (no code runs on loading), the metadata its attribute names, EPs, EP durations and
feature schema (``{"format": "features", ...}`` with EP-prefixed feature names ``"<ep>:<feature>"``).

``tzsl predict --eps-done squeeze,hold [--suggest-next] [--json]`` reads the done EPs' feature
columns of one trial (other columns may be absent: only what the robot has measured is read),
updates the sequential posterior over the candidate classes and, through
:func:`tzsl.models.active_touch.suggest_next_ep`, reports the ranking, whether the stopping rule has decided and
the next EP with the largest expected entropy reduction (bits). :func:`active_report` returns it as
one JSON-serialisable dict (the ``--json`` output).
"""

from __future__ import annotations

import inspect
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from tzsl.datasets import FeatureSet
from tzsl.exceptions import ConfigError, DataFileError, ModelBundleError
from tzsl.inference.bundle import load_bundle, save_bundle
from tzsl.inference.bundle_kinds import PER_EP_KIND
from tzsl.inference.predict_inputs import feature_schema, read_feature_rows
from tzsl.models import PerEPAttributeModel
from tzsl.models.active_touch import ep_column_blocks, suggest_next_ep

__all__ = ["PER_EP_KIND", "active_report", "active_report_from_features", "format_active_report", "load_per_ep_model",
           "train_per_ep_bundle"]



def train_per_ep_bundle(features: FeatureSet, save, *, seed: int = 0, cv: int | None = None,
                        tempering: str | None = None, force: bool = False, **extra) -> dict:
    """Fit a per-EP model on the training objects and save it as a ``per-ep`` bundle.

    Parameters
    ----------
    features : FeatureSet
        The training objects' features (e.g. from
        :func:`tzsl.inference.model_bundles.training_subset`), named ``"<ep>:<feature>"`` (PHAC-2
        Penn features); its attribute columns are the attributes to learn.
    save : path
    seed : int
    cv : int, optional
        Object-grouped folds of the confusion model and of the posterior exponents; default the model's.
    tempering : {"subset", "count", "none"}, optional
        Exponents of the sequential posterior (fitted on pseudo-unseen training objects); default the model's.
    force : bool
    **extra
        JSON-serialisable provenance.

    Returns
    -------
    dict
        The metadata saved.
    """
    sub = features
    params = {**({} if cv is None else {"cv": int(cv)}), **({} if tempering is None else {"tempering": tempering})}
    model = PerEPAttributeModel(ep_columns=ep_column_blocks(sub.feature_names), random_state=seed, **params)
    model.fit(sub.X, sub.trial_attributes(), sub.objects)
    metadata = {"method": "per-ep", "attribute_names": [str(a) for a in sub.attributes.columns],
                "input": feature_schema(sub, 3), "eps": list(model.eps_),
                "ep_seconds": [float(s) for s in model.ep_seconds_],
                "posterior": {"tempering": model.tempering, "exponents": [float(t) for t in model.exponents_],
                              "fitted_on_trials": model.tempering_trials_, "folds": model.cv},
                "training_objects": sorted(set(sub.objects)), "seed": int(seed), "dataset": sub.dataset, **extra}
    save_bundle(save, model, kind=PER_EP_KIND, metadata=metadata, force=force)
    return metadata


def load_per_ep_model(path: str | Path, *, trust_pickle: bool = False) -> tuple[PerEPAttributeModel, dict]:
    """Load a ``per-ep`` bundle (no code is run) and check it.

    Raises
    ------
    ModelBundleError
        Not a per-EP bundle, or a payload that is not a fitted PerEPAttributeModel matching the
        metadata.
    """
    model, metadata = load_bundle(path, expected_kind=PER_EP_KIND, trust_pickle=trust_pickle)
    if not isinstance(model, PerEPAttributeModel) or not hasattr(model, "banks_"):
        raise ModelBundleError(f"{path}: a per-ep bundle must hold a fitted PerEPAttributeModel, "
                               f"found {type(model).__name__}")
    exponents = getattr(model, "exponents_", None)
    if exponents is None or np.shape(exponents) != (2 ** len(model.eps_),):
        raise ModelBundleError(f"{path}: per-ep bundle has no fitted posterior exponents (written before the "
                               "tempered update); re-run 'tzsl train-attributes --per-ep'")
    schema, names = metadata.get("input"), metadata.get("attribute_names")
    if not (isinstance(schema, dict) and isinstance(schema.get("feature_names"), list)
            and isinstance(schema.get("sensors"), list) and isinstance(names, list)
            and len(names) == model.n_attributes_ and len(schema["feature_names"]) == model.n_features_in_
            and len(schema["sensors"]) == model.n_sensors_):
        raise ModelBundleError(f"{path}: per-ep bundle metadata (input, attribute_names) do not match the model")
    return model, metadata


def _done_rows(path: Path, model: PerEPAttributeModel, schema: dict, eps_done: Sequence[str]) -> tuple[dict, str]:
    """Features of the done EPs of the one trial in ``path``: {ep: (n_sensors, n_ep_features)}, trial id."""
    unknown = [ep for ep in eps_done if ep not in model.eps_]
    if unknown or not eps_done:
        raise ConfigError(f"--eps-done: unknown EP(s) {unknown}; the model knows {list(model.eps_)}")
    if len(set(eps_done)) != len(eps_done):
        raise ConfigError(f"--eps-done names an EP twice: {list(eps_done)}")
    names = schema["feature_names"]
    cols = {ep: np.asarray(model.ep_columns[ep], dtype=int) for ep in eps_done}
    sub_schema = {**schema, "feature_names": [names[c] for ep in eps_done for c in cols[ep]]}
    X, ids = read_feature_rows(Path(path), sub_schema)
    if X.shape[0] != 1:
        raise DataFileError(path, f"holds {X.shape[0]} trials; give the features of the one trial being explored")
    out, start = {}, 0
    for ep in eps_done:
        out[ep] = X[0, :, start:start + cols[ep].size]
        start += cols[ep].size
    return out, ids[0]


def active_report(model: PerEPAttributeModel, metadata: dict, classes: pd.DataFrame, features_file: str | Path,
                  eps_done: Sequence[str], *, threshold: float | None = None, max_eps: int | None = None,
                  max_seconds: float | None = None, n_samples: int = 256, random_state=0) -> dict:
    """Ranking, decision and suggested next EP after the EPs done so far on one object.

    Parameters
    ----------
    model, metadata
        From :func:`load_per_ep_model`.
    classes : DataFrame of shape (c, m)
        Candidate classes (:func:`tzsl.inference.predict.read_class_table`), model attribute order.
    features_file : path
        Feature CSV / ``.npz`` of one trial holding (at least) the done EPs' columns.
    eps_done : sequence of str
        EPs done so far, e.g. ``["squeeze", "hold"]``.
    threshold : float, optional
        Stop when the top class posterior reaches it; default :func:`~tzsl.models.active_touch.suggest_next_ep`'s.
    max_eps, max_seconds, n_samples, random_state
        As :func:`~tzsl.models.active_touch.suggest_next_ep`.

    Returns
    -------
    dict (JSON-serialisable)
        ``bundle``, ``trial``, ``threshold`` and the keys of :func:`~tzsl.models.active_touch.suggest_next_ep`:
        ``ranking`` (list of ``{"class", "probability"}``, best first; tempered posterior), ``decided``,
        ``decision``, ``stop_reason``, ``done_eps``, ``seconds_used``, ``next_ep``, ``expected_gain_bits``,
        ``candidates`` (list of ``{"ep", "seconds", "expected_gain_bits"}``, best first), ``posterior``
        (``{"tempering", "exponent", "untempered_top_probability", "fitted_on"}``).
    """
    done, trial = _done_rows(Path(features_file), model, metadata["input"], list(eps_done))
    return active_report_from_features(model, metadata, classes, done, trial, threshold=threshold, max_eps=max_eps,
                                       max_seconds=max_seconds, n_samples=n_samples, random_state=random_state)


def active_report_from_features(model: PerEPAttributeModel, metadata: dict, classes: pd.DataFrame,
                                done: Mapping[str, np.ndarray], trial: str, *, threshold: float | None = None,
                                max_eps: int | None = None, max_seconds: float | None = None, n_samples: int = 256,
                                random_state=0) -> dict:
    """:func:`active_report` of feature arrays already read.

    Parameters
    ----------
    done : mapping of str -> ndarray of shape (n_sensors, n_ep_features)
        Each EP done so far -> its features on this object (that EP's columns, in the bundle's
        feature order, units of training).
    trial : str
        Name of the object being explored (the report's ``trial``).
    model, metadata, classes, threshold, max_eps, max_seconds, n_samples, random_state
        As :func:`active_report`.

    Raises
    ------
    ConfigError
        An unknown EP, none done, or an array of the wrong shape.
    """
    if threshold is None:
        threshold = float(inspect.signature(suggest_next_ep).parameters["threshold"].default)
    unknown = [ep for ep in done if ep not in model.eps_]
    if unknown or not done:
        raise ConfigError(f"EPs done: unknown EP(s) {unknown}; the model knows {list(model.eps_)}")
    for ep, features in done.items():
        shape = (model.n_sensors_, len(model.ep_columns[ep]))
        if np.shape(features) != shape:
            raise ConfigError(f"EP {ep!r}: features of shape {np.shape(features)}; the model needs {shape} "
                              "(sensors x that EP's features)")
    report = suggest_next_ep(model, classes.to_numpy(dtype=int), done, class_names=list(classes.index),
                             threshold=threshold, max_eps=max_eps, max_seconds=max_seconds, n_samples=n_samples,
                             random_state=random_state)
    where = metadata.get("bundle", {}).get("path", "")
    return {"bundle": where, "trial": trial, "threshold": float(threshold), **report}


def format_active_report(report: dict, *, top: int = 5, suggest: bool = True) -> str:
    """The report of :func:`active_report` as text for a person."""
    seconds = f"{report['seconds_used']:g} s"
    lines = [f"trial {report['trial']}: EPs done {', '.join(report['done_eps'])} ({seconds})", "ranking:"]
    ranking = report["ranking"][: top if top > 0 else None]
    width = max(len(r["class"]) for r in ranking)
    lines += [f"  {i + 1:>3}. {r['class']:<{width}}  {r['probability']:.3f}" for i, r in enumerate(ranking)]
    best = report["ranking"][0]
    post = report["posterior"]
    lines.append(f"posterior: tempering {post['tempering']!r}, exponent {post['exponent']:.3g} for the EPs done "
                 f"(untempered top {post['untempered_top_probability']:.3f}); fitted on {post['fitted_on']}")
    if report["decided"]:
        lines.append(f"decided: {report['decision']!r} (stop: {report['stop_reason']}; top posterior "
                     f"{best['probability']:.3f}, threshold {report['threshold']:g})")
    else:
        lines.append(f"not decided: top posterior {best['probability']:.3f} < threshold {report['threshold']:g}")
    if suggest and report["next_ep"] is not None:
        others = ", ".join(f"{c['ep']} {c['expected_gain_bits']:.3f} bits ({c['seconds']:g} s)"
                           for c in report["candidates"][1:])
        first = report["candidates"][0]
        lines.append(f"suggested next EP: {report['next_ep']} (expected entropy reduction "
                     f"{report['expected_gain_bits']:.3f} bits, {first['seconds']:g} s)"
                     + (f"; others: {others}" if others else ""))
    elif suggest:
        lines.append("suggested next EP: none (decided, or no EP left within the budget)")
    return "\n".join(lines)
