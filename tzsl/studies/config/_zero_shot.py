"""The schema of ``study = "zero-shot"`` (any dataset x every method x random and challenging splits),
which its PHAC-2 paper preset ``study = "phac2-dap"`` shares.

Both run the same study (:func:`tzsl.studies.zero_shot.runner.run_zero_shot`): attribute models
+ DAP (fusions, priors), the attribute tables, the attribute-count sweep, the method comparison
and GZSL, on random and challenging unseen-class splits. One flat model per table, composed into
:class:`ZeroShotSettings` (what the study reads) and :class:`ZeroShotStudy` (a study file), each
default written once: the generic study's on the fields, and what a preset changes of them in
:data:`PRESET_DEFAULTS` (``phac2-dap``: the cheapest complete study, DAP only on the paper's random
splits of 10 test objects; the ``[zero_shot]`` table of the fabric and hand presets: no compared
method and no sweep). Where a default belongs to an estimator (the SVM grids), it is read from it.
"""

from __future__ import annotations

import inspect
from typing import Any, Literal, cast

from pydantic import Field, field_validator, model_validator

from tzsl.datasets import dataset_names, get_dataset
from tzsl.studies.config._common import (
    COMPARE_DESCRIPTION,
    DaskCompute,
    MethodEntry,
    Output,
    Purpose,
    Section,
    Seed,
    dap_label,
    dap_settings,
    distinct,
    lambdas_ok,
    method_label,
    methods_ok,
    non_empty,
)
from tzsl.value_lists import FUSIONS, PRIORS, SPLIT_KINDS, SPLIT_SOURCES


def _svm_default(name: str):
    """The default of :class:`~tzsl.models.AttributeSVM`'s parameter ``name``."""
    from tzsl.models import AttributeSVM  # noqa: PLC0415

    value = inspect.signature(AttributeSVM).parameters[name].default
    return list(value) if isinstance(value, tuple) else value


def _study_detector() -> str:
    """The generic study's detector family (:data:`tzsl.models.attribute_training.STUDY_DETECTOR`)."""
    from tzsl.models.attribute_training import STUDY_DETECTOR  # noqa: PLC0415

    return STUDY_DETECTOR


def _bank_default(name: str):
    """The default of :class:`~tzsl.models.AttributeClassifierBank`'s parameter ``name``."""
    from tzsl.models import AttributeClassifierBank  # noqa: PLC0415

    return inspect.signature(AttributeClassifierBank).parameters[name].default


class DatasetSource(Section):
    """``[dataset]``: exactly one of a built-in dataset, a plain-file folder or a feature table."""

    builtin: str | None = Field(default=None, description=f"a built-in dataset ({', '.join(dataset_names())})")
    plain: str | None = Field(default=None, description="a plain-file dataset folder (tzsl formats)")
    features: str | None = Field(default=None, description="a feature table written by tzsl extract --out")
    path: str | None = Field(default=None, description="the file of a built-in dataset that reads one (phac2-h5: the "
                                                       "HDF5 release)")
    data_dir: str | None = Field(default=None,
                                 description="data home (default: $TZSL_DATA_DIR or the user data folder)")
    min_objects: int | None = Field(default=None, ge=1, description="keep attributes present in >= this many objects "
                                    "(built-in: the extractor's default; plain folders: keep all)")

    @model_validator(mode="after")
    def _one_source(self):
        sources = [k for k in ("builtin", "plain", "features") if getattr(self, k) is not None]
        if len(sources) != 1:
            raise ValueError(f"needs exactly one of builtin, plain, features; got {sources or 'none'}")
        if self.builtin is not None and self.builtin not in dataset_names():
            raise ValueError(f"builtin = {self.builtin!r}: expected one of {', '.join(dataset_names())}")
        needs_path = self.builtin is not None and get_dataset(self.builtin).needs_path
        if self.path is not None and not needs_path:
            raise ValueError(f"path is the input file of a built-in dataset that reads one "
                             f"({', '.join(n for n in dataset_names() if get_dataset(n).needs_path)}) only")
        if needs_path and self.path is None:
            raise ValueError(f"builtin = {self.builtin!r} needs path = its input file")
        if self.features is not None and self.min_objects is not None:
            raise ValueError("min_objects does not apply to a feature table")
        if self.builtin is not None and self.min_objects is None:
            from tzsl.features import DEFAULT_MIN_OBJECTS  # noqa: PLC0415

            self.min_objects = DEFAULT_MIN_OBJECTS
        return self


