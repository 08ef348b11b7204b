"""Building blocks of the experiment schema: the strict section base and shared sections."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator

from tzsl.value_lists import FUSIONS, PRIORS, STUDY_BACKENDS

#: Largest seed numpy's legacy RandomState and scikit-learn accept (exclusive).
SEED_LIMIT = 2**32

#: ``[dataset]`` settings that name what a study reads, and whether each is a file or a folder (checked
#: before a run by the engine, listed in the study cache's key).
DATASET_PATHS: dict[str, Literal["file", "folder"]] = {
    "plain": "folder", "features": "file", "path": "file", "data_dir": "folder", "grasps": "folder",
    "table": "file", "gelsight_root": "folder",
}


class Section(BaseModel):
    """A table of an experiment file: unknown keys and wrong types are errors.

    ``strict=True``: no silent conversions (``"3"`` is not an integer, ``true`` not a number);
    an integer is accepted where a number is expected.
    """

    model_config = ConfigDict(extra="forbid", strict=True, validate_default=False, frozen=False)


Seed = Field(default=0, ge=0, lt=SEED_LIMIT, description="random seed, 0 <= seed < 2**32")

#: ``[splits] purpose`` (tzsl.evaluation.PURPOSES): which random splits a seed draws, and the fits' seed.
Purpose: Literal["select", "confirm"] = Field(
    default="confirm", description="'select': splits that make a choice (a method, a grid); 'confirm': splits "
                                   "that report it. No seed of one purpose draws a random split of the other; "
                                   "the purpose also seeds the fits")


def distinct(values: list) -> list:
    """Refuse lists that name one value twice."""
    seen = [repr(v) for v in values]
    if len(set(seen)) != len(seen):
        raise ValueError("lists a value twice")
    return values


def non_empty(values: list) -> list:
    if not values:
        raise ValueError("must not be empty")
    return values


def check_n_jobs(value: int) -> int:
    """``n_jobs`` in joblib's sense (workers; -1 = every core), refused when 0 (``[compute]`` and ``--n-jobs``)."""
    if value == 0:
        raise ValueError("n_jobs = 0 runs nothing; use 1, 2, ... workers or -1 for every core")
    return value


class Compute(Section):
    """``[compute]``: parallel fits and progress bars."""

    n_jobs: int = Field(default=1, description="parallel fits (joblib); -1 = every core; never 0")
    progress: bool = Field(default=True, description="progress bars")

    _n_jobs = field_validator("n_jobs")(check_n_jobs)


class DaskCompute(Compute):
    """``[compute]`` of studies that can run their fits on a Dask cluster, with a fit cache."""

    backend: Literal[STUDY_BACKENDS] = Field(default="loky", description="joblib backend")  # type: ignore[valid-type]  # Literal of a value list: pydantic reads it at run time, mypy cannot
    scheduler: str | None = Field(default=None, description="Dask scheduler address (tcp://host:port) for backend = "
                                                           "'dask'; unset = a local cluster")
    connect_timeout: float = Field(default=10.0, gt=0, description="seconds to wait for the Dask scheduler")
    cache: bool = Field(default=True, description="cache fitted attribute models (resumable runs)")


class Output(Section):
    """``[output]``: where the results go."""

    folder: str = Field(default="results", description="results folder, relative to the current directory")


def lambdas_ok(values: list) -> list:
    """The embedding model's lambdas: numbers >= 0 or the string "inf"."""
    for v in values:
        if isinstance(v, str):
            if v != "inf":
                raise ValueError(f'{v!r}: expected a number >= 0 or "inf"')
        elif v < 0:
            raise ValueError(f"{v!r}: expected a number >= 0 or \"inf\"")
    return distinct(non_empty(values))


# --------------------------------------------------------------------------- registry methods

#: ``methods.compare`` entries: a registry name, or ``{name = "...", <parameter> = value, ...}``.
MethodEntry = str | dict[str, Any]

COMPARE_DESCRIPTION = ('registry methods (tzsl methods) run on the same splits: "eszsl", '
                       '{name = "embedding", lam = 0.1} or {name = "dap", detector = "logistic"}')


#: The parameters of the registry's DAP (``tzsl.models.DAP_METHOD``) that its row label names (:func:`dap_label`).
DAP_LABEL_KEYS = ("fusion", "detector", "prior")


def dap_settings(spec: dict) -> dict | None:
    """The fusion, detector and prior of a method entry of the registry's DAP, else None.

    The entry names ``dap`` or one of its aliases (``dap-max``: ``fusion = "max"``); what it does not
    set is the method's default (:meth:`tzsl.models.Method.parameters`). None for another method or an
    unknown name (which :func:`methods_ok` reports).
    """
    from tzsl.models import DAP_METHOD, get_method, method_aliases  # noqa: PLC0415 (the registry, read when named)

    name = spec.get("name")
    if not isinstance(name, str):
        return None
    entry = {**method_aliases().get(name, {"name": name}), **{k: v for k, v in spec.items() if k != "name"}}
    if entry["name"] != DAP_METHOD:
        return None
    defaults = get_method(DAP_METHOD).parameters()
    return {key: entry.get(key, defaults[key]) for key in DAP_LABEL_KEYS}


