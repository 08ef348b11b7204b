"""Imports every command module so each registers its commands on the root group."""

from tzsl.cli import _cache_commands  # noqa: F401
from tzsl.cli import _data_commands  # noqa: F401
from tzsl.cli import _dap_commands  # noqa: F401
from tzsl.cli import _dataset_commands  # noqa: F401
from tzsl.cli import _deep_commands  # noqa: F401
from tzsl.cli import _hand_commands  # noqa: F401
from tzsl.cli import _fabric_commands  # noqa: F401
from tzsl.cli import _fetch_commands  # noqa: F401
from tzsl.cli import _run_commands  # noqa: F401
from tzsl.cli import _methods_commands  # noqa: F401
from tzsl.cli import _predict_commands  # noqa: F401