class SignalFeatures(Section):
    """For plain folders with signal files; unset = the folder's dataset.toml [signals]."""

    statistics: list[str] | None = Field(default=None, description="per-channel statistics of signal files")
    baseline_rows: int | None = Field(default=None, ge=0, description="baseline rows subtracted from signal files")
    channels: list[str] | None = Field(default=None, description="signal channels to use, in order")


#: Registry methods read from the study's own DAP posteriors, besides the registry's DAP (tzsl.models.DAP_METHOD).
FROM_DAP_POSTERIORS = ("multilabel-dap",)


def every_feature_method() -> list[dict]:
    """``[{"name": m}, ...]`` for every registered method on feature vectors (not aliases), except those
    read from the study's own DAP posteriors (the registry's DAP and :data:`FROM_DAP_POSTERIORS`)."""
    from tzsl.models import DAP_METHOD, available_methods, get_method  # noqa: PLC0415 (the registry, read when used)

    return [{"name": name} for name in available_methods()
            if get_method(name).input_kind == "features" and name not in {DAP_METHOD, *FROM_DAP_POSTERIORS}]


def _every_feature_entry() -> list[MethodEntry]:
    """:func:`every_feature_method` as ``[methods] compare`` entries (that field's default)."""
    return [*every_feature_method()]


class ZeroShotMethods(Section):
    """``[methods]``: DAP always; every registered feature method beside it (``compare``), the
    attribute-count sweep and GZSL by default."""

    dap: Literal[True] = Field(default=True, description="DAP with independent attribute models (always runs)")
    fusions: list[Literal[FUSIONS]] = Field(default=list(FUSIONS), description="Table 1 columns")  # type: ignore[valid-type]  # Literal of a value list: pydantic reads it at run time, mypy cannot
    priors: list[Literal[PRIORS]] = Field(default=list(PRIORS), description="Table 2 columns")  # type: ignore[valid-type]  # Literal of a value list: pydantic reads it at run time, mypy cannot
    multilabel: bool = Field(default=False, description="joint multi-label attribute model (random splits)")
    sweep: bool = Field(default=True, description="attribute-count sweep (random splits)")
    sweep_min_attributes: int = Field(default=3, ge=1)
    sweep_max_subsets: int = Field(default=200, ge=1)
    eszsl: bool = Field(default=False, description="ESZSL on the random splits (the method comparison)")
    embedding: bool = Field(default=False, description="the fabric paper's embedding model (the method comparison)")
    embedding_lambdas: list[float] = Field(default=[0.1, 1.0], description="lambdas of the embedding model")
    compare: list[MethodEntry] = Field(default_factory=_every_feature_entry,
                                       description=COMPARE_DESCRIPTION + " (default: every feature method)")
    gzsl: bool = Field(default=True, description="generalised zero-shot evaluation (gzsl.csv, see [gzsl])")
    compare_on: list[Literal[SPLIT_KINDS]] = Field(  # type: ignore[valid-type]  # Literal of a value list: pydantic reads it at run time, mypy cannot
        default=["random"], description="split kinds the compared methods run on (rows of the method comparison by "
                                        "split_kind); 'challenging' needs it in [splits] kinds")

    _lists = field_validator("fusions", "priors", "compare_on")(lambda v: distinct(non_empty(v)))
    _lams = field_validator("embedding_lambdas")(lambdas_ok)

    def _from_switches(self) -> list[dict]:
        """The methods ``eszsl`` and ``embedding`` (+ ``embedding_lambdas``) switch on."""
        specs: list[dict[str, Any]] = [{"name": "eszsl"}] if self.eszsl else []
        if self.embedding:
            specs += [{"name": "embedding", "lam": float(lam)} for lam in self.embedding_lambdas]
        return specs

    @model_validator(mode="after")
    def _registry(self):
        """The default ``compare`` leaves out what the ``eszsl`` / ``embedding`` switches already run."""
        if "compare" not in self.model_fields_set:
            switched = {spec["name"] for spec in self._from_switches()}
            self.compare = [spec for spec in self.compare if spec["name"] not in switched]
        if self.compare:
            self.compare = methods_ok(self.compare, tuple(method_label(s) for s in self._from_switches()))
        return self

    def method_specs(self) -> list[dict]:
        """Every method compared with DAP: the switches' then ``compare``'s.

        Each as ``{"name": registry name, **parameters}`` (see :func:`tzsl.models.build_method`).
        """
        compare = cast("list[dict[str, Any]]", self.compare)  # methods_ok (_registry) made every entry a dict
        return self._from_switches() + [dict(s) for s in compare]


