"""The experiment schema: one typed model per study kind, every default written once.

``study = "zero-shot"`` (:class:`ZeroShotStudy`, any dataset), its PHAC-2 paper preset
``"phac2-dap"`` (:class:`Phac2Study`), ``"fabric"`` (:class:`FabricStudy`),
``"fabric-deep"`` (:class:`FabricDeepStudy`), ``"hand"`` (:class:`HandStudy`) and
``"active-touch"`` (:class:`ActiveTouchStudy`), each registered with its runner by
:func:`register_study` (:func:`study_kinds` lists them). Each table of
an experiment file is a strict pydantic model (unknown keys, wrong types and bad ranges are
errors, all reported at once as ``FILE: key.path: reason``). Each study reads its own
validated tables (the DAP study: :class:`DapSettings`, which every zero-shot study file is), and the
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
    method_label,
)
from tzsl.studies.config._load import (
    Experiment,
    builtin_names,
    builtin_text,
    config_from_options,
    defaults,
    load_experiment,
    to_toml,
    validate,
)
from tzsl.studies.config._phac2 import (
    DapSettings,
    Phac2Dataset,
    Phac2Features,
    Phac2Gzsl,
    Phac2Methods,
    Phac2Splits,
    Phac2Study,
    Phac2Svm,
    ZeroShotMethods,
    ZeroShotSplits,
    ZeroShotStudy,
    every_feature_method,
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
from tzsl.studies.config._registry import (
    StudyKind,
    get_study,
    register_study,
    study_kinds,
    study_names,
    unregister_study,
)

__all__ = [
    "DATASET_PATHS", "SEED_LIMIT", "StudyKind", "get_study", "register_study", "study_kinds", "study_names",
    "unregister_study",
    "ActiveMethods", "ActiveSplits", "ActiveTouchStudy", "Compute",
    "DapSettings", "DaskCompute", "Experiment", "FabricDeepStudy",
    "FabricStudy", "HandFeatures", "HandMethods", "HandSettings", "HandSimulation", "HandStudy", "Output", "Phac2Dataset",
    "Phac2Features", "Phac2Gzsl", "Phac2Methods", "Phac2Splits", "Phac2Study", "Phac2Svm", "builtin_names",
    "builtin_text", "check_n_jobs", "config_from_options", "defaults", "estimator_parameters", "load_experiment",
    "to_toml",
    "dap_label", "method_label", "validate", "ZeroShotMethods", "ZeroShotSplits", "ZeroShotStudy", "every_feature_method",
]
