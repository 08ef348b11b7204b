"""The result type of the hand study (:class:`HandStudyResult`), in a module of its own so that the study
and its tables import it without importing each other."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

__all__ = ["HandStudyResult"]


@dataclass
class HandStudyResult:
    """Tables of one :func:`run_hand_study` call (each with per-seed, ``mean`` and ``std`` rows).

    Attributes
    ----------
    table5, multigrasp_T, multigrasp_k, attribute_accuracy, attribute_distance, confusion : DataFrame
    method_comparison : DataFrame
        Every method on the same test grasps, LDAP the reference (``hand_method_comparison.csv``).
    simulated : bool
        Whether the grasps came from the simulator.
    notes : list of str
        Grasps dropped, sequence lengths capped, ...
    written : list of Path
    record : dict
        What the run's manifest records of the study: ``"hand"`` (settings, seeds, the grasps' source,
        whether simulated, the table's split), ``"notes"`` and, when simulated, ``"simulation"``.
    data_files : list of Path
        The data files read (the grasp folder's ``grasps.csv``), checksummed in the manifest.
    """

    table5: pd.DataFrame
    multigrasp_T: pd.DataFrame
    multigrasp_k: pd.DataFrame
    attribute_accuracy: pd.DataFrame
    attribute_distance: pd.DataFrame
    confusion: pd.DataFrame
    method_comparison: pd.DataFrame
    simulated: bool
    notes: list[str] = field(default_factory=list)
    written: list[Path] = field(default_factory=list)
    record: dict = field(default_factory=dict)
    data_files: list[Path] = field(default_factory=list)
