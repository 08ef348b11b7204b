"""Embedding and compatibility methods: attribute models whose scores are a vector in attribute space.

The room of a new embedding or compatibility model (``score_kind = "embedding"``, read by
:class:`tzsl.models.CompatibilityRule` or :class:`tzsl.models.NearestAttributeRule`): ESZSL
(:class:`ESZSL`, :class:`ESZSLCV`), the semantic autoencoder (:class:`SAE`, :class:`SAECV`), the
bilinear compatibility models trained by SGD (:class:`ALE`, :class:`SJE`, :class:`DeViSE`) and the
fabric paper's lambda embedding (:class:`EmbeddingZSL`), whose deep version (CNN + LSTM over key
frames) is the sub-room :mod:`tzsl.models.embedding.deep`.

Helpers: the weights of the classification and regression losses for a given ``lam``
(:func:`loss_weights`), and the deep model as arrays and back (:func:`deep_model_arrays`,
:func:`deep_model_from_arrays`, from :mod:`tzsl.models.embedding.deep`; its bundle file is
:mod:`tzsl.inference.deep_bundles`; both need the ``deep`` extra). The estimators are also at the top of
:mod:`tzsl.models`.
"""

from tzsl.models.embedding._compatibility import ALE, SJE, DeViSE
from tzsl.models.embedding._embedding import EmbeddingZSL, loss_weights
from tzsl.models.embedding._eszsl import ESZSL, ESZSLCV
from tzsl.models.embedding._sae import SAE, SAECV
from tzsl.models.embedding.deep import DeepAttributeEmbedding, deep_model_arrays, deep_model_from_arrays

__all__ = ["ALE", "ESZSL", "ESZSLCV", "SAE", "SAECV", "SJE", "DeViSE", "DeepAttributeEmbedding", "EmbeddingZSL",
           "deep_model_arrays", "deep_model_from_arrays", "loss_weights"]
