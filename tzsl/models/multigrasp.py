"""The hand's fusion helpers under their name before the rooms (issue 43): :mod:`tzsl.models.hand`.

Kept so that code written against ``tzsl.models.multigrasp`` keeps importing; every name here is the same
object as in :mod:`tzsl.models.hand`, where it is documented. New code imports from there.
"""

from tzsl.models.hand import (
    HAND_FUSIONS,
    attribute_distance_matrix,
    df_mdap,
    df_mdap_log_scores,
    fuse_grasp_posteriors,
    sample_grasp_sequences,
    sc_mdap,
)

__all__ = [
    "HAND_FUSIONS",
    "attribute_distance_matrix",
    "df_mdap",
    "df_mdap_log_scores",
    "fuse_grasp_posteriors",
    "sample_grasp_sequences",
    "sc_mdap",
]