class GzslSettings(Section):
    """``[gzsl]``: generalised zero-shot evaluation (seen and unseen classes at test time)."""

    holdout_fraction: float = Field(default=0.3, gt=0, lt=1, description="fraction of each training object's trials "
                                                                       "held out as seen-class test trials")
    methods: list[str] = Field(default=["dap", "eszsl"], description="'dap' (the study's attribute models, the fusion "
                               "and prior below) and registered methods on feature vectors (tzsl methods)")
    fusion: Literal[FUSIONS] = "avg"  # type: ignore[valid-type]  # Literal of a value list: pydantic reads it at run time, mypy cannot
    prior: Literal[PRIORS] = "uni"  # type: ignore[valid-type]  # Literal of a value list: pydantic reads it at run time, mypy cannot
    calibrated_stacking: bool = True
    max_draws: int = Field(default=1000, ge=1, description="draws of pseudo-unseen training classes")

    @field_validator("methods")
    @classmethod
    def _methods(cls, v: list[str]) -> list[str]:
        """``"dap"`` or a registered method on feature vectors (each scores every class of a trial)."""
        distinct(non_empty(v))
        from tzsl.exceptions import ConfigError  # noqa: PLC0415
        from tzsl.models import get_method  # noqa: PLC0415 (the registry; imported only when a method is named)

        for name in v:
            if name == "dap":
                continue
            try:
                method = get_method(name)
            except ConfigError as exc:
                raise ValueError(str(exc)) from None
            if method.input_kind != "features":
                raise ValueError(f"method {name!r} takes {method.input_kind}, not feature vectors")
        return v


class ZeroShotSplits(Section):
    """``[splits]``: unseen-class splits (random object splits, the challenging partitions, or a file)."""

    kinds: list[Literal[SPLIT_SOURCES]] = Field(default=list(SPLIT_KINDS))  # type: ignore[valid-type]  # Literal of a value list: pydantic reads it at run time, mypy cannot
    n_splits: int = Field(default=5, ge=1, description="random splits")
    n_test: int = Field(default=5, ge=1, description="test (unseen) objects per random split")
    seed: int = Seed
    purpose: Literal["select", "confirm"] = Purpose
    file: str | None = Field(default=None, description="split CSV for kinds = ['file'] (default: the splits.csv of the "
                                                       "plain folder, or of a catalog dataset that ships one)")
    random_min_train_positives: int = Field(default=2, ge=1)
    challenging_min_train_positives: int = Field(default=3, ge=1)
    min_train_negatives: int = Field(default=1, ge=1, description="a split leaves out an attribute with fewer negative "
                                                                  "training objects")
    refit_seeds: int = Field(default=0, ge=0, description="refit each of the first refit_splits splits of every kind "
                                                          "with this many other model seeds (SVM folds, under-sampling "
                                                          "draws, seeded methods): refit_accuracy.csv and the "
                                                          "sd_over_refit_seeds columns; 0 = no refits")
    refit_splits: int | None = Field(default=None, ge=1, description="splits of each kind refitted (the first ones; "
                                                                     "unset = all)")

    @field_validator("kinds")
    @classmethod
    def _kinds(cls, v):
        distinct(non_empty(v))
        if "file" in v and len(v) > 1:
            raise ValueError("['file'] cannot be combined with random/challenging")
        return v

    @model_validator(mode="after")
    def _file(self):
        if self.file is not None and "file" not in self.kinds:
            raise ValueError("file is given but kinds does not include 'file'")
        return self


