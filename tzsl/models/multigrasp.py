"""Recognition from a robot hand's grasps: fusion over fingers and over grasps.

One grasp: :func:`fuse_grasp_posteriors` fuses the touching BioTacs' attribute posteriors
(:data:`HAND_FUSIONS`: MAXDAP, AVGDAP, LDAP; DAP paper eqs. 7-10), as
:class:`tzsl.models.HandDAPClassifier` does. Several grasps (section 5.7.3): DF-MDAP
(:func:`df_mdap`, :func:`df_mdap_log_scores`), SC-MDAP (:func:`sc_mdap`) on grasp sequences
drawn by :func:`sample_grasp_sequences`, and the attribute distance matrix of eq. 13
(:func:`attribute_distance_matrix`).
"""

from tzsl.models._hand_dap import FUSIONS as HAND_FUSIONS
from tzsl.models._hand_dap import fuse_grasp_posteriors
from tzsl.models._multigrasp import (
    attribute_distance_matrix,
    df_mdap,
    df_mdap_log_scores,
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
