"""``tzsl run EXPERIMENT.toml``: a whole study described by one TOML file.

An experiment file names a study (``study = "phac2-dap" | "fabric" | "hand"``) and its
settings in tables: ``[dataset]``, ``[features]``, ``[methods]``, ``[splits]``, ``[svm]``,
``[gzsl]``, ``[compute]``, ``[output]`` (which of them a study accepts, and every key, is
in :data:`SCHEMAS`; ``experiments/README.md`` explains them). :func:`load_experiment` parses
the file with :mod:`tomllib`, checks every key (unknown keys, wrong types, bad choices are
all listed at once, each with the file name and key path) and fills in defaults;
:func:`run_experiment` runs the study into a results folder and writes ``manifest.json``
with the resolved settings and the experiment file itself.

Paths in ``[dataset]`` are relative to the experiment file; ``[output] folder`` (and
``--out``) relative to the current directory. The shipped ``experiments/phac2_dap.toml``,
``fabric.toml`` and ``hand_simulated.toml`` run exactly what ``tzsl reproduce-tables``
runs (a test compares the resulting :class:`~tzsl.experiments.phac2_dap.DapStudyConfig`).
"""

from __future__ import annotations

import math
import os
import tomllib
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import pandas as pd

from tzsl._io import file_sha256
from tzsl.exceptions import ConfigError
from tzsl.experiments._outputs import ResultsDir

__all__ = [
    "SCHEMAS",
    "STUDIES",
    "Experiment",
    "Opt",
    "dap_config",
    "fabric_arguments",
    "gzsl_config",
    "hand_config",
    "load_experiment",
    "run_experiment",
]

_REQUIRED = object()


@dataclass(frozen=True)
class Opt:
    """One key of an experiment file: its type, default and allowed values.

    ``kind``: ``string``, ``integer``, ``number``, ``boolean``, ``strings``, ``integers``,
    ``numbers``, ``lambdas`` (numbers or ``"inf"``), ``range`` (two increasing positive
    numbers) or ``table`` (any TOML table, passed on as is). ``default=None`` means "not
    given" (the study's own default applies).
    """

    kind: str
    default: Any = None
    choices: tuple = ()
    minimum: float | None = None
    help: str = ""


_DATA_DIR = Opt("string", help="data home (default: $TZSL_DATA_DIR or the user data folder)")
_COMPUTE = {
    "n_jobs": Opt("integer", 1, help="parallel fits (joblib); -1 = every core"),
    "progress": Opt("boolean", True, help="progress bars"),
}
_OUTPUT = {"folder": Opt("string", "results", help="results folder, relative to the current directory")}

