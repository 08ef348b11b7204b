"""The choices a user inherits (:data:`tzsl.models.INHERITED_CHOICES`), as records and as a table.

One :class:`InheritedChoice` per choice; :func:`inherited_choices` gives them as plain dicts
(the documentation's page is generated from it); :data:`NO_SELECTION_SPLITS` is what a choice
made on no recorded splits says; :data:`DEFAULT_METHOD` is the method `tzsl train-attributes` trains
without --method.
"""

from tzsl.models._choices import DEFAULT_METHOD, NO_SELECTION_SPLITS, InheritedChoice, inherited_choices

__all__ = ["DEFAULT_METHOD", "NO_SELECTION_SPLITS", "InheritedChoice", "inherited_choices"]
