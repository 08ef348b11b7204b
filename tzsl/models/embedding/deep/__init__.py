"""The deep attribute embedding: a CNN + LSTM over key-frame sequences, trained with the F15 loss (F17).

The room of a deep (PyTorch) method. :class:`DeepAttributeEmbedding` is the fabric paper's lambda
embedding (:class:`tzsl.models.EmbeddingZSL`, same loss ``C + lambda R``) with a learned front end;
:func:`deep_model_arrays` and :func:`deep_model_from_arrays` give a fitted model as arrays and back (what
its bundle, :mod:`tzsl.inference.deep_bundles`, stores). Importing this module does not import torch;
fitting needs the ``deep`` extra (``pip install 'tzsl[deep]'``). The estimator is also at the top of
:mod:`tzsl.models`, the two functions in :mod:`tzsl.models.embedding`.
"""

from tzsl.models.embedding.deep._bundle import deep_model_arrays, deep_model_from_arrays
from tzsl.models.embedding.deep._model import DeepAttributeEmbedding

__all__ = ["DeepAttributeEmbedding", "deep_model_arrays", "deep_model_from_arrays"]
