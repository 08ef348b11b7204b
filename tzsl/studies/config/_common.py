"""Building blocks of the experiment schema: the strict section base and shared sections."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator

from tzsl.value_lists import STUDY_BACKENDS

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

COMPARE_DESCRIPTION = ('registry methods (tzsl methods) run on the same splits: "eszsl" or '
                       '{name = "embedding", lam = 0.1}')


def method_label(spec: dict) -> str:
    """Column/row label of a method entry: ``{"name": "embedding", "lam": 0.1}`` -> ``embedding_lam_0.1``."""
    parts = [spec["name"]]
    for key, value in spec.items():
        if key != "name":
            parts.append(f"{key}_{value:g}" if isinstance(value, float) else f"{key}_{value}")
    return "_".join(parts)


def dap_label(fusion: str, detector: str = "rbf-svm", *, prior: str = "uni") -> str:
    """Row label of the study's own DAP with ``fusion`` and ``prior``.

    ``dap-avg`` / ``dap-max`` with the paper's RBF-SVM detectors and the uniform prior; with another
    ``[svm] detector`` the family follows the fusion (``dap-avg-logistic-c1``: the name of the registered
    method it is); another prior follows last (``dap-max-train-prior``, ``dap-avg-logistic-c1-test-prior``).
    """
    base = f"dap-{fusion}" if detector == "rbf-svm" else f"dap-{fusion}-{detector}"
    return base if prior == "uni" else f"{base}-{prior}-prior"


def methods_ok(values: list, taken: tuple[str, ...] = ()) -> list[dict]:
    """``methods.compare`` checked against the method registry, each entry as ``{"name": ..., **params}``.

    ``taken``: labels the study already runs (refused here, so no column is computed twice).
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
            method.build(**{k: v for k, v in spec.items() if k != "name"})
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
