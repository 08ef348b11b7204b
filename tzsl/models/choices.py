"""The choices a user inherits (:data:`tzsl.models.INHERITED_CHOICES`), as records and as a table.

One :class:`InheritedChoice` per choice; :func:`inherited_choices` gives them as plain dicts
(the documentation's page is generated from it); :data:`NO_SELECTION_SPLITS` is what a choice
made on no recorded splits says; :data:`DEFAULT_METHOD` is the method `tzsl train-attributes` trains
without --method; :data:`BENCHMARK_CHECKED` names the benchmark datasets the defaults were checked on.
"""

from tzsl.models._choices import (
    BENCHMARK_CHECKED,
    DEFAULT_METHOD,
    NO_SELECTION_SPLITS,
    InheritedChoice,
    inherited_choices,
)

__all__ = ["BENCHMARK_CHECKED", "DEFAULT_METHOD", "NO_SELECTION_SPLITS", "InheritedChoice", "inherited_choices"]
