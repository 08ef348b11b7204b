"""Schemas of ``study = "fabric"``, ``"fabric-deep"``, ``"hand"`` and ``"active-touch"``.

Estimator parameters (``[methods.model]``) are checked against the estimator's own
``get_params`` names; their defaults stay the estimator's.
"""

from __future__ import annotations

import inspect
from typing import Any, Literal

from pydantic import Field, field_validator, model_validator

from tzsl.studies.config._common import (
    COMPARE_DESCRIPTION,
    Compute,
    MethodEntry,
    Output,
    Purpose,
    Section,
    Seed,
    distinct,
    lambdas_ok,
    methods_ok,
    non_empty,
)
from tzsl.studies.config._zero_shot import PresetZeroShot
from tzsl.value_lists import SPLIT_KINDS

FABRIC_ATTRIBUTES = ("a8", "a4", "a12", "three_value_a8", "three_value_a8v2")
FabricAttributes = Literal["a8", "a4", "a12", "three_value_a8", "three_value_a8v2"]
PAPER_LAMBDAS: list[float | Literal["inf"]] = [0.0, 0.1, 1.0, 10.0, "inf"]


def estimator_parameters(name: str) -> dict[str, Any]:
    """Parameter names and defaults of the estimator ``name`` of :mod:`tzsl.models`."""
    import tzsl.models  # noqa: PLC0415

    cls = getattr(tzsl.models, name)
    return {k: p.default for k, p in inspect.signature(cls).parameters.items() if p.kind == p.KEYWORD_ONLY
            or p.kind == p.POSITIONAL_OR_KEYWORD}


def _known_parameters(params: dict, estimator: str, refused: tuple[str, ...]) -> dict:
    known = estimator_parameters(estimator)
    unknown = sorted(set(params) - set(known))
    if unknown:
        raise ValueError(f"unknown {estimator} parameter(s) {unknown} (known: {', '.join(sorted(known))})")
    bad = sorted(set(params) & set(refused))
    if bad:
        raise ValueError(f"{bad} are set by the study, not here")
    return params


# --------------------------------------------------------------------------- fabric


class FabricDataset(Section):
    builtin: Literal["fabric"] = "fabric"
    data_dir: str | None = Field(default=None,
                                 description="data home (default: $TZSL_DATA_DIR or the user data folder)")
    attributes: FabricAttributes = Field(default="a8", description="group x attribute matrix")
    gelsight_root: str | None = Field(default=None, description="your GelSight fabric videos (adds gelsight-* rows)")


class FabricFeatures(Section):
    conditions: list[Literal["depth-sequence", "depth-image"]] = Field(default=["depth-sequence", "depth-image"])
    gelsight_conditions: list[str] | None = Field(default=None, description="condition folders of gelsight_root "
                                                                            "(unset: all)")

    _conditions = field_validator("conditions")(distinct)


class FabricMethods(Section):
    """The embedding model over a lambda grid; ESZSL (closed form) always runs beside."""

    embedding_lambdas: list[float | Literal["inf"]] = Field(default=PAPER_LAMBDAS, description="the paper's grid")
    alphas: list[float] = Field(default=[1.0, 0.1, 0.01, 0.001], description="weight decay, chosen by class-grouped CV")
    max_iter: int = Field(default=500, ge=1, description="L-BFGS iterations per fit")
    compare: list[MethodEntry] = Field(default=[], description=COMPARE_DESCRIPTION + " (runs rows beside ESZSL)")

    _lams = field_validator("embedding_lambdas")(lambdas_ok)
    _compare = field_validator("compare")(lambda v: methods_ok(v, ("ESZSL",)))

    @field_validator("alphas")
    @classmethod
    def _alphas(cls, v):
        if any(a < 0 for a in v):
            raise ValueError("alphas must be >= 0")
        return distinct(non_empty(v))


class FabricSplits(Section):
    configs: list[Literal[1, 2]] = Field(default=[1, 2], description="1: test groups 0,5,7 (the paper's); 2: 0,4,7")
    n_seeds: int = Field(default=5, ge=1, description="embedding-model seeds seed .. seed + n_seeds - 1")
    seed: int = Seed

    _configs = field_validator("configs")(lambda v: distinct(non_empty(v)))


class FabricPartitions(Section):
    """Repeated group partitions (:mod:`tzsl.studies.fabric.partitions`): ESZSL over every valid split."""

    enabled: bool = Field(default=False, description="run the protocol (writes fabric_partitions.csv)")
    attributes: FabricAttributes | None = Field(default=None, description="group x attribute matrix of the partitions "
                                                                          "(unset: [dataset] attributes)")
    min_test: int = Field(default=4, ge=2, le=7, description="fewest test groups per partition")
    both_signs: bool = Field(default=True, description="every attribute positive and negative in some training group")
    max_partitions: int | None = Field(default=None, ge=1, description="random sample of this many (unset: all)")