class SvmSettings(Section):
    """Per-(attribute, sensor) RBF-SVM (:class:`~tzsl.models.AttributeSVM`); unset keys take its defaults."""

    cv: int = Field(default=5, ge=0, description="object-grouped folds; 0 = leave-one-object-out")
    undersampling: Literal["select", "bagging", "none"] = Field(default_factory=lambda: _svm_default("undersampling"))
    C_range: list[float] = Field(default_factory=lambda: _svm_default("C_range"))
    gamma_range: list[float] = Field(default_factory=lambda: _svm_default("gamma_range"))
    n_C: int = Field(default_factory=lambda: _svm_default("n_C"), ge=1)
    n_gamma: int = Field(default_factory=lambda: _svm_default("n_gamma"), ge=1)
    grid: Literal["paper", "extended", "adaptive"] = Field(
        default_factory=lambda: _svm_default("grid"),
        description="gamma grid: 'paper' (gamma_range, n_gamma), 'extended' (two decades below it added) or "
                    "'adaptive' (the extended grid, widened one log step at a chosen end of the C or gamma grid, "
                    "at most tzsl.models.attribute_training.MAX_GRID_EXTENSIONS steps per end)")
    n_draws: int = Field(default_factory=lambda: _svm_default("n_draws"), ge=1)
    scoring: Literal["log_loss", "balanced_accuracy"] = Field(default_factory=lambda: _svm_default("scoring"))
    platt_weighting: Literal["balanced", "empirical"] = Field(
        default_factory=lambda: _svm_default("platt_weighting"))
    search: Literal["grid", "halving"] = Field(
        default_factory=lambda: _svm_default("search"),
        description="'grid': every (draw, C, gamma) on every fold; 'halving': successive halving over the folds")
    solver: Literal["auto", "exact", "approximate"] = Field(
        default_factory=lambda: _bank_default("solver"),
        description="'exact': these SVMs; 'approximate': Nystroem features + logistic regression (linear in "
                    "trials); 'auto': exact up to max_exact_trials training trials, approximate above")
    max_exact_trials: int = Field(default_factory=lambda: _bank_default("max_exact_trials"), ge=1,
                                  description="largest training set (trials) that solver = 'auto' fits exactly")
    detector: str = Field(
        default_factory=lambda: _study_detector(),
        description="family of the per-(attribute, sensor) classifier of the study's DAP "
                    "(tzsl.models.attribute_training.DETECTORS): 'rbf-svm' (these SVMs: the DAP paper's), 'logistic', "
                    "'linear-svm', 'robust-logistic' "
                    "(linear, C by object-grouped CV), 'logistic-c1' (class-balanced L2 logistic regression, C = 1) or "
                    "'auto' (rbf-svm or logistic, chosen on pseudo-unseen training classes); the other keys of [svm] "
                    "apply to 'rbf-svm' (and 'auto''s RBF-SVM). The DAP rows are labelled with it: dap-avg for "
                    "'rbf-svm', dap-avg-<detector> otherwise (the label of {name = 'dap', detector = ...}). Default: "
                    "the detector of the first DAP entry of [methods] compare (dap-avg: 'rbf-svm'), else the "
                    "zero-shot study's tzsl.models.attribute_training.STUDY_DETECTOR, chosen on PHAC-2 selection "
                    "splits (tzsl.models.INHERITED_CHOICES, study-detector); the paper presets: the paper's 'rbf-svm'")

    @field_validator("detector")
    @classmethod
    def _detector(cls, v):
        from tzsl.models.attribute_training import DETECTORS  # noqa: PLC0415

        if v not in DETECTORS:
            raise ValueError(f"unknown detector {v!r}; choose one of {', '.join(DETECTORS)}")
        return v

    def estimator_params(self) -> dict:
        """The :class:`~tzsl.models.AttributeSVM` parameters of this table that differ from the SVM's
        defaults (``cv = 0`` is its ``cv=None``, leave-one-object-out); ``undersampling``, ``solver`` and
        ``max_exact_trials`` are passed on their own."""
        from tzsl.models import AttributeSVM  # noqa: PLC0415

        defaults = AttributeSVM().get_params()
        params: dict = {"cv": None if self.cv == 0 else self.cv}
        for key in ("C_range", "gamma_range", "n_C", "n_gamma", "grid", "n_draws", "scoring", "platt_weighting",
                    "search"):
            value = getattr(self, key)
            params[key] = tuple(float(v) for v in value) if key.endswith("_range") else value
        return {k: v for k, v in params.items() if v != defaults[k]}

    @field_validator("cv")
    @classmethod
    def _cv(cls, v):
        if v == 1:
            raise ValueError("use 0 (leave-one-object-out) or at least 2 folds")
        return v

    @field_validator("C_range", "gamma_range")
    @classmethod
    def _range(cls, v):
        if len(v) != 2 or not 0 < v[0] <= v[1]:
            raise ValueError("expected [low, high] with 0 < low <= high")
        return v


