"""Imports every command module so each registers its commands on the root group."""

from tzsl.cli import (
    _benchmark_commands,  # noqa: F401
    _cache_commands,  # noqa: F401
    _dap_commands,  # noqa: F401
    _data_commands,  # noqa: F401
    _dataset_commands,  # noqa: F401
    _deep_commands,  # noqa: F401
    _fabric_commands,  # noqa: F401
    _fetch_commands,  # noqa: F401
    _hand_commands,  # noqa: F401
    _methods_commands,  # noqa: F401
    _predict_commands,  # noqa: F401
    _run_commands,  # noqa: F401
)