#: Accepted tables and keys of each study. Nested dicts are tables.
SCHEMAS: dict[str, dict[str, dict[str, Opt]]] = {
    "phac2-dap": {
        "dataset": {
            "builtin": Opt("string", choices=("phac2-penn", "phac2-h5", "phac2-hold-mat"),
                           help="a built-in dataset"),
            "plain": Opt("string", help="a plain-file dataset folder (tzsl formats)"),
            "features": Opt("string", help="a feature table written by tzsl extract --out"),
            "path": Opt("string", help="the HDF5 file of builtin = 'phac2-h5'"),
            "data_dir": _DATA_DIR,
            "min_objects": Opt("integer", minimum=1, help="keep attributes present in >= this many objects "
                                                          "(builtin default 3; plain/features: keep all)"),
        },
        "features": {
            "statistics": Opt("strings", help="per-channel statistics of signal files"),
            "baseline_rows": Opt("integer", minimum=0, help="baseline rows subtracted from signal files"),
            "channels": Opt("strings", help="signal channels to use, in order"),
        },
        "methods": {
            "dap": Opt("boolean", True, help="DAP with independent attribute SVMs (always run)"),
            "fusions": Opt("strings", ["max", "avg"], choices=("max", "avg"), help="Table 1 columns"),
            "priors": Opt("strings", ["uni", "test", "train"], choices=("uni", "test", "train"),
                          help="Table 2 columns"),
            "multilabel": Opt("boolean", True, help="joint multi-label attribute model (random splits)"),
            "sweep": Opt("boolean", True, help="attribute-count sweep (random splits)"),
            "sweep_min_attributes": Opt("integer", 7, minimum=1),
            "sweep_max_subsets": Opt("integer", 1000, minimum=1),
            "eszsl": Opt("boolean", True, help="ESZSL on the random splits (phac2_methods.csv)"),
            "embedding": Opt("boolean", True, help="the fabric paper's embedding model (phac2_methods.csv)"),
            "embedding_lambdas": Opt("numbers", [0.1, 1.0], minimum=0.0),
            "gzsl": Opt("boolean", False, help="generalised zero-shot evaluation (gzsl.csv, see [gzsl])"),
        },
        "gzsl": {
            "holdout_fraction": Opt("number", 0.3, help="fraction of each training object's trials held out"),
            "methods": Opt("strings", ["dap", "eszsl"], choices=("dap", "eszsl")),
            "fusion": Opt("string", "avg", choices=("avg", "max")),
            "prior": Opt("string", "uni", choices=("uni", "train", "test")),
            "calibrated_stacking": Opt("boolean", True),
        },
        "splits": {
            "kinds": Opt("strings", ["random", "challenging"], choices=("random", "challenging", "file")),
            "n_splits": Opt("integer", 5, minimum=1, help="random splits"),
            "n_test": Opt("integer", 10, minimum=1, help="test objects per random split"),
            "seed": Opt("integer", 0, minimum=0),
            "file": Opt("string", help="split CSV for kinds = ['file'] (default: the plain folder's splits.csv)"),
            "random_min_train_positives": Opt("integer", 2, minimum=1),
            "challenging_min_train_positives": Opt("integer", 3, minimum=1),
        },
        "svm": {
            "cv": Opt("integer", 5, minimum=0, help="object-grouped folds; 0 = leave-one-object-out"),
            "undersampling": Opt("string", "select", choices=("select", "bagging", "none")),
            "C_range": Opt("range"),
            "gamma_range": Opt("range"),
            "n_C": Opt("integer", minimum=1),
            "n_gamma": Opt("integer", minimum=1),
            "n_draws": Opt("integer", minimum=1),
            "scoring": Opt("string", choices=("log_loss", "balanced_accuracy")),
            "platt_weighting": Opt("string", choices=("balanced", "empirical")),
        },
        "compute": {
            **_COMPUTE,
            "backend": Opt("string", "loky", choices=("loky", "dask")),
            "scheduler": Opt("string", help="Dask scheduler address for backend = 'dask'"),
            "cache": Opt("boolean", True, help="cache fitted attribute models (resumable runs)"),
        },
        "output": _OUTPUT,
    },
    "fabric": {
        "dataset": {
            "builtin": Opt("string", "fabric", choices=("fabric",)),
            "data_dir": _DATA_DIR,
            "attributes": Opt("string", "a8", choices=("a8", "a4", "a12", "three_value_a8", "three_value_a8v2")),
            "gelsight_root": Opt("string", help="your GelSight fabric videos (adds gelsight-* rows)"),
        },
        "features": {
            "conditions": Opt("strings", ["depth-sequence", "depth-image"],
                              choices=("depth-sequence", "depth-image")),
            "gelsight_conditions": Opt("strings"),
        },
        "methods": {
            "embedding_lambdas": Opt("lambdas", [0, 0.1, 1, 10, "inf"], minimum=0.0),
            "alphas": Opt("numbers", [1.0, 0.1, 0.01, 0.001], minimum=0.0),
            "max_iter": Opt("integer", 500, minimum=1),
        },
        "splits": {
            "configs": Opt("integers", [1, 2], choices=(1, 2)),
            "seeds": Opt("integer", 5, minimum=1, help="embedding-model seeds seed .. seed + seeds - 1"),
            "seed": Opt("integer", 0, minimum=0),
        },
        "compute": dict(_COMPUTE),
        "output": _OUTPUT,
    },
    "hand": {
        "dataset": {
            "builtin": Opt("string", choices=("hand-simulated",), help="simulated grasps from Table 4"),
            "grasps": Opt("string", help="a grasp folder (grasps.csv + .npz)"),
            "table": Opt("string", help="class-attribute table in Table 4's layout (default: Table 4)"),
        },
        "simulation": {
            "n_grasps_per_object": Opt("integer", 30, minimum=1),
            "noise": Opt("number", 1.0, minimum=0.0),
            "difficulty": Opt("number", 0.5, minimum=0.0),
            "shape_miss_rate": Opt("number", 0.3, minimum=0.0),
        },
        "features": {
            "contact_threshold": Opt("number", 20.0, minimum=0.0),
            "baseline_rows": Opt("integer", 10, minimum=1),
            "hold_fraction": Opt("number", 0.5, minimum=0.0),
            "end_rows": Opt("integer", 5, minimum=1),
        },
        "methods": {
            "max_T": Opt("integer", 10, minimum=1),
            "max_k": Opt("integer", 7, minimum=1),
            "sequence_length": Opt("integer", minimum=1),
            "n_sequences": Opt("integer", 200, minimum=1),
            "confusion_T": Opt("integer", minimum=1),
            "confusion_k": Opt("integer", minimum=1),
            "model": Opt("table", {}, help="HandDAPClassifier parameters"),
        },
        "splits": {"seeds": Opt("integers", [0, 1, 2, 3, 4], minimum=0)},
        "compute": {"n_jobs": _COMPUTE["n_jobs"]},
        "output": _OUTPUT,
    },
}