class PrefixedOutput(Output):
    prefix: str = Field(default="", pattern=r"^([a-z0-9]+([_-][a-z0-9]+)*)?$",
                        description="written before every file name of the run (``PREFIX_table1_fusion.csv``) "
                                            "and after its study label in method comparisons, so two runs can share "
                                            "one folder (reproduce-tables); lower-case letters, digits, '-', '_'")
    model: bool = Field(default=False, description="study = 'zero-shot': after the run, also write model.tzsl, the "
                                                   "method of deployment.json (the study's deploy choice) trained on "
                                                   "every object, as 'tzsl train-attributes --from-results' trains it")


class ZeroShotSettings(Section):
    """What the zero-shot study reads: the ``[methods]``, ``[gzsl]``, ``[splits]``, ``[svm]`` and ``[compute]`` tables.

    A study file (:class:`ZeroShotStudy`) is one with its data and output; from Python, give only what
    differs from the defaults, e.g. ``ZeroShotSettings(splits={"n_splits": 2}, svm={"cv": 3})``, or
    start from a preset's: ``ZeroShotSettings.of_preset("phac2-dap", splits={"seed": 1})``
    (:func:`tzsl.studies.zero_shot.study.run_split_tables`).
    """

    methods: ZeroShotMethods = Field(default_factory=ZeroShotMethods)
    gzsl: GzslSettings = Field(default_factory=GzslSettings)
    splits: ZeroShotSplits = Field(default_factory=ZeroShotSplits)
    svm: SvmSettings = Field(default_factory=SvmSettings)
    compute: DaskCompute = Field(default_factory=DaskCompute)

    @model_validator(mode="before")
    @classmethod
    def _preset_defaults(cls, data: Any) -> Any:
        study = data.get("study") if isinstance(data, dict) else None
        return default_compare(default_detector(with_preset_defaults(data, study) if study in PRESET_DEFAULTS
                                                else data))

    @model_validator(mode="after")
    def _own_dap_entries(self):
        """A ``compare`` entry that is one of the study's own DAP rows (``dap-avg`` when ``[svm] detector`` is
        ``'rbf-svm'``) is read from the study's own fits: it leaves ``compare`` instead of being fitted twice."""
        own = {dap_label(fusion, self.svm.detector) for fusion in FUSIONS}
        compare = cast("list[dict[str, Any]]", self.methods.compare)  # methods_ok made every entry a dict
        self.methods.compare = [spec for spec in compare if method_label(spec) not in own]
        return self

    @property
    def study_seed(self) -> int:
        """The seed of every fit and draw after the splits: ``[splits] seed`` and ``purpose`` together."""
        from tzsl.evaluation import purpose_seed  # noqa: PLC0415

        return purpose_seed(self.splits.seed, self.splits.purpose)

    @classmethod
    def of_preset(cls, preset: str, **tables: dict) -> ZeroShotSettings:
        """The settings of ``preset`` (a key of :data:`PRESET_DEFAULTS`) with ``tables`` given on top."""
        return cls.model_validate(with_preset_defaults(tables, preset))


