"""The method a zero-shot study would deploy: chosen on the dataset's classes only, recorded, carried.

A zero-shot study's random splits are pseudo-unseen, object-grouped splits of the dataset's classes,
which are the classes a deployed model is trained on; so they are the cross-validation of the deploy
choice, and the choice reads their own scores (nothing is fitted again). The rule, fixed before any
result was seen (:data:`DEPLOY_RULE`):

1. candidates: the methods of the study a model bundle can hold (the study's own DAP, each fusion with
   the uniform prior, and every compared attribute model + decision rule method) that completed every
   scored split;
2. each is scored by its per-class mean accuracy on each split, averaged over the splits, with its
   two-level bootstrap 95% interval (:func:`tzsl.evaluation.bootstrap_accuracy`);
3. with fewer than :data:`MIN_SPLITS` splits the generic default
   (:data:`tzsl.models.choices.DEFAULT_METHOD`) is kept, and the record says why;
4. when the default did not complete every split, the most accurate candidate is chosen, and the
   record says so;
5. otherwise the most accurate candidate replaces the default only when its paired gain over the
   default (:func:`tzsl.evaluation.paired_difference_interval`: same splits, same classes) has a 95%
   interval above 0.

The chosen method's accuracy on these splits is optimistic (it was chosen on them; :data:`SELECTION_NOTE`).
:func:`study_deployment` makes the record ``deployment.json`` holds; ``tzsl train-attributes
--from-results`` reads it back (:func:`read_deployment`, :func:`dataset_values`,
:func:`check_dataset`) and trains that entry on every object
(:func:`tzsl.inference.model_bundles.train_attribute_bundle`).
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from tzsl._io import file_sha256
from tzsl.evaluation import bootstrap_accuracy, paired_difference_interval
from tzsl.exceptions import ConfigError, TzslError
from tzsl.models import DAP_METHOD, get_method
from tzsl.models.choices import DEFAULT_METHOD
from tzsl.studies.comparison.method_runs import comparison_trials
from tzsl.studies.config import dap_label, method_label
from tzsl.studies.zero_shot.tables import split_label
from tzsl.value_lists import FUSIONS

if TYPE_CHECKING:
    from tzsl.studies.zero_shot.split_posteriors import SplitPosteriors

__all__ = [
    "DEPLOYMENT_FILE", "DEPLOY_RULE", "MIN_SPLITS", "MODEL_FILE", "SELECTION_NOTE", "check_dataset",
    "choose_deployment", "class_accuracy", "dap_class_accuracy", "data_fingerprint", "dataset_values", "default_entry",
    "deployable", "deployment_candidates", "read_deployment", "study_deployment",
]

#: The file of a results folder that holds the deploy choice.
DEPLOYMENT_FILE = "deployment.json"
#: Per (method, split, test class): the share of the class's test trials recognised, on the splits the choice
#: reads (the random or the file splits); a split's per-class mean accuracy is the mean of its classes' rows.
CLASS_ACCURACY_FILE = "class_accuracy.csv"
#: The model bundle ``[output] model = true`` writes beside it.
MODEL_FILE = "model.tzsl"
#: Fewest completed random splits the choice is made on; below it the generic default is kept.
MIN_SPLITS = 2
#: The rule, as the record states it.
DEPLOY_RULE = (f"per-class mean accuracy over the study's random splits (pseudo-unseen, object-grouped splits of "
               f"the dataset's classes) of every deployable method that completed every split; the generic "
               f"default ({DEFAULT_METHOD}) stays unless the most accurate method's paired gain over it has a 95% "
               f"interval above 0; fewer than {MIN_SPLITS} splits: the default; the default not run: the most "
               "accurate")
#: What the record says of the chosen method's numbers.
SELECTION_NOTE = ("its accuracy on these splits is optimistic: it was chosen on them (selection); confirm it on "
                  "other splits before reporting it")
#: Keys a readable deployment.json must have.
_REQUIRED = ("label", "method", "svm", "dataset", "seed", "splits", "branch", "reason")


def class_accuracy(trials: pd.DataFrame) -> pd.DataFrame:
    """Per (method, split, class): the share of the class's test trials recognised.

    ``trials``: :func:`tzsl.studies.comparison.method_runs.comparison_trials` rows (``method``,
    ``split``, ``class``, ``correct``). Returns columns ``method``, ``split``, ``class``, ``accuracy``.
    """
    grouped = trials.groupby(["method", "split", "class"], sort=False)["correct"].mean()
    return grouped.rename("accuracy").reset_index()


def dap_class_accuracy(results: Sequence[SplitPosteriors]) -> pd.DataFrame:
    """:func:`class_accuracy` of the study's own DAP rows (each fusion, uniform prior) on its fitted splits: the
    deploy choice's scores when no method was compared on them."""
    trials = [comparison_trials(dap_label(fusion, getattr(r.model, "detector", "rbf-svm")), split_label(r.split),
                                np.asarray(r.split.test_objects)[r.y], r.predict(fusion, "uni") == r.y)
              for r in results for fusion in FUSIONS]
    return class_accuracy(pd.concat(trials, ignore_index=True)) if trials else pd.DataFrame(
        columns=["method", "split", "class", "accuracy"])


