"""Splits, metrics and the evaluation pieces every study composes.

Object splits for zero-shot evaluation (random and challenging, DAP paper 4.2 and 4.6),
their CSV files, and the metrics reported per split (trial accuracy, per-class mean
accuracy, per-attribute balanced accuracy, generalised-ZSL scores), the calibration of class posteriors
(expected calibration error, Brier score, reliability table), the within-object correlation of
attribute errors; mean and std rows over
splits or seeds (:func:`summarise_over_splits`, the one place studies average); the GZSL
protocol's held-out trials and calibrated stacking; hyper-parameter selection on training
classes only (:func:`select_embedding_alpha`). The studies in :mod:`tzsl.studies` import
these from here.
"""

from tzsl.evaluation._challenging_splits import challenging_splits
from tzsl.evaluation._metrics import (
    gzsl_scores,
    per_attribute_balanced_accuracy,
    per_class_accuracy,
    per_class_mean_accuracy,
    summarise_over_splits,
    trial_accuracy,
)
from tzsl.evaluation._split_io import read_splits_csv, write_splits_csv
from tzsl.evaluation._splits import (
    PURPOSES,
    Split,
    attribute_exclusions,
    check_attribute_table,
    duplicate_attribute_groups,
    purpose_seed,
    random_object_splits,
    split_purpose,
)

__all__: list[str] = [
    "PURPOSES",
    "Split",
    "attribute_exclusions",
    "challenging_splits",
    "check_attribute_table",
    "duplicate_attribute_groups",
    "gzsl_scores",
    "per_attribute_balanced_accuracy",
    "per_class_accuracy",
    "per_class_mean_accuracy",
    "purpose_seed",
    "random_object_splits",
    "read_splits_csv",
    "split_purpose",
    "summarise_over_splits",
    "trial_accuracy",
    "write_splits_csv",
]

# Intervals: two-level bootstrap over splits and test classes, paired differences.
from tzsl.evaluation._intervals import (
    Interval,
    bootstrap_accuracy,
    bootstrap_accuracy_columns,
    bootstrap_cell_weights,
    bootstrap_trial_weights,
    cluster_cells,
    paired_difference_interval,
    paired_differences_table,
    splits_for_paired_interval,
)

__all__ += [
    "Interval",
    "bootstrap_accuracy",
    "bootstrap_accuracy_columns",
    "bootstrap_cell_weights",
    "bootstrap_trial_weights",
    "cluster_cells",
    "paired_difference_interval",
    "paired_differences_table",
    "splits_for_paired_interval",
]

# Baselines: chance, majority class, per-attribute majority, shuffled-rows negative control.
from tzsl.evaluation._baselines import (  # noqa: E402
    attribute_baselines,
    chance_accuracy,
    majority_class_accuracy,
    shuffled_attribute_rows,
    shuffled_rows_control,
)

__all__ += [
    "attribute_baselines",
    "chance_accuracy",
    "majority_class_accuracy",
    "shuffled_attribute_rows",
    "shuffled_rows_control",
]

# Zero-shot validity: test classes whose attribute row occurs in training, and a valid variant.
from tzsl.evaluation._zero_shot_check import (  # noqa: E402
    ZeroShotVariant,
    seen_test_classes,
    zero_shot_variant,
)

__all__ += ["ZeroShotVariant", "seen_test_classes", "zero_shot_variant"]

# GZSL protocol pieces (moved from tzsl.studies.zero_shot.gzsl)
from tzsl.evaluation._gzsl import choose_stacking_constant, holdout_trials, stacked_predict  # noqa: E402

__all__ += ["choose_stacking_constant", "holdout_trials", "stacked_predict"]

# model selection on training classes (moved from tzsl.studies.fabric.study)
from tzsl.evaluation._model_selection import DEFAULT_ALPHAS, select_embedding_alpha  # noqa: E402

__all__ += ["DEFAULT_ALPHAS", "select_embedding_alpha"]

# Calibration of class posteriors: ECE (equal-mass bins), Brier score, reliability diagram points.
from tzsl.evaluation._calibration import (  # noqa: E402
    CALIBRATION_METRICS,
    DEFAULT_N_BINS,
    CalibrationTerms,
    add_calibration_columns,
    brier_score,
    calibration_columns,
    calibration_intervals,
    calibration_terms,
    equal_mass_bins,
    expected_calibration_error,
    expected_ece_if_calibrated,
    reliability_table,
)

__all__ += ["CALIBRATION_METRICS", "DEFAULT_N_BINS", "CalibrationTerms", "add_calibration_columns", "brier_score",
            "calibration_columns", "calibration_intervals", "calibration_terms", "equal_mass_bins",
            "expected_calibration_error", "expected_ece_if_calibrated", "reliability_table"]

# Trust columns: the interval, chance and majority baseline beside every accuracy a study writes.
from tzsl.evaluation._trust import (  # noqa: E402
    INTERVAL_DOC,
    Outcomes,
    add_trust_columns,
    attribute_intervals,
    interval_columns,
)

__all__ += ["INTERVAL_DOC", "Outcomes", "add_trust_columns", "attribute_intervals", "interval_columns"]

# Whether an object's attributes are mispredicted together (what DAP's product is sensitive to).
from tzsl.evaluation._attribute_errors import within_object_error_correlation  # noqa: E402

__all__ += ["within_object_error_correlation"]
