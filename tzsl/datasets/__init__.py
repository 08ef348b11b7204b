"""Dataset registry, data home and loaders (files -> arrays + a trial table)."""

from tzsl.datasets._types import PHAC2_EPS, TRIAL_COLUMNS, BiotacSignals, FeatureSet, RawTrial

__all__ = ["PHAC2_EPS", "TRIAL_COLUMNS", "BiotacSignals", "FeatureSet", "RawTrial"]