#: Study names of ``study = ...``.
STUDIES: tuple[str, ...] = tuple(SCHEMAS)

_TOP_LEVEL = {"study", "description"}


@dataclass
class Experiment:
    """A checked experiment file.

    Attributes
    ----------
    path : Path
        The TOML file.
    study : str
        One of :data:`STUDIES`.
    settings : dict
        ``{table: {key: value}}`` with every key of the study's schema (defaults filled in;
        ``None`` = not given). Paths are as written in the file.
    given : dict
        The tables and keys as written (for the manifest).
    description : str
    text : str
        The file's text.
    """

    path: Path
    study: str
    settings: dict
    given: dict = field(default_factory=dict)
    description: str = ""
    text: str = ""

    def resolve(self, value: str | None) -> Path | None:
        """A path of the file, relative to the file's folder."""
        if value is None:
            return None
        p = Path(os.path.expanduser(value))
        return p if p.is_absolute() else self.path.parent / p


# --------------------------------------------------------------------------- checking


def _type_problem(value: Any, opt: Opt) -> str | None:
    """Why ``value`` does not fit ``opt`` (None when it does)."""

    def is_int(v):
        return isinstance(v, int) and not isinstance(v, bool)

    def is_num(v):
        return isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)

    kind = opt.kind
    if kind == "string" and not isinstance(value, str):
        return "expected a string"
    if kind == "integer" and not is_int(value):
        return "expected an integer"
    if kind == "number" and not is_num(value):
        return "expected a number"
    if kind == "boolean" and not isinstance(value, bool):
        return "expected true or false"
    if kind == "table" and not isinstance(value, dict):
        return "expected a table"
    if kind in ("strings", "integers", "numbers", "lambdas", "range"):
        if not isinstance(value, list):
            return f"expected a list ({kind})"
        check = {"strings": lambda v: isinstance(v, str), "integers": is_int, "numbers": is_num,
                 "range": is_num, "lambdas": lambda v: is_num(v) or v == "inf"}[kind]
        bad = [v for v in value if not check(v)]
        if bad:
            what = {"strings": "strings", "integers": "integers", "numbers": "numbers",
                    "range": "numbers", "lambdas": "numbers or \"inf\""}[kind]
            return f"expected a list of {what}, got {bad[0]!r}"
        if kind == "range" and (len(value) != 2 or not 0 < value[0] <= value[1]):
            return "expected [low, high] with 0 < low <= high"
        if len(set(map(repr, value))) != len(value):
            return "lists a value twice"
    items = value if isinstance(value, list) else [value]
    if opt.choices:
        bad = [v for v in items if v not in opt.choices]
        if bad:
            return f"{bad[0]!r} is not one of {list(opt.choices)}"
    if opt.minimum is not None and kind != "range":
        bad = [v for v in items if isinstance(v, int | float) and not isinstance(v, bool) and v < opt.minimum]
        if bad:
            return f"must be >= {opt.minimum:g}, got {bad[0]!r}"
    return None


