"""Feature extraction as scikit-learn transformers."""

__all__: list[str] = []