def deployable(spec: Mapping[str, Any]) -> bool:
    """Whether a model bundle can hold the method entry: an attribute model + decision rule on feature vectors."""
    try:
        method = get_method(str(spec["name"]))
    except TzslError:
        return False
    return method.estimator is None and method.input_kind == "features"


def _dap_entry(fusion: str, detector: str) -> dict:
    """The method entry of the study's own DAP row (uniform prior): the registry's ``dap`` with its settings."""
    return {"name": DAP_METHOD, "detector": detector, "fusion": fusion, "prior": "uni"}


def deployment_candidates(config) -> dict[str, dict]:
    """Label -> deployable entry of every method of a zero-shot study a bundle can hold.

    An entry is ``{"label", "method": {"name": ..., **parameters}, "svm": settings or None}``: the
    study's own DAP rows (built from its ``[svm]`` settings, ``svm`` the table as used) and every
    compared method entry that :func:`deployable` (built from the registry, ``svm`` None).
    """
    svm = config.svm.model_dump(mode="json")
    out = {dap_label(f, config.svm.detector): {"label": dap_label(f, config.svm.detector),
                                               "method": _dap_entry(f, config.svm.detector), "svm": svm}
           for f in FUSIONS}
    for spec in config.methods.method_specs():
        if deployable(spec):
            out[method_label(spec)] = {"label": method_label(spec), "method": dict(spec), "svm": None}
    return out


def default_entry() -> dict:
    """The generic default (:data:`~tzsl.models.choices.DEFAULT_METHOD`) as a registry entry."""
    spec = {"name": DEFAULT_METHOD}
    return {"label": method_label(spec), "method": spec, "svm": None}


def _numbers(rows: pd.DataFrame) -> dict[str, float]:
    iv = bootstrap_accuracy(rows["accuracy"].to_numpy(), classes=rows["class"].to_numpy(),
                            splits=rows["split"].to_numpy(), metric="class_mean")
    return {"mean": iv.mean, "ci95_low": iv.ci95_low, "ci95_high": iv.ci95_high}


def _shown(label: str, numbers: Mapping[str, float], sign: str = "") -> str:
    return (f"{label} {numbers['mean']:{sign}.3f} [{numbers['ci95_low']:{sign}.3f}, "
            f"{numbers['ci95_high']:{sign}.3f}]")


