"""The kinds of model bundle tzsl writes (the header's ``kind``) and the metadata fields loading reads,
in a module that imports nothing.

Read by the code that saves bundles (:mod:`tzsl.inference.model_bundles`,
:mod:`tzsl.inference.predict_active`) and by the code that loads them for ``tzsl predict``, which
must not import scikit-learn before it knows the bundle needs it.
"""

from __future__ import annotations

__all__ = ["DEEP_KIND", "PER_EP_KIND", "ZERO_SHOT_KIND", "left_out_attributes"]

#: Bundle kind of every zero-shot model that ``tzsl predict`` ranks classes with (attribute model + rule).
ZERO_SHOT_KIND = "zero-shot"
#: Bundle kind of the deep CNN + LSTM (npz weights).
DEEP_KIND = "deep"
#: Bundle kind of a saved :class:`~tzsl.models.PerEPAttributeModel` (active touch).
PER_EP_KIND = "per-ep"


def left_out_attributes(metadata: dict) -> list[str]:
    """Names of the attributes a bundle's model left out (its ``left_out_attributes``; [] for older bundles)."""
    return [str(r["attribute"]) for r in metadata.get("left_out_attributes", []) if isinstance(r, dict)]