class FabricStudy(Section):
    """``study = "fabric"``, a preset of ``zero-shot``: the generic study's tables on the built-in
    ``fabric-depth`` dataset (``[zero_shot]``), then the fabric paper's protocol - texture
    descriptors + EmbeddingZSL / ESZSL (Table 1 analogue), group partitions - with its numbers."""

    study: Literal["fabric"] = "fabric"
    description: str = ""
    dataset: FabricDataset = Field(default_factory=FabricDataset)
    features: FabricFeatures = Field(default_factory=FabricFeatures)
    methods: FabricMethods = Field(default_factory=FabricMethods)
    splits: FabricSplits = Field(default_factory=FabricSplits)
    partitions: FabricPartitions = Field(default_factory=FabricPartitions)
    zero_shot: PresetZeroShot = Field(default_factory=PresetZeroShot)
    compute: Compute = Field(default_factory=Compute)
    output: Output = Field(default_factory=Output)

    @model_validator(mode="after")
    def _something_to_run(self):
        if not self.features.conditions and self.dataset.gelsight_root is None:
            raise ValueError("@features.conditions: is empty and no [dataset] gelsight_root")
        return self


# --------------------------------------------------------------------------- fabric-deep


class DeepDataset(FabricDataset):
    """The fabric data (default), or ``builtin = "physiclear"``: the 5 contact key frames of PhysiCLeAR's
    GelSight videos, its class-attribute table and the paper's object split
    (:mod:`tzsl.studies.fabric.deep_physiclear`)."""

    builtin: Literal["fabric", "physiclear"] = Field(  # type: ignore[assignment]
        default="fabric", description='"fabric" (depth images or gelsight_root) or "physiclear" (GelSight videos)')

    @model_validator(mode="after")
    def _physiclear_reads_its_own_table(self):
        if self.builtin != "physiclear":
            return self
        fabric_only = [k for k, set_ in (("attributes", self.attributes != "a8"),
                                         ("gelsight_root", self.gelsight_root is not None)) if set_]
        if fabric_only:
            raise ValueError(f"{', '.join(fabric_only)}: fabric data only; builtin = 'physiclear' reads its own "
                             "videos and class-attribute table")
        return self


class DeepMethods(Section):
    embedding_lambdas: list[float | Literal["inf"]] = Field(default=PAPER_LAMBDAS, description="the paper's grid")
    model: dict[str, Any] = Field(default_factory=dict, description="DeepAttributeEmbedding parameters "
                                                                    "(backbone, epochs, ...); unset: its defaults")

    _lams = field_validator("embedding_lambdas")(lambdas_ok)

    @field_validator("model")
    @classmethod
    def _model(cls, v):
        return _known_parameters(v, "DeepAttributeEmbedding", ("lam", "random_state"))


class DeepFeatures(Section):
    gelsight_conditions: list[str] | None = Field(default=None, description="condition folders of gelsight_root "
                                                                            "(unset: all)")


class DeepSplits(FabricSplits):
    n_seeds: int = Field(default=1, ge=1,
                         description="seeds per (condition, config, lambda): seed .. seed + n_seeds - 1")


class DeepCompute(Section):
    progress: bool = Field(default=True, description="progress bars (features, epochs)")


class DeepOutput(Output):
    model: str | None = Field(default=None, description="also save the trained network as a model bundle (tzsl "
                                                        "predict); needs exactly one fit: one config, lambda, seed "
                                                        "and condition")


class FabricDeepStudy(Section):
    """``study = "fabric-deep"``: the CNN + LSTM over the lambda grid (needs tzsl[deep]).

    ``tzsl train-deep`` builds this config from its options (one config, lambda and seed, and
    ``output.model``), so the command and the matching file give the same tables.
    """

    study: Literal["fabric-deep"] = "fabric-deep"
    description: str = ""
    dataset: DeepDataset = Field(default_factory=DeepDataset)
    features: DeepFeatures = Field(default_factory=DeepFeatures)
    methods: DeepMethods = Field(default_factory=DeepMethods)
    splits: DeepSplits = Field(default_factory=DeepSplits)
    compute: DeepCompute = Field(default_factory=DeepCompute)
    output: DeepOutput = Field(default_factory=DeepOutput)

    @model_validator(mode="after")
    def _one_fit_for_a_model(self):
        if self.output.model is None:
            return self
        physiclear = self.dataset.builtin == "physiclear"  # one object split: configs are the fabric's
        many = [f"{key} has {n}" for key, n in (("splits.configs", 1 if physiclear else len(self.splits.configs)),
                                                  ("methods.embedding_lambdas", len(self.methods.embedding_lambdas)),
                                                  ("splits.n_seeds", self.splits.n_seeds)) if n != 1]
        conditions = self.features.gelsight_conditions
        if self.dataset.gelsight_root is not None and (conditions is None or len(conditions) != 1):
            many.append("features.gelsight_conditions must name one condition")
        if many:
            raise ValueError("@output.model: saving a model needs exactly one fit; " + "; ".join(many))
        return self