def _shown(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _check_tables(raw: dict, schema: dict[str, dict[str, Opt]], where: str) -> tuple[dict, list[str]]:
    problems: list[str] = []
    settings: dict[str, dict[str, Any]] = {}
    for key in raw:
        if key in _TOP_LEVEL:
            continue
        if key not in schema:
            problems.append(f"{where}: unknown key {key!r} (this study accepts: "
                            f"{', '.join(sorted(_TOP_LEVEL | set(schema)))})")
        elif not isinstance(raw[key], dict):
            problems.append(f"{where}: {key} must be a table [{key}], got {_shown(raw[key])}")
    for table, keys in schema.items():
        given = raw.get(table, {})
        given = given if isinstance(given, dict) else {}
        values: dict[str, Any] = {}
        for key, value in given.items():
            if key not in keys:
                problems.append(f"{where}: unknown key [{table}] {key} (known: {', '.join(sorted(keys))})")
                continue
            problem = _type_problem(value, keys[key])
            if problem:
                problems.append(f"{where}: [{table}] {key} = {_shown(value)}: {problem}")
        for key, opt in keys.items():
            value = given.get(key, opt.default)
            values[key] = list(value) if isinstance(value, list) else (dict(value) if isinstance(value, dict)
                                                                      else value)
        settings[table] = values
    return settings, problems


def _cross_checks(study: str, s: dict, where: str) -> list[str]:
    problems: list[str] = []
    if study == "phac2-dap":
        ds = s["dataset"]
        sources = [k for k in ("builtin", "plain", "features") if ds[k] is not None]
        if len(sources) != 1:
            problems.append(f"{where}: [dataset] needs exactly one of builtin, plain, features; got "
                            f"{sources or 'none'}")
        if ds["path"] is not None and ds["builtin"] != "phac2-h5":
            problems.append(f"{where}: [dataset] path is the HDF5 file of builtin = 'phac2-h5' only")
        if ds["builtin"] == "phac2-h5" and ds["path"] is None:
            problems.append(f"{where}: [dataset] builtin = 'phac2-h5' needs path = the HDF5 release file")
        if ds["features"] is not None and ds["min_objects"] is not None:
            problems.append(f"{where}: [dataset] min_objects does not apply to a feature table")
        given_features = [k for k, v in s["features"].items() if v is not None]
        if given_features and ds["plain"] is None:
            problems.append(f"{where}: [features] {', '.join(given_features)} apply to plain signal datasets only")
        if not s["methods"]["dap"]:
            problems.append(f"{where}: [methods] dap = false: the phac2-dap study always runs DAP "
                            "(ESZSL and the embedding model are compared on its splits)")
        for key in ("fusions", "priors"):
            if not s["methods"][key]:
                problems.append(f"{where}: [methods] {key} is empty")
        kinds = s["splits"]["kinds"]
        if not kinds:
            problems.append(f"{where}: [splits] kinds is empty")
        if "file" in kinds and len(kinds) > 1:
            problems.append(f"{where}: [splits] kinds = ['file'] cannot be combined with random/challenging")
        if s["splits"]["file"] is not None and "file" not in kinds:
            problems.append(f"{where}: [splits] file is given but kinds does not include 'file'")
        if kinds == ["file"] and s["splits"]["file"] is None and ds["plain"] is None:
            problems.append(f"{where}: [splits] kinds = ['file'] needs file = a split CSV")
        if s["svm"]["cv"] == 1:
            problems.append(f"{where}: [svm] cv = 1: use 0 (leave-one-object-out) or at least 2 folds")
        if s["methods"]["gzsl"] and "challenging" in kinds and "random" not in kinds:
            problems.append(f"{where}: [methods] gzsl runs on the random (or file) splits; kinds has neither")
        h = s["gzsl"]["holdout_fraction"]
        if not 0 < h < 1:
            problems.append(f"{where}: [gzsl] holdout_fraction must be in (0, 1), got {h!r}")
        if not s["gzsl"]["methods"]:
            problems.append(f"{where}: [gzsl] methods is empty")
        if s["compute"]["scheduler"] is not None and s["compute"]["backend"] != "dask":
            problems.append(f"{where}: [compute] scheduler needs backend = 'dask'")
    elif study == "fabric":
        if not s["features"]["conditions"] and s["dataset"]["gelsight_root"] is None:
            problems.append(f"{where}: [features] conditions is empty and no [dataset] gelsight_root")
        for key in ("embedding_lambdas", "alphas"):
            if not s["methods"][key]:
                problems.append(f"{where}: [methods] {key} is empty")
        if not s["splits"]["configs"]:
            problems.append(f"{where}: [splits] configs is empty")
    elif study == "hand":
        ds = s["dataset"]
        sources = [k for k in ("builtin", "grasps") if ds[k] is not None]
        if len(sources) != 1:
            problems.append(f"{where}: [dataset] needs exactly one of builtin = 'hand-simulated', grasps; got "
                            f"{sources or 'none'}")
        if not s["splits"]["seeds"]:
            problems.append(f"{where}: [splits] seeds is empty")
        if "material_attributes" in s["methods"]["model"]:
            problems.append(f"{where}: [methods.model] material_attributes comes from the table; remove it")
    return problems


def load_experiment(path: str | os.PathLike) -> Experiment:
    """Read and check an experiment file.

    Raises
    ------
    ConfigError
        The file is missing or not TOML, or has problems: every unknown key, wrong type and
        bad value is listed, one per line, as ``<file>: [table] key = value: problem``.
    """
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"{path}: experiment file not found")
    text = path.read_text(encoding="utf-8")
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path}: not valid TOML: {exc}") from exc
    study = raw.get("study")
    if study is None:
        raise ConfigError(f"{path}: missing key study (one of {', '.join(STUDIES)})")
    if study not in SCHEMAS:
        raise ConfigError(f"{path}: study = {_shown(study)}: expected one of {', '.join(STUDIES)}")
    description = raw.get("description", "")
    problems: list[str] = []
    if not isinstance(description, str):
        problems.append(f"{path}: description must be a string")
        description = ""
    settings, found = _check_tables(raw, SCHEMAS[study], str(path))
    problems += found
    if not problems:
        problems += _cross_checks(study, settings, str(path))
    if problems:
        raise ConfigError(f"{path}: {len(problems)} problem(s):\n  " + "\n  ".join(problems))
    given = {k: v for k, v in raw.items() if k not in _TOP_LEVEL}
    return Experiment(path=path, study=study, settings=settings, given=given, description=description,
                      text=text)