def choose_deployment(table: pd.DataFrame, candidates: Mapping[str, dict], default: Mapping[str, Any], *,
                      split_kind: str = "random") -> dict[str, Any]:
    """Apply :data:`DEPLOY_RULE` to per-(method, split, class) accuracies.

    Parameters
    ----------
    table : DataFrame
        :func:`class_accuracy` of the study's scored splits (methods that are not candidates are ignored).
    candidates : dict
        Label -> deployable entry (:func:`deployment_candidates`), in the study's order (ties go to the
        default, then to the earlier candidate).
    default : dict
        The generic default's entry (:func:`default_entry`); the study's candidate of the same label,
        when it ran, is used instead (it carries the study's configuration).
    split_kind : str
        What the splits are (``random``, or ``file`` for a split file), for the record.

    Returns
    -------
    dict
        The chosen entry (``label``, ``method``, ``svm``), ``branch`` (``too-few-splits``,
        ``default-most-accurate``, ``clear-winner``, ``default-kept``, ``default-not-run``), ``reason``
        (one sentence), ``rule``, ``metric``, ``split_kind``, ``n_splits``, ``chance``, ``chosen`` and
        ``default`` (mean and 95% interval, when scored), ``paired`` (the most accurate minus the
        default, when both ran), ``candidates`` (every scored one), ``incomplete`` (candidates that
        missed a split) and ``selection_note``.
    """
    default_label = str(default["label"])
    splits = list(dict.fromkeys(table["split"])) if len(table) else []
    complete = {}
    for label in candidates:
        rows = table[table["method"] == label]
        if splits and set(rows["split"]) == set(splits) and rows["accuracy"].notna().all():
            complete[label] = rows
    numbers = {label: _numbers(rows) for label, rows in complete.items()}
    first = table[table["method"] == next(iter(complete))] if complete else table.iloc[0:0]
    chance = float(first.groupby("split")["class"].nunique().rdiv(1.0).mean()) if len(first) else float("nan")
    order = list(candidates)
    ranked = sorted(numbers, key=lambda m: (-numbers[m]["mean"], m != default_label, order.index(m)))
    record: dict[str, Any] = {
        "rule": DEPLOY_RULE, "metric": "per-class mean accuracy", "split_kind": split_kind, "n_splits": len(splits),
        "chance": chance, "default": {"label": default_label, "ran": default_label in numbers,
                                      **numbers.get(default_label, {})},
        "candidates": [{"label": m, **numbers[m]} for m in ranked],
        "incomplete": [m for m in candidates if m not in complete and (table["method"] == m).any()],
        "paired": None, "selection_note": SELECTION_NOTE}
    kind = f"{len(splits)} {split_kind} split(s)"
    if len(splits) < MIN_SPLITS or not ranked:
        why = (f"only {kind} completed, fewer than the {MIN_SPLITS} the choice needs" if len(splits) < MIN_SPLITS
               else f"no deployable method completed every one of the {kind}")
        return _chosen(record, candidates.get(default_label, default), "too-few-splits", numbers,
                       f"{why}: the generic default {default_label}, chosen on no split of this dataset")
    best = ranked[0]
    if default_label not in numbers:
        missed = ("did not complete every split" if (table["method"] == default_label).any()
                  else "was not run in this study")
        return _chosen(record, candidates[best], "default-not-run", numbers,
                       f"the generic default {default_label} {missed}, so the most accurate of {len(ranked)} on "
                       f"{kind}: {_shown(best, numbers[best])}, chance {chance:.3f}")
    if best == default_label:
        return _chosen(record, candidates[best], "default-most-accurate", numbers,
                       f"the generic default is the most accurate of {len(ranked)} on {kind}: "
                       f"{_shown(best, numbers[best])}, chance {chance:.3f}")
    pair = table[table["method"].isin([best, default_label])].pivot_table(
        index=["split", "class"], columns="method", values="accuracy", aggfunc="first")
    iv = paired_difference_interval(pair[best].to_numpy(), pair[default_label].to_numpy(),
                                    classes=pair.index.get_level_values("class").to_numpy(),
                                    splits=pair.index.get_level_values("split").to_numpy(), metric="class_mean")
    record["paired"] = {"method": best, "reference": default_label, "mean": iv.mean, "ci95_low": iv.ci95_low,
                        "ci95_high": iv.ci95_high}
    gain = _shown("", record["paired"], "+").strip()
    if iv.ci95_low > 0:
        return _chosen(record, candidates[best], "clear-winner", numbers,
                       f"{best} beats the generic default {default_label} clearly on {kind}: paired gain {gain} "
                       f"(interval above 0); {_shown(best, numbers[best])}, chance {chance:.3f}")
    return _chosen(record, candidates[default_label], "default-kept", numbers,
                   f"{best} is the most accurate on {kind} but its paired gain over the generic default, {gain}, "
                   f"does not clear 0, so the default stays: {_shown(default_label, numbers[default_label])}, "
                   f"chance {chance:.3f}")


def _chosen(record: dict, entry: Mapping[str, Any], branch: str, numbers: Mapping[str, dict], reason: str) -> dict:
    label = str(entry["label"])
    return {"label": label, "method": dict(entry["method"]), "svm": entry.get("svm"), "branch": branch,
            "reason": reason, "chosen": numbers.get(label), **record}


# ----------------------------------------------------------------------------- the study's record


def data_fingerprint(paths: Sequence[str | Path]) -> str | None:
    """sha256 of the sorted sha256 of the files' contents (where they lie does not count); None: no file."""
    digests = sorted(file_sha256(p) for p in paths)
    return hashlib.sha256("\n".join(digests).encode()).hexdigest() if digests else None


def _dataset_record(exp, features) -> dict[str, Any]:
    """What ``train-attributes --from-results`` needs to read the study's dataset again, and its fingerprint."""
    ds = exp.config.dataset

    def absolute(value):
        return None if value is None else str(exp.resolve(value).resolve())

    return {"name": features.dataset, "builtin": ds.builtin, "plain": absolute(ds.plain),
            "features": absolute(ds.features), "path": absolute(ds.path), "data_dir": absolute(ds.data_dir),
            "min_objects": ds.min_objects, "signal_features": exp.config.features.model_dump(mode="json"),
            "n_objects": int(features.n_objects),
            "fingerprint": data_fingerprint(features.info.get("data_files", []))}