def method_label(spec: dict) -> str:
    """Column/row label of a method entry: ``{"name": "embedding", "lam": 0.1}`` -> ``embedding_lam_0.1``.

    An entry of the registry's DAP (``dap`` or an alias) is named by :func:`dap_label` of its fusion,
    detector and prior, then its other parameters: ``"dap-avg-logistic-c1"`` and ``{name = "dap",
    detector = "logistic-c1"}`` are both ``dap-avg-logistic-c1``, ``{name = "dap-avg", solver =
    "exact"}`` is ``dap-avg_solver_exact``.
    """
    dap = dap_settings(spec)
    named: tuple[str, ...] = ()
    if dap is not None and all(isinstance(value, str) for value in dap.values()):
        parts = [dap_label(dap["fusion"], dap["detector"], prior=dap["prior"])]
        named = DAP_LABEL_KEYS
    else:
        parts = [spec["name"]]
    for key, value in spec.items():
        if key != "name" and key not in named:
            parts.append(f"{key}_{value:g}" if isinstance(value, float) else f"{key}_{value}")
    return "_".join(parts)


def dap_label(fusion: str, detector: str = "rbf-svm", *, prior: str = "uni") -> str:
    """Row label of a DAP configuration: the study's own DAP with ``fusion`` and ``prior``, or the registry's
    ``dap`` with these parameters (:func:`method_label`).

    ``dap-avg`` / ``dap-max`` with the paper's RBF-SVM detectors and the uniform prior; with another
    detector the family follows the fusion (``dap-avg-logistic-c1``, also the name of the alias of that
    configuration); another prior follows last (``dap-max-train-prior``, ``dap-avg-logistic-c1-test-prior``).
    """
    base = f"dap-{fusion}" if detector == "rbf-svm" else f"dap-{fusion}-{detector}"
    return base if prior == "uni" else f"{base}-{prior}-prior"


def registered_method(label: str) -> str:
    """The registered method a row label of a method comparison is a configuration of.

    ``dap`` for every DAP label (:func:`dap_label` of any fusion, detector and prior: the study's own rows
    and the registry's ``dap`` entries, aliases included), else the method an alias names, else the label
    up to its first ``_`` (``embedding_lam_0.1``: ``embedding``).
    """
    from tzsl.models import DAP_METHOD, method_aliases  # noqa: PLC0415 (the registry, read when a table is stacked)
    from tzsl.models.detectors import DETECTORS  # noqa: PLC0415 (the models, read when a table is stacked)

    name = label.split("_")[0]
    if name in {dap_label(f, d, prior=p) for f in FUSIONS for d in DETECTORS for p in PRIORS}:
        return DAP_METHOD
    return str(method_aliases().get(name, {"name": name})["name"])


def methods_ok(values: list, taken: tuple[str, ...] = ()) -> list[dict]:
    """``methods.compare`` checked against the method registry, each entry as ``{"name": ..., **params}``.

    A name is a method or an alias (``dap-avg``); a string value a parameter does not take is reported
    at its key (``@methods.compare[0].detector: ...``). ``taken``: labels the study already runs
    (refused here, so no column is computed twice).
    """
    from tzsl.exceptions import ConfigError  # noqa: PLC0415
    from tzsl.models import get_method  # noqa: PLC0415 (the registry; imported only when methods are listed)

    specs, problems, labels = [], [], list(taken)
    for i, entry in enumerate(values):
        key = f"methods.compare[{i}]"
        spec = {"name": entry} if isinstance(entry, str) else dict(entry)
        name = spec.get("name")
        if not isinstance(name, str):
            problems.append(f"@{key}.name: missing (a registry method name)")
            continue
        try:
            method = get_method(name)
            params = {k: v for k, v in spec.items() if k != "name"}
            refused = method.value_problems(params)  # one line per value, at its key
            if refused:
                problems += [f"@{key}.{param}: {why}" for param, why in refused.items()]
                continue
            method.build(**params)
        except ConfigError as exc:
            where = f"{key}.name" if str(exc).startswith("unknown method") else key
            problems.append(f"@{where}: {exc}")
            continue
        if method.input_kind != "features":
            problems.append(f"@{key}.name: method {name!r} takes {method.input_kind}, not feature vectors "
                            "(its own study runs it)")
            continue
        label = method_label(spec)
        if label in labels:
            problems.append(f"@{key}: {label!r} is already run (listed twice, or by another [methods] key)")
        labels.append(label)
        specs.append(spec)
    if problems:
        raise ValueError("\n".join(problems))
    return specs
