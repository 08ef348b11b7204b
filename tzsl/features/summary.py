"""``tzsl extract``'s summary of a FeatureSet (its features come from :func:`tzsl.features.dataset_features`)."""

from __future__ import annotations

from tzsl.datasets import FeatureSet

__all__ = ["format_summary", "summarise"]


def summarise(features: FeatureSet) -> dict[str, object]:
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


def format_summary(summary: dict[str, object]) -> str:
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