#: The DAP paper's attribute detector (per-(attribute, sensor) RBF-SVMs), which the paper presets keep.
PAPER_DETECTOR = "rbf-svm"

#: What a preset changes of the zero-shot study's defaults, by table (every other default is the
#: generic study's): ``"phac2-dap"``, the DAP paper's protocol, the cheapest complete study (DAP only,
#: the paper's 5 random splits of 10 test objects, the paper's attribute-count sweep range when it is
#: switched on, the paper's RBF-SVM detectors); ``"zero_shot_part"``, the ``[zero_shot]`` table of the fabric
#: and hand presets (the paper protocol compares its own methods: no compared method, no sweep, RBF-SVMs).
PRESET_DEFAULTS: dict[str, dict[str, dict[str, Any]]] = {
    "phac2-dap": {"methods": {"compare": [], "sweep": False, "gzsl": False, "sweep_min_attributes": 7,
                              "sweep_max_subsets": 1000},
                  "splits": {"kinds": ["random"], "n_test": 10}, "svm": {"detector": PAPER_DETECTOR}},
    "zero_shot_part": {"methods": {"compare": [], "sweep": False}, "svm": {"detector": PAPER_DETECTOR}},
}


def with_preset_defaults(raw: Any, preset: str) -> Any:
    """``raw`` (a study file's tables, as TOML gives them) with :data:`PRESET_DEFAULTS` ``[preset]``
    filled in where it gives no value (a table that is not a table is left for the schema to refuse)."""
    if not isinstance(raw, dict):
        return raw
    filled = dict(raw)
    for table, values in PRESET_DEFAULTS[preset].items():
        given = filled.get(table, {})
        if isinstance(given, dict):
            filled[table] = {**values, **given}
    return filled


def default_detector(data: Any) -> Any:
    """A study file's tables with the ``[svm] detector`` of the first DAP entry of ``[methods] compare``
    (``"dap-avg"``: ``'rbf-svm'``) when ``[svm]`` gives none, so the study's own DAP (the reference) is the DAP
    asked for; without a valid one (or in a preset, which sets it) the default stays."""
    from tzsl.models.detectors import DETECTORS  # noqa: PLC0415 (the models, read when a file is read)

    if not isinstance(data, dict):
        return data
    methods, svm = data.get("methods") or {}, data.get("svm") or {}
    compare = methods.get("compare") if isinstance(methods, dict) else None
    if not isinstance(svm, dict) or "detector" in svm or not isinstance(compare, list):
        return data
    for entry in compare:
        spec = {"name": entry} if isinstance(entry, str) else entry
        dap = dap_settings(spec) if isinstance(spec, dict) else None
        if dap is not None and dap["detector"] in DETECTORS:
            return {**data, "svm": {**svm, "detector": dap["detector"]}}
    return data


