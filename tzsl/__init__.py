"""tzsl: tactile zero-shot learning.

Recognise objects a robot has never touched from their attribute description, by learning
attribute detectors from touch data of other objects (DAP, ESZSL, learned embeddings).

Layers (lower never imports higher): ``tzsl.datasets`` (files -> arrays + trial table),
``tzsl.features`` (scikit-learn transformers), ``tzsl.models`` (scikit-learn estimators),
``tzsl.evaluation`` (splits, metrics), ``tzsl.experiments`` (studies writing tables and
figures) and ``tzsl.cli`` (the ``tzsl`` command).
"""

from tzsl.exceptions import TzslError

__version__ = "0.1.0"

__all__ = ["TzslError", "__version__"]