# --------------------------------------------------------------------------- settings -> study configs


def _svm_params(svm: dict) -> dict:
    """``[svm]`` -> :class:`~tzsl.models.AttributeSVM` parameters that differ from its defaults."""
    from tzsl.models import AttributeSVM  # noqa: PLC0415

    defaults = AttributeSVM().get_params()
    params: dict[str, Any] = {"cv": None if svm["cv"] == 0 else svm["cv"]}
    for key in ("C_range", "gamma_range", "n_C", "n_gamma", "n_draws", "scoring", "platt_weighting"):
        if svm[key] is not None:
            params[key] = tuple(float(v) for v in svm[key]) if key.endswith("_range") else svm[key]
    return {k: v for k, v in params.items() if v != defaults[k]}


def dap_config(exp: Experiment, n_jobs: int | None = None, progress: bool | None = None):
    """The :class:`~tzsl.experiments.phac2_dap.DapStudyConfig` of a phac2-dap experiment."""
    from tzsl.experiments.phac2_dap import DapStudyConfig  # noqa: PLC0415

    _need(exp, "phac2-dap")
    s = exp.settings
    compute = s["compute"]
    return DapStudyConfig(
        n_splits=s["splits"]["n_splits"], n_test=s["splits"]["n_test"], seed=s["splits"]["seed"],
        random_min_train_positives=s["splits"]["random_min_train_positives"],
        challenging_min_train_positives=s["splits"]["challenging_min_train_positives"],
        undersampling=s["svm"]["undersampling"], svm_params=_svm_params(s["svm"]),
        multilabel=s["methods"]["multilabel"], sweep_min_attributes=s["methods"]["sweep_min_attributes"],
        sweep_max_subsets=s["methods"]["sweep_max_subsets"],
        n_jobs=compute["n_jobs"] if n_jobs is None else n_jobs, backend=compute["backend"],
        scheduler=compute["scheduler"], progress=compute["progress"] if progress is None else progress,
        cache=compute["cache"],
    )


def gzsl_config(exp: Experiment):
    """The :class:`~tzsl.experiments.gzsl.GzslConfig` of a phac2-dap experiment's ``[gzsl]``."""
    from tzsl.experiments.gzsl import GzslConfig  # noqa: PLC0415

    _need(exp, "phac2-dap")
    g = exp.settings["gzsl"]
    return GzslConfig(holdout_fraction=float(g["holdout_fraction"]), methods=tuple(g["methods"]),
                      fusion=g["fusion"], prior=g["prior"], calibrated_stacking=g["calibrated_stacking"])


