"""Test helper: a study's checked settings from flat keyword arguments (``n_splits=2, cv=3``).

Each key goes to the one table of the schema that has it (``svm_params`` = several ``[svm]`` keys;
``**{"methods.cv": 3}`` names the table where two have the key);
a key that no table, or two tables, have is an error, so the helper cannot route a setting silently.
"""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel

#: Appended to experiments/my_dataset_template.toml, the template made fast: one compared method, two random
#: splits, a one-point SVM grid, DAP-only GZSL (the command-line tests of a small dataset).
FAST_TEMPLATE = """
[methods]
compare = ["eszsl"]
sweep = false

[gzsl]
methods = ["dap"]

[splits]
n_splits = 2

[svm]
n_C = 1
n_gamma = 1
n_draws = 1
"""


def study_settings(schema: type[BaseModel], preset: str | None = None, **flat: Any) -> BaseModel:
    """``schema`` validated from ``flat`` keys sorted into its tables (tuples as lists, as TOML gives),
    on top of ``preset``'s defaults (:data:`tzsl.studies.config.PRESET_DEFAULTS`; None: the generic study's)."""
    tables: dict[str, dict[str, Any]] = {}
    for key, value in flat.items():
        if key == "svm_params":
            tables.setdefault("svm", {}).update({k: 0 if k == "cv" and v is None else v for k, v in value.items()})
            continue
        if "." in key:  # "table.key" where two tables have the key
            table, key = key.split(".")
            tables.setdefault(table, {})[key] = list(value) if isinstance(value, tuple) else value
            continue
        owners = [name for name, field in schema.model_fields.items()
                  if isinstance(field.annotation, type) and issubclass(field.annotation, BaseModel)
                  and key in field.annotation.model_fields]
        if len(owners) != 1:
            raise KeyError(f"{key!r} is in the tables {owners} of {schema.__name__}, not exactly one")
        tables.setdefault(owners[0], {})[key] = list(value) if isinstance(value, tuple) else value
    if preset is not None:
        from tzsl.studies.config import with_preset_defaults

        tables = with_preset_defaults(tables, preset)
    return schema.model_validate(tables)