def default_compare(data: Any) -> Any:
    """A study file's tables with the default ``[methods] compare`` of a non-RBF ``[svm] detector``: the paper's
    DAP (``{name = "dap", detector = "rbf-svm"}``, row ``dap-avg``) beside the study's own, then every other
    feature method (:func:`every_feature_method`: one row per method, not one per detector). A file that lists
    ``compare`` (or a preset that sets it) keeps its own."""
    from tzsl.models import DAP_METHOD  # noqa: PLC0415 (the registry, read when a file is read)

    if not isinstance(data, dict):
        return data
    methods, svm = data.get("methods") or {}, data.get("svm") or {}
    if not isinstance(methods, dict) or "compare" in methods:
        return data
    detector = (svm.get("detector") if isinstance(svm, dict) else getattr(svm, "detector", None)) or _study_detector()
    if detector == PAPER_DETECTOR:
        return data
    switched = {name for name in ("eszsl", "embedding") if methods.get(name)}
    compare = [{"name": DAP_METHOD, "detector": PAPER_DETECTOR}] + [spec for spec in every_feature_method()
                                                                    if spec["name"] not in switched]
    return {**data, "methods": {**methods, "compare": compare}}


class ZeroShotStudy(ZeroShotSettings):
    """``study = "zero-shot"`` (any dataset, every registered feature method, random + challenging splits)
    and its PHAC-2 paper preset ``study = "phac2-dap"`` (:data:`PRESET_DEFAULTS`)."""

    study: Literal["zero-shot", "phac2-dap"] = "zero-shot"
    description: str = ""
    dataset: DatasetSource
    features: SignalFeatures = Field(default_factory=SignalFeatures)
    output: PrefixedOutput = Field(default_factory=PrefixedOutput)

    @model_validator(mode="after")
    def _across_tables(self):
        problems = []
        given = [k for k, v in self.features.model_dump().items() if v is not None]
        if given and self.dataset.plain is None:
            problems.append(("features", f"{', '.join(given)} apply to plain signal datasets only"))
        kinds, ds = self.splits.kinds, self.dataset
        if kinds == ["file"] and self.splits.file is None and ds.plain is None and not (  # a folder's splits.csv
                ds.builtin and get_dataset(ds.builtin).ships_splits):
            problems.append(("splits.kinds", "['file'] needs file = a split CSV (or a dataset with its splits.csv)"))
        if "challenging" in self.methods.compare_on and "challenging" not in kinds:
            problems.append(("methods.compare_on", "'challenging' needs 'challenging' in splits.kinds"))
        if self.methods.gzsl and kinds == ["challenging"]:
            problems.append(("methods.gzsl", "runs on the random (or file) splits; kinds has neither"))
        if self.output.model and self.study != "zero-shot":
            problems.append(("output.model", "the deploy choice and its model belong to study = 'zero-shot'"))
        if self.compute.scheduler is not None and self.compute.backend != "dask":
            problems.append(("compute.scheduler", "needs backend = 'dask'"))
        if problems:
            raise ValueError("\n".join(f"@{key}: {why}" for key, why in problems))
        return self


# --------------------------------------------------------------------------- [zero_shot] of a paper preset


class PresetZeroShot(Section):
    """``[zero_shot]`` of a paper preset (``fabric``, ``hand``): the generic study on the preset's dataset.

    Its ``methods``, ``gzsl``, ``splits`` and ``svm`` are the ``zero-shot`` study's sections
    (``[zero_shot.methods]`` ...) with :data:`PRESET_DEFAULTS` ``["zero_shot_part"]``; the dataset is the
    preset's built-in one, ``[compute]`` and ``[output] folder`` are the preset's, and every file is
    written as ``<dataset>_<name>``.
    """

    enabled: bool = Field(default=True, description="run the generic zero-shot tables before the paper protocol's")
    min_objects: int | None = Field(default=None, ge=1, description="keep attributes present in >= this many objects "
                                    "(unset: the extractor's default)")
    methods: ZeroShotMethods = Field(default_factory=ZeroShotMethods)
    gzsl: GzslSettings = Field(default_factory=GzslSettings)
    splits: ZeroShotSplits = Field(default_factory=ZeroShotSplits)
    svm: SvmSettings = Field(default_factory=SvmSettings)

    @model_validator(mode="before")
    @classmethod
    def _preset_defaults(cls, data: Any) -> Any:
        return with_preset_defaults(data, "zero_shot_part")
