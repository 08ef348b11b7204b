"""Splits, metrics and the evaluation pieces every study composes.

Object splits for zero-shot evaluation (random and challenging, DAP paper 4.2 and 4.6),
their CSV files, and the metrics reported per split (trial accuracy, per-class mean
accuracy, per-attribute balanced accuracy, generalised-ZSL scores); mean and std rows over
splits or seeds (:func:`summarise_over_splits`, the one place studies average); the GZSL
protocol's held-out trials and calibrated stacking; hyper-parameter selection on training
classes only (:func:`select_embedding_alpha`). The studies in :mod:`tzsl.experiments` import
these from here.
"""

from tzsl.evaluation._metrics import (
    gzsl_scores,
    per_attribute_balanced_accuracy,
    per_class_accuracy,
    per_class_mean_accuracy,
    summarise_over_splits,
    trial_accuracy,
)
from tzsl.evaluation._challenging_splits import challenging_splits
from tzsl.evaluation._split_io import read_splits_csv, write_splits_csv
from tzsl.evaluation._splits import (
    Split,
    attribute_exclusions,
    check_attribute_table,
    duplicate_attribute_groups,
    random_object_splits,
)

__all__: list[str] = [
    "Split",
    "attribute_exclusions",
    "challenging_splits",
    "check_attribute_table",
    "duplicate_attribute_groups",
    "gzsl_scores",
    "per_attribute_balanced_accuracy",
    "per_class_accuracy",
    "per_class_mean_accuracy",
    "random_object_splits",
    "read_splits_csv",
    "summarise_over_splits",
    "trial_accuracy",
    "write_splits_csv",
]

# GZSL protocol pieces (moved from tzsl.experiments.gzsl)
from tzsl.evaluation._gzsl import choose_stacking_constant, holdout_trials, stacked_predict  # noqa: E402

__all__ += ["choose_stacking_constant", "holdout_trials", "stacked_predict"]

# model selection on training classes (moved from tzsl.experiments.fabric)
from tzsl.evaluation._model_selection import DEFAULT_ALPHAS, select_embedding_alpha  # noqa: E402

__all__ += ["DEFAULT_ALPHAS", "select_embedding_alpha"]
