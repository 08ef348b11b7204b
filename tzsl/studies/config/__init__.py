"""The experiment schema: one typed model per study kind, every default written once.

``study = "zero-shot"`` and its PHAC-2 paper preset ``"phac2-dap"`` (:class:`ZeroShotStudy`, any
dataset; what the preset changes of the defaults is :data:`PRESET_DEFAULTS`), ``"fabric"`` (:class:`FabricStudy`),
``"fabric-deep"`` (:class:`FabricDeepStudy`), ``"hand"`` (:class:`HandStudy`) and
``"active-touch"`` (:class:`ActiveTouchStudy`), each registered with its runner by
:func:`register_study` (:func:`study_kinds` lists them). Each table of
an experiment file is a strict pydantic model (unknown keys, wrong types and bad ranges are
errors, all reported at once as ``FILE: key.path: reason``). Each study reads its own
validated tables (the zero-shot study: :class:`ZeroShotSettings`, which every zero-shot study file is), and the
command-line options read their defaults from here; where a default is an estimator's, it is read from the estimator.

``[methods] compare = ["eszsl", {name = "embedding", lam = 0.1}]`` lists registry methods
(``tzsl methods``) with parameters, checked against the registry at load time.
"""

from tzsl.studies.config._common import (
    DATASET_PATHS,
    SEED_LIMIT,
    Compute,
    DaskCompute,
    Output,
    check_n_jobs,
    dap_label,
    dap_settings,
    method_label,
    registered_method,
)
from tzsl.studies.config._load import (
    OPTION_KEYS,
    Experiment,
    builtin_names,
    builtin_text,
    config_from_options,
    defaults,
    load_experiment,
    option_values,
    to_toml,
    validate,
)
from tzsl.studies.config._registry import (
    StudyKind,
    get_study,
    register_study,
    study_kinds,
    study_names,
    unregister_study,
)
from tzsl.studies.config._studies import (
    ActiveMethods,
    ActiveSplits,
    ActiveTouchStudy,
    FabricDeepStudy,
    FabricStudy,
    HandFeatures,
    HandMethods,
    HandSettings,
    HandSimulation,
    HandStudy,
    estimator_parameters,
)
from tzsl.studies.config._zero_shot import (
    PRESET_DEFAULTS,
    DatasetSource,
    GzslSettings,
    PrefixedOutput,
    PresetZeroShot,
    SignalFeatures,
    SvmSettings,
    ZeroShotMethods,
    ZeroShotSettings,
    ZeroShotSplits,
    ZeroShotStudy,
    every_feature_method,
    with_preset_defaults,
)

__all__ = [
    "DATASET_PATHS", "SEED_LIMIT", "StudyKind", "get_study", "register_study", "study_kinds", "study_names",
    "unregister_study",
    "ActiveMethods", "ActiveSplits", "ActiveTouchStudy", "Compute", "DaskCompute", "Experiment", "FabricDeepStudy",
    "FabricStudy", "HandFeatures", "HandMethods", "HandSettings", "HandSimulation", "HandStudy", "Output",
    "PRESET_DEFAULTS", "DatasetSource", "GzslSettings", "PrefixedOutput", "PresetZeroShot", "SignalFeatures",
    "SvmSettings", "ZeroShotMethods", "ZeroShotSettings", "ZeroShotSplits", "ZeroShotStudy", "every_feature_method",
    "with_preset_defaults", "builtin_names", "builtin_text", "check_n_jobs", "config_from_options", "defaults",
    "estimator_parameters", "load_experiment", "OPTION_KEYS", "option_values", "to_toml", "dap_label", "method_label",
    "dap_settings", "registered_method", "validate",
]
