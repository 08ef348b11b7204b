"""Helpers of the learned embeddings (:class:`tzsl.models.EmbeddingZSL`, :class:`tzsl.models.DeepAttributeEmbedding`).

The weights of the classification and regression losses for a given ``lam``
(:func:`loss_weights`), and the deep model's files (:func:`save_deep_bundle`,
:func:`load_deep_bundle`; loading a bundle needs the ``deep`` extra).
"""

from tzsl.models._deep_bundle import load_deep_bundle, save_deep_bundle
from tzsl.models._embedding import loss_weights

__all__ = ["load_deep_bundle", "loss_weights", "save_deep_bundle"]
