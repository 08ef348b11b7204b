"""``tzsl extract``'s summary of a FeatureSet (its features come from :func:`tzsl.features.dataset_features`)."""

from __future__ import annotations

from typing import TypedDict

from tzsl.datasets import FeatureSet

__all__ = ["FeatureSummary", "format_summary", "summarise"]


class FeatureSummary(TypedDict):
    """What :func:`summarise` returns (a plain dict with these keys)."""

    dataset: str
    trials: int
    objects: int
    sensors: int
    sensor_names: list[str]
    dimensions: int
    kept_attributes: list[str]
    dropped_attributes: list[str]


def summarise(features: FeatureSet) -> FeatureSummary:
    """What ``tzsl extract`` prints: counts, dimensions, kept and dropped attributes."""
    return {
        "dataset": features.dataset,
        "trials": features.n_trials,
        "objects": features.n_objects,
        "sensors": len(features.sensors),
        "sensor_names": list(features.sensors),
        "dimensions": int(features.X.shape[2]),
        "kept_attributes": list(features.attributes.columns),
        "dropped_attributes": list(features.info.get("dropped_attributes", [])),
    }


def format_summary(summary: FeatureSummary) -> str:
    """Human-readable lines of :func:`summarise`."""
    kept = summary["kept_attributes"]
    dropped = summary["dropped_attributes"]
    return "\n".join([
        f"dataset:    {summary['dataset']}",
        f"trials:     {summary['trials']}",
        f"objects:    {summary['objects']}",
        f"sensors:    {summary['sensors']} ({', '.join(summary['sensor_names'])})",
        f"dimensions: {summary['dimensions']} per sensor",
        f"attributes: {len(kept)} kept: {', '.join(kept)}",
        f"dropped:    {len(dropped)} ({', '.join(dropped) if dropped else 'none'})",
    ])
