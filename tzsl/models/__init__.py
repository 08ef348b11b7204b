"""Zero-shot models as scikit-learn estimators."""

__all__: list[str] = []
