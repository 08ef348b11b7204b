"""Helpers of the learned embeddings (:class:`tzsl.models.EmbeddingZSL`, :class:`tzsl.models.DeepAttributeEmbedding`).

The weights of the classification and regression losses for a given ``lam``
(:func:`loss_weights`), and the deep model as arrays and back (:func:`deep_model_arrays`,
:func:`deep_model_from_arrays`; its bundle file is :mod:`tzsl.inference.deep_bundles`; both need
the ``deep`` extra).
"""

from tzsl.models._deep_bundle import deep_model_arrays, deep_model_from_arrays
from tzsl.models._embedding import loss_weights

__all__ = ["deep_model_arrays", "deep_model_from_arrays", "loss_weights"]
