"""A robot hand: recognition from its grasps, fusion over fingers and over grasps.

One grasp: :func:`fuse_grasp_posteriors` fuses the touching BioTacs' attribute posteriors
(:data:`HAND_FUSIONS`: MAXDAP, AVGDAP, LDAP; DAP paper eqs. 7-10), as
:class:`tzsl.models.HandDAPClassifier` does. Several grasps (section 5.7.3): DF-MDAP
(:func:`df_mdap`, :func:`df_mdap_log_scores`), SC-MDAP (:func:`sc_mdap`) on grasp sequences
drawn by :func:`sample_grasp_sequences`, and the attribute distance matrix of eq. 13
(:func:`attribute_distance_matrix`).

The room of a method for a robot hand (input kind ``"grasps"``). :class:`HandDAPClassifier` and
:class:`NoContactError` are also at the top of :mod:`tzsl.models`; these helpers were
:mod:`tzsl.models.multigrasp` before the rooms (that name still imports them).
"""

from tzsl.models.hand._hand_dap import FUSIONS as HAND_FUSIONS
from tzsl.models.hand._hand_dap import HandDAPClassifier, NoContactError, fuse_grasp_posteriors
from tzsl.models.hand._multigrasp import (
    attribute_distance_matrix,
    df_mdap,
    df_mdap_log_scores,
    sample_grasp_sequences,
    sc_mdap,
)

__all__ = [
    "HandDAPClassifier",
    "NoContactError",
    "HAND_FUSIONS",
    "attribute_distance_matrix",
    "df_mdap",
    "df_mdap_log_scores",
    "fuse_grasp_posteriors",
    "sample_grasp_sequences",
    "sc_mdap",
]