def fabric_arguments(exp: Experiment, n_jobs: int | None = None, progress: bool | None = None,
                     data_dir: str | os.PathLike | None = None) -> dict:
    """Keyword arguments of :func:`tzsl.experiments.fabric.run_fabric_study` (all but ``out``)."""
    _need(exp, "fabric")
    s = exp.settings
    return {
        "data_dir": data_dir if data_dir is not None else exp.resolve(s["dataset"]["data_dir"]),
        "seeds": s["splits"]["seeds"],
        "configs": tuple(s["splits"]["configs"]),
        "gelsight_root": exp.resolve(s["dataset"]["gelsight_root"]),
        "attributes": s["dataset"]["attributes"],
        "progress": s["compute"]["progress"] if progress is None else progress,
        "lams": tuple(s["methods"]["embedding_lambdas"]),
        "alphas": tuple(float(a) for a in s["methods"]["alphas"]),
        "conditions": tuple(s["features"]["conditions"]),
        "gelsight_conditions": (None if s["features"]["gelsight_conditions"] is None
                                else tuple(s["features"]["gelsight_conditions"])),
        "seed": s["splits"]["seed"],
        "max_iter": s["methods"]["max_iter"],
        "n_jobs": s["compute"]["n_jobs"] if n_jobs is None else n_jobs,
    }


def hand_config(exp: Experiment, n_jobs: int | None = None):
    """The :class:`~tzsl.experiments.hand.HandStudyConfig` of a hand experiment."""
    from tzsl.experiments.hand import HandStudyConfig  # noqa: PLC0415

    _need(exp, "hand")
    s = exp.settings
    values = {**s["simulation"], **s["features"],
              **{k: v for k, v in s["methods"].items() if k != "model" and v is not None},
              "model_params": dict(s["methods"]["model"]),
              "n_jobs": s["compute"]["n_jobs"] if n_jobs is None else n_jobs}
    values = {k: float(v) if isinstance(HandStudyConfig.__dataclass_fields__[k].default, float) else v
              for k, v in values.items()}
    config = HandStudyConfig(**values)
    config.check()
    return config


def _need(exp: Experiment, study: str) -> None:
    if exp.study != study:
        raise ConfigError(f"{exp.path}: study = {exp.study!r}, not {study!r}")


# --------------------------------------------------------------------------- running


class _SelectedColumns(ResultsDir):
    """A results folder that leaves unselected fusion / prior columns out of Tables 1 and 2."""

    def __init__(self, root, force: bool, drop: Mapping[str, list[str]]) -> None:
        super().__init__(root, force=force)
        self.drop = dict(drop)

    def write_csv(self, name: str, table: pd.DataFrame, index: bool = False) -> Path:
        return super().write_csv(name, table.drop(columns=self.drop.get(name, []), errors="ignore"), index)


def _dropped_columns(methods: dict) -> dict[str, list[str]]:
    drop: dict[str, list[str]] = {"table1_fusion.csv": [], "table2_priors.csv": []}
    for fusion in {"max", "avg"} - set(methods["fusions"]):
        drop["table1_fusion.csv"] += [f"{fusion}dap", f"paper_{fusion}dap"]
        if fusion == "avg":
            drop["table1_fusion.csv"].append("avgdap_per_class_mean")
    for prior in {"uni", "test", "train"} - set(methods["priors"]):
        drop["table2_priors.csv"] += [prior, f"paper_{prior}"]
    return drop


def _phac2_outputs(s: dict) -> list[str]:
    kinds, methods = s["splits"]["kinds"], s["methods"]
    names = ["manifest.json"]
    if "random" in kinds or "file" in kinds:
        names += ["table1_fusion.csv", "table2_priors.csv", "attribute_accuracy.csv",
                  "attribute_accuracy_per_split.csv", "attribute_accuracy.png"]
        if methods["multilabel"]:
            names.append("multilabel.csv")
        if methods["sweep"]:
            names += ["attribute_sweep.csv", "attribute_sweep.png"]
        if methods["eszsl"] or methods["embedding"]:
            names.append("phac2_methods.csv")
        if methods["gzsl"]:
            names.append("gzsl.csv")
    if "challenging" in kinds:
        names += ["table3_challenging.csv", "object_map.csv", "object_map.png"]
    return names