# --------------------------------------------------------------------------- hand


class HandDataset(Section):
    builtin: Literal["hand-simulated"] | None = Field(default=None, description="simulated grasps from Table 4")
    grasps: str | None = Field(default=None, description="a grasp folder (grasps.csv + .npz)")
    table: str | None = Field(default=None, description="class-attribute table in Table 4's layout (default: Table 4)")

    @model_validator(mode="after")
    def _one_source(self):
        if (self.builtin is None) == (self.grasps is None):
            raise ValueError("needs exactly one of builtin = 'hand-simulated', grasps")
        return self


class HandSimulation(Section):
    """Simulator settings (builtin = "hand-simulated" only)."""

    n_grasps_per_object: int = Field(default=30, ge=1)
    noise: float = Field(default=1.0, ge=0)
    difficulty: float = Field(default=0.5, ge=0)
    shape_miss_rate: float = Field(default=0.3, ge=0, le=1)


class HandFeatures(Section):
    contact_threshold: float = Field(default=20.0, ge=0, description="ADC counts")
    baseline_rows: int = Field(default=10, ge=1)
    hold_fraction: float = Field(default=0.5, gt=0, le=1)
    end_rows: int = Field(default=5, ge=1)


def _paper(name: str) -> int:
    from tzsl.studies.papers import numbers as paper_numbers  # noqa: PLC0415

    return getattr(paper_numbers, name)


class HandMethods(Section):
    max_T: int = Field(default=10, ge=1, description="DF-MDAP over T = 1..max_T grasps")
    max_k: int = Field(default=7, ge=1, description="SC-MDAP stops at k equal decisions, k = 1..max_k")
    sequence_length: int = Field(default_factory=lambda: _paper("DAP_HAND_MAX_TEST_GRASPS"), ge=1,
                                 description="grasps per random sequence (paper: up to 15)")
    n_sequences: int = Field(default=200, ge=1, description="random grasp orders per test object and seed")
    confusion_T: int = Field(default_factory=lambda: _paper("DAP_HAND_CONFUSION_T"), ge=1)
    confusion_k: int = Field(default_factory=lambda: _paper("DAP_HAND_CONFUSION_K"), ge=1)
    model: dict[str, Any] = Field(default_factory=dict, description="HandDAPClassifier parameters; "
                                                                    "unset: its defaults")
    compare: list[MethodEntry] = Field(default=[], description=COMPARE_DESCRIPTION + " (on the packed grasp "
                                       "features, beside MAXDAP/AVGDAP/LDAP)")

    _compare = field_validator("compare")(lambda v: methods_ok(v))

    @field_validator("model")
    @classmethod
    def _model(cls, v):
        return _known_parameters(v, "HandDAPClassifier", ("material_attributes",))


class HandSplits(Section):
    seeds: list[int] = Field(default=[0, 1, 2, 3, 4], description="one simulated data set and model fit per seed")

    @field_validator("seeds")
    @classmethod
    def _seeds(cls, v):
        if any(not 0 <= s < 2**32 for s in v):
            raise ValueError("seeds must be in 0 .. 2**32 - 1")
        return distinct(non_empty(v))


class HandCompute(Compute):
    pass


class HandSettings(Section):
    """What the hand study reads: ``[simulation]``, ``[features]``, ``[methods]`` and ``[compute]``.

    Every hand study file is one (:class:`HandStudy` adds the data, seeds and output); from Python,
    give what differs from the defaults, e.g. ``HandSettings(methods={"max_T": 4})``
    (:func:`tzsl.studies.hand.study.run_hand_study`).
    """

    simulation: HandSimulation = Field(default_factory=HandSimulation)
    features: HandFeatures = Field(default_factory=HandFeatures)
    methods: HandMethods = Field(default_factory=HandMethods)
    compute: HandCompute = Field(default_factory=HandCompute)


