"""Zero-shot models as scikit-learn estimators.

One protocol (:class:`ZeroShotClassifier` = attribute model + decision rule), a method registry
(:func:`build_method`, :func:`available_methods`) and :func:`all_estimators`.
"""

from tzsl.models._attribute_svm import AttributeSVM
from tzsl.models._attribute_bank import AttributeClassifierBank
from tzsl.models._attribute_search import SEARCHES
from tzsl.models._attribute_training import (
    AUTO_MAX_EXACT_TRIALS,
    GRIDS,
    SOLVERS,
    AttributeTrainingError,
    GridEdgeWarning,
    balanced_object_draws,
    default_preprocessor,
    fit_platt,
    fit_platt_many,
    gamma_grid,
)
from tzsl.models._scalable_attribute import ScalableAttributeClassifier
from tzsl.models._dap import (
    attribute_prior,
    break_ties,
    check_attribute_posteriors,
    check_class_attributes,
    dap_accuracy_over_subsets,
    dap_log_scores,
    fuse_attribute_posteriors,
)
from tzsl.models._decision import (
    CompatibilityRule,
    DAPRule,
    DecisionRule,
    NearestAttributeRule,
    cosine_similarities,
    squared_distances,
)
from tzsl.models._embedding import EmbeddingZSL, loss_weights
from tzsl.models._deep import DeepAttributeEmbedding
from tzsl.models._deep_bundle import load_deep_bundle, save_deep_bundle
from tzsl.models._hand_dap import FUSIONS as HAND_FUSIONS
from tzsl.models._hand_dap import HandDAPClassifier, NoContactError, fuse_grasp_posteriors
from tzsl.models._multigrasp import (
    attribute_distance_matrix,
    df_mdap,
    df_mdap_log_scores,
    sample_grasp_sequences,
    sc_mdap,
)
from tzsl.models._multilabel import MultiLabelAttributeClassifier
from tzsl.models._eszsl import ESZSL, ESZSLCV
from tzsl.models._iap import IAP
from tzsl.models._sae import SAE, SAECV
from tzsl.models._compatibility import ALE, SJE, DeViSE
from tzsl.models._active_touch import (
    PHAC2_EP_SECONDS,
    LogisticAttribute,
    PerEPAttributeModel,
    binned_confusion,
    ep_column_blocks,
)
from tzsl.models._active_suggest import suggest_next_ep
from tzsl.models._active_policy import (
    TEMPERINGS,
    done_subset_index,
    expected_information_gain,
    fit_posterior_exponents,
    outcome_log_likelihoods,
    run_policy,
    sequential_log_posterior,
    stop_reasons,
)
from tzsl.models._zsl_input import (
    MIN_CV_CLASSES,
    ZSLInputError,
    attribute_rows,
    class_grouped_folds,
    training_classes,
)
from tzsl.models._validation import ParameterError
from tzsl.models._zero_shot import ZeroShotClassifier, score_kind
from tzsl.models._registry import (
    FAMILIES,
    INPUT_KINDS,
    Method,
    all_estimators,
    available_methods,
    build_method,
    get_method,
    register_method,
    unregister_method,
)
from tzsl.models._score_ensemble import ScoreEnsembleZSL, zscore_rows
from tzsl._fit_store import FITS_FOLDER, count_fits, fit_cached, fit_store_counts, resolve_store
from tzsl.models._posterior_calibration import (
    CALIBRATIONS,
    CalibratedZeroShotClassifier,
    CalibrationWarning,
    fit_temperature,
    pseudo_unseen_scores,
    tempered_proba,
)
from tzsl.models import _builtin_methods  # noqa: F401,E402  (registers the shipped methods)
from tzsl.models._choices import (  # noqa: E402
    INHERITED_CHOICES,
    NO_SELECTION_SPLITS,
    InheritedChoice,
    inherited_choices,
)

__all__: list[str] = [
    "FITS_FOLDER",
    "count_fits",
    "fit_cached",
    "fit_store_counts",
    "resolve_store",
    "DeepAttributeEmbedding",
    "load_deep_bundle",
    "save_deep_bundle",
    "HAND_FUSIONS",
    "HandDAPClassifier",
    "NoContactError",
    "fuse_grasp_posteriors",
    "attribute_distance_matrix",
    "df_mdap",
    "df_mdap_log_scores",
    "sample_grasp_sequences",
    "sc_mdap",
    "AttributeClassifierBank",
    "AttributeSVM",
    "AttributeTrainingError",
    "AUTO_MAX_EXACT_TRIALS",
    "SOLVERS",
    "GRIDS",
    "SEARCHES",
    "GridEdgeWarning",
    "ScalableAttributeClassifier",
    "balanced_object_draws",
    "default_preprocessor",
    "fit_platt",
    "fit_platt_many",
    "gamma_grid",
    "MultiLabelAttributeClassifier",
    "attribute_prior",
    "check_attribute_posteriors",
    "check_class_attributes",
    "dap_accuracy_over_subsets",
    "break_ties",
    "dap_log_scores",
    "fuse_attribute_posteriors",
    "CompatibilityRule",
    "DAPRule",
    "DecisionRule",
    "NearestAttributeRule",
    "squared_distances",
    "cosine_similarities",
    "ZeroShotClassifier",
    "score_kind",
    "ParameterError",
    "ZSLInputError",
    "attribute_rows",
    "class_grouped_folds",
    "fit_temperature",
    "MIN_CV_CLASSES",
    "training_classes",
    "FAMILIES",
    "INPUT_KINDS",
    "Method",
    "all_estimators",
    "available_methods",
    "build_method",
    "get_method",
    "register_method",
    "unregister_method",
    "ESZSL", "ESZSLCV", "EmbeddingZSL", "loss_weights", "IAP", "SAE", "SAECV", "ALE", "SJE", "DeViSE",
    "PHAC2_EP_SECONDS", "LogisticAttribute", "PerEPAttributeModel", "binned_confusion", "ep_column_blocks",
    "suggest_next_ep", "TEMPERINGS", "done_subset_index", "fit_posterior_exponents",
    "expected_information_gain", "outcome_log_likelihoods", "run_policy", "sequential_log_posterior",
    "stop_reasons", "ScoreEnsembleZSL", "zscore_rows",
    "INHERITED_CHOICES", "NO_SELECTION_SPLITS", "InheritedChoice", "inherited_choices",
    "CALIBRATIONS", "CalibratedZeroShotClassifier", "CalibrationWarning", "fit_temperature", "pseudo_unseen_scores",
    "tempered_proba"]