def study_deployment(exp, features, table: pd.DataFrame, split_kind: str) -> dict[str, Any]:
    """The record of ``deployment.json`` for a zero-shot study (``exp`` as run, after any relaxation).

    ``table``: :func:`class_accuracy` of the study's scored (random or file) splits; empty when it
    has none. Adds to :func:`choose_deployment`'s record the dataset (paths, attribute filter,
    fingerprint), the seed and the ``[splits]`` keys that decide which attributes a model can learn.
    """
    c = exp.config
    chosen = choose_deployment(table, deployment_candidates(c), default_entry(), split_kind=split_kind)
    return {**chosen, "study": exp.study, "experiment": exp.source, "purpose": c.splits.purpose,
            "seed": c.splits.seed, "splits": {"random_min_train_positives": c.splits.random_min_train_positives,
                                              "min_train_negatives": c.splits.min_train_negatives},
            "dataset": _dataset_record(exp, features), "model_file": MODEL_FILE if c.output.model else None}


# ----------------------------------------------------------------------------- reading it back


def read_deployment(where: str | Path) -> tuple[Path, dict[str, Any]]:
    """The deploy choice of a results folder (its ``deployment.json``, or the one ``*_deployment.json``), or
    that file given directly.

    Raises
    ------
    ConfigError
        One line naming the file: missing, not JSON, or without a key the training needs.
    """
    where = Path(where)
    path = where
    if where.is_dir():
        path = where / DEPLOYMENT_FILE
        found = sorted(where.glob(f"*_{DEPLOYMENT_FILE}"))
        if not path.is_file() and len(found) == 1:
            path = found[0]
    if not path.is_file():
        raise ConfigError(f"{path}: no deploy choice here; run a zero-shot study (study = 'zero-shot', tzsl run) "
                          "into this folder first")
    try:
        record = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ConfigError(f"{path}: not a readable deploy choice ({exc})") from None
    if not isinstance(record, dict):
        raise ConfigError(f"{path}: not a readable deploy choice (expected a JSON object)")
    missing = [key for key in _REQUIRED if key not in record]
    method, dataset = record.get("method"), record.get("dataset")
    if not missing and not (isinstance(method, dict) and isinstance(method.get("name"), str)):
        missing = ["method.name"]
    if not missing and not isinstance(dataset, dict):
        missing = ["dataset"]
    if missing:
        raise ConfigError(f"{path}: key {missing[0]!r} missing or malformed; re-run the study to write it again")
    return path, record


def dataset_values(path: Path, record: Mapping[str, Any], given: Mapping[str, str | None]) -> dict[str, Any]:
    """The experiment keys (``{"dataset.plain": ..., ...}``) that read the study's dataset again.

    ``given``: the dataset options of the command (``builtin``, ``plain``, ``features``, ``path``; None
    when not given); one that names another dataset than the study's is refused.
    """
    ds = record["dataset"]
    for key, value in given.items():
        if value is None:
            continue
        recorded = ds.get(key)
        same = recorded == value if key == "builtin" else (
            recorded is not None and Path(value).expanduser().resolve() == Path(recorded))
        if not same:
            raise ConfigError(f"{path}: the study ran on {key} = {recorded!r}, not {value!r}; leave out the dataset "
                              "options, or train that dataset with --method")
    values = {f"dataset.{key}": ds.get(key) for key in ("builtin", "plain", "features", "path", "data_dir")}
    values["dataset.min_objects"] = None if ds.get("features") else ds.get("min_objects")
    for key, value in (ds.get("signal_features") or {}).items():
        if value is not None:
            values[f"features.{key}"] = value
    values.update({f"splits.{key}": value for key, value in record["splits"].items()})
    values["splits.seed"] = record["seed"]
    return {k: v for k, v in values.items() if v is not None}


def check_dataset(path: Path, record: Mapping[str, Any], features) -> None:
    """Refuse to train on data that differ from the study's (another fingerprint of the files read)."""
    recorded = record["dataset"].get("fingerprint")
    now = data_fingerprint(features.info.get("data_files", []))
    if recorded is not None and now != recorded:
        raise ConfigError(f"{path}: the dataset's files differ from those the study read (fingerprint "
                          f"{str(now)[:12]} != {str(recorded)[:12]}); re-run the study on these data")
