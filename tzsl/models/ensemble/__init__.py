"""Ensembles of zero-shot methods: several registry methods, one class score.

The room of a method that combines others. :class:`ScoreEnsembleZSL` z-scores its members' class scores per
trial (:func:`tzsl.models.protocol.zscore_rows`) and averages them; its default members are
:data:`DEFAULT_MEMBERS`. The class is also at the top of :mod:`tzsl.models`.
"""

from tzsl.models.ensemble._score_ensemble import DEFAULT_MEMBERS, ScoreEnsembleZSL

__all__ = ["DEFAULT_MEMBERS", "ScoreEnsembleZSL"]
