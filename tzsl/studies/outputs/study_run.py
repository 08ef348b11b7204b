"""What a study gives: :class:`StudyRun`, what every study runner returns, and how runners print a table.

A study reads its settings from its checked experiment file (:mod:`tzsl.studies.config`) itself;
nothing converts them. Shared by the engine and the runners (so neither imports the other both ways).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import pandas as pd

from tzsl.studies.outputs.failures import table_failures

__all__ = ["StudyRun", "format_table"]


@dataclass
class StudyRun:
    """What :func:`execute_study` returns: the tables written and what the manifest records."""

    tables: dict[str, pd.DataFrame]
    record: dict[str, Any]
    data_files: list = field(default_factory=list)

    @property
    def failures(self) -> list[str]:
        """One line per failed (split, method) fit, read from the tables' ``error`` columns."""
        return table_failures(self.tables)


def format_table(table: pd.DataFrame) -> str:
    """A table as the runners print it: no index, three decimals, ``-`` for NaN."""
    return table.to_string(index=False, float_format=lambda v: f"{v:.3f}", na_rep="-")