def _phac2_features(exp: Experiment, data_dir):
    from tzsl.experiments.sources import load_study_features  # noqa: PLC0415
    from tzsl.features import filter_attributes  # noqa: PLC0415

    ds, feat = exp.settings["dataset"], exp.settings["features"]
    data_dir = data_dir if data_dir is not None else exp.resolve(ds["data_dir"])
    if ds["builtin"] is not None:
        from tzsl.experiments.extract import extract_features  # noqa: PLC0415

        min_objects = 3 if ds["min_objects"] is None else ds["min_objects"]
        return extract_features(ds["builtin"], data_dir=data_dir, path=exp.resolve(ds["path"]),
                                min_objects=min_objects)
    if ds["plain"] is not None:
        from tzsl.features import load_plain_dataset  # noqa: PLC0415

        return load_plain_dataset(exp.resolve(ds["plain"]), statistics=feat["statistics"],
                                  baseline_rows=feat["baseline_rows"], channels=feat["channels"],
                                  min_objects=ds["min_objects"])
    features = load_study_features(None, features_file=exp.resolve(ds["features"]))
    if ds["min_objects"] is not None:  # pragma: no cover - refused by the cross checks
        features.attributes, _ = filter_attributes(features.attributes, ds["min_objects"])
    return features


def _format(table: pd.DataFrame) -> str:
    return table.to_string(index=False, float_format=lambda v: f"{v:.3f}", na_rep="-")


_TITLES = {
    "table1_fusion": "Table 1: DAP sensor fusion (uni-prior), random splits - ours beside the paper",
    "table2_priors": "Table 2: AVGDAP by attribute prior, random splits - ours beside the paper",
    "table3_challenging": "Table 3: challenging splits (AVGDAP, uni-prior) - ours beside the paper",
    "multilabel": "Independent vs multi-label attribute classifiers (AVGDAP, uni-prior)",
    "attribute_accuracy": "Per-attribute test accuracy (mean over random splits and sensors)",
    "phac2_methods": "DAP vs ESZSL vs embedding model on the same random splits (trial accuracy)",
}


def _run_phac2(exp: Experiment, results: ResultsDir, n_jobs, progress, data_dir, say) -> dict:
    from tzsl.evaluation import read_splits_csv  # noqa: PLC0415
    from tzsl.experiments.gzsl import GZSL_FILE, gzsl_config_record, run_gzsl  # noqa: PLC0415
    from tzsl.experiments.phac2_dap import make_splits, run_dap_study  # noqa: PLC0415

    s = exp.settings
    config = dap_config(exp, n_jobs=n_jobs, progress=progress)
    methods = s["methods"]
    features = _phac2_features(exp, data_dir)
    say(f"{features.dataset}: {features.n_trials} trials, {features.n_objects} objects, "
        f"{len(features.sensors)} sensor(s), {features.X.shape[2]} features per sensor, "
        f"{features.attributes.shape[1]} attributes")
    kinds = tuple(s["splits"]["kinds"])
    user_splits = None
    split_file = None
    if kinds == ("file",):
        split_file = exp.resolve(s["splits"]["file"]) if s["splits"]["file"] is not None else (
            exp.resolve(s["dataset"]["plain"]) / "splits.csv")
        user_splits = read_splits_csv(split_file, features.attributes,
                                      min_train_positives=config.random_min_train_positives)
    compare = methods["eszsl"] or methods["embedding"]
    options = {"eszsl": methods["eszsl"],
               "embedding_lams": tuple(float(v) for v in methods["embedding_lambdas"]) if methods["embedding"]
               else ()}
    tables = run_dap_study(features, results, config, kinds=kinds, splits=user_splits, sweep=methods["sweep"],
                           compare_methods=compare, method_options=options)
    gzsl_record = None
    if methods["gzsl"]:
        gzsl = gzsl_config(exp)
        splits = user_splits if user_splits is not None else make_splits(features, "random", config)[0]
        tables["gzsl"] = run_gzsl(features, splits, config, gzsl, echo=say)
        results.write_csv(GZSL_FILE, tables["gzsl"])
        gzsl_record = gzsl_config_record(gzsl)
    drop = getattr(results, "drop", {})
    for name, title in {**_TITLES, "gzsl": "Generalised zero-shot: seen / unseen per-class accuracy, "
                                          "harmonic mean (H)"}.items():
        if name in tables:
            table = tables[name].drop(columns=drop.get(f"{name}.csv", []), errors="ignore")
            say(f"\n{title}\n{_format(table)}")
    return {"config": {"phac2_dap": asdict(config), "kinds": list(kinds),
                       "splits_file": None if split_file is None else str(split_file),
                       "method_options": {k: list(v) if isinstance(v, tuple) else v for k, v in options.items()},
                       "gzsl": gzsl_record, "dataset": features.dataset},
            "data_files": features.info.get("data_files", []), "tables": sorted(tables)}


