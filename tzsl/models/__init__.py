"""Zero-shot models as scikit-learn estimators."""

from tzsl.models._embedding import EmbeddingZSL
from tzsl.models._eszsl import ESZSL, ESZSLCV

__all__: list[str] = ["ESZSL", "ESZSLCV", "EmbeddingZSL"]