class HandStudy(HandSettings):
    """``study = "hand"``, a preset of ``zero-shot``: the generic study's tables on the built-in
    ``hand-simulated`` dataset (``[zero_shot]``), then the DAP paper's Shadow-hand protocol (5 BioTacs,
    Tables 4-5, multi-grasp; sections 5.6-5.8) with its numbers."""

    study: Literal["hand"] = "hand"
    description: str = ""
    dataset: HandDataset
    splits: HandSplits = Field(default_factory=HandSplits)
    zero_shot: PresetZeroShot = Field(default_factory=PresetZeroShot)
    output: Output = Field(default_factory=Output)


# --------------------------------------------------------------------------- active-touch


class ActiveDataset(Section):
    builtin: Literal["phac2-penn"] = Field(default="phac2-penn", description="EP-prefixed per-trial features "
                                           "(Penn static features: squeeze, hold, slow and fast slide)")
    data_dir: str | None = Field(default=None,
                                 description="data home (default: $TZSL_DATA_DIR or the user data folder)")


class ActiveMethods(Section):
    """Per-EP attribute models, the active policy and the stopping rule (tzsl.models.PerEPAttributeModel)."""

    update: Literal["dap", "confusion"] = Field(default="dap", description="per-EP class scores: DAP log-scores, or "
                                                "the log-likelihood under the grouped-CV confusion model")
    cv: int = Field(default=5, ge=2,
                    description="object-grouped folds of the confusion estimate (training objects only)")
    n_samples: int = Field(default=128, ge=1, description="Monte-Carlo outcomes per class for the expected gain")
    thresholds: list[float] = Field(default=[0.7, 0.9, 0.99], description="stopping rule: stop once the top class "
                                    "posterior is >= a threshold (one row per threshold)")
    tempering: Literal["subset", "count", "none"] = Field(
        default="subset", description="exponents of the sequential posterior, fitted on pseudo-unseen training "
        "objects: one per set of EPs done, one per number of EPs done, or none (the plain product of the EPs' "
        "evidence)")
    decided_thresholds: list[float] = Field(
        default=[0.5, 0.6, 0.7, 0.8, 0.85, 0.9, 0.95, 0.99], description="thresholds of the decided-at-t table: "
        "accuracy of the trials whose top posterior reached t, against t")
    n_boot: int = Field(default=2000, ge=1, description="bootstrap replicates of the 95% intervals")

    @field_validator("thresholds", "decided_thresholds")
    @classmethod
    def _thresholds(cls, v):
        if any(not 0 < t <= 1 for t in v):
            raise ValueError("thresholds must be in (0, 1]")
        return distinct(non_empty(v))


class ActiveSplits(Section):
    kinds: list[Literal[SPLIT_KINDS]] = Field(default=list(SPLIT_KINDS))  # type: ignore[valid-type]  # Literal of a value list: pydantic reads it at run time, mypy cannot
    n_splits: int = Field(default=10, ge=1, description="random splits (the challenging splits are always 5)")
    n_test: int = Field(default=10, ge=2, description="test objects per random split")
    seed: int = Seed
    purpose: Literal["select", "confirm"] = Purpose

    _kinds = field_validator("kinds")(lambda v: distinct(non_empty(v)))


class ActiveHand(Section):
    """``[hand]``: the same policy choosing the next grasp type on SIMULATED Shadow-hand grasps (Table 4)."""

    simulated: bool = Field(default=True,
                            description="run the simulated-hand part (grasp types pinch / tripod / power)")
    seeds: list[int] = Field(default=[0, 1, 2], description="one simulated data set and model fit per seed")
    n_sequences: int = Field(default=20, ge=1, description="grasp sequences per test object and seed")
    max_grasps: int = Field(default=6, ge=1, description="grasps per sequence")
    cv: int = Field(default=3, ge=2, description="folds over training grasps for the grasp-type confusion model")

    @field_validator("seeds")
    @classmethod
    def _seeds(cls, v):
        if any(not 0 <= s < 2**32 for s in v):
            raise ValueError("seeds must be in 0 .. 2**32 - 1")
        return distinct(non_empty(v))


class ActiveTouchStudy(Section):
    """``study = "active-touch"``: choosing the next EP on PHAC-2 vs every fixed and a random order."""

    study: Literal["active-touch"] = "active-touch"
    description: str = ""
    dataset: ActiveDataset = Field(default_factory=ActiveDataset)
    methods: ActiveMethods = Field(default_factory=ActiveMethods)
    splits: ActiveSplits = Field(default_factory=ActiveSplits)
    hand: ActiveHand = Field(default_factory=ActiveHand)
    compute: Compute = Field(default_factory=Compute)
    output: Output = Field(default_factory=Output)