def _run_fabric(exp: Experiment, results: ResultsDir, n_jobs, progress, data_dir, say) -> dict:
    from tzsl.experiments.fabric import format_fabric_table, run_fabric_study  # noqa: PLC0415

    kwargs = fabric_arguments(exp, n_jobs=n_jobs, progress=progress, data_dir=data_dir)
    tables = run_fabric_study(results, **kwargs)
    say("\nFabric Table 1 analogue - ours beside the paper's\n" + format_fabric_table(tables["table1"]))
    record = {k: (str(v) if isinstance(v, Path) else list(v) if isinstance(v, tuple) else v)
              for k, v in kwargs.items()}
    return {"config": {"fabric": record}, "data_files": [], "tables": sorted(tables)}


def _run_hand(exp: Experiment, results: ResultsDir, n_jobs, progress, data_dir, say) -> dict:
    from tzsl.datasets import load_hand_table4  # noqa: PLC0415
    from tzsl.experiments.hand import format_hand_summary, run_hand_study  # noqa: PLC0415

    ds = exp.settings["dataset"]
    config = hand_config(exp, n_jobs=n_jobs)
    table = load_hand_table4(exp.resolve(ds["table"]))
    grasps = exp.resolve(ds["grasps"])
    seeds = tuple(exp.settings["splits"]["seeds"])
    result = run_hand_study(grasps, table, results, seeds=seeds, config=config, force=results.force,
                            log=say if progress is not False else None)
    if result.simulated:
        say("\nHand study on SIMULATED grasps (the paper's Shadow-hand data are not public)")
    say(format_hand_summary(result))
    return {"config": {"hand": asdict(config), "seeds": list(seeds), "grasps": None if grasps is None else str(grasps),
                       "table": ds["table"]},
            "data_files": [] if grasps is None else [grasps / "grasps.csv"], "tables": ["hand"]}


_RUNNERS: dict[str, Callable] = {"phac2-dap": _run_phac2, "fabric": _run_fabric, "hand": _run_hand}


def run_experiment(
    experiment: str | os.PathLike | Experiment,
    out: str | os.PathLike | None = None,
    force: bool = False,
    n_jobs: int | None = None,
    progress: bool | None = None,
    data_dir: str | os.PathLike | None = None,
    echo: Callable[[str], None] | None = None,
) -> ResultsDir:
    """Run the study an experiment file describes; returns the results folder.

    Parameters
    ----------
    experiment : path or Experiment
    out : path, optional
        Results folder; default ``[output] folder`` (relative to the current directory).
    force : bool
        Overwrite existing results (otherwise refused before any computation).
    n_jobs, progress : optional
        Override ``[compute] n_jobs`` / ``progress``.
    data_dir : path, optional
        Override ``[dataset] data_dir`` of built-in datasets.
    echo : callable, optional
        Receives progress lines and the result tables.
    """
    exp = experiment if isinstance(experiment, Experiment) else load_experiment(experiment)
    say = echo or (lambda _msg: None)
    folder = Path(out) if out is not None else Path(exp.settings["output"]["folder"])
    if exp.study == "phac2-dap":
        results: ResultsDir = _SelectedColumns(folder, force, _dropped_columns(exp.settings["methods"]))
        results.check_free(_phac2_outputs(exp.settings))
    else:
        results = ResultsDir(folder, force=force)
        results.check_free(["manifest.json"])
    say(f"{exp.path}: study {exp.study} -> {folder}")
    record = _RUNNERS[exp.study](exp, results, n_jobs, progress, data_dir, say)
    results.write_manifest(
        {"study": exp.study, "experiment": str(exp.path), "settings": exp.settings, **record["config"]},
        data_files=record["data_files"],
        extra={"experiment_sha256": file_sha256(exp.path), "experiment_toml": exp.text,
               "description": exp.description, "tables": record["tables"]},
    )
    return results
