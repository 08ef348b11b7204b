"""Where tzsl looks for datasets and keeps its caches.

One place decides the data home, in this order:

1. an explicit ``data_dir`` argument (the CLI's ``--data-dir``),
2. the environment variable ``TZSL_DATA_DIR``,
3. the per-user cache directory of the platform:
   ``platformdirs.user_cache_dir("tzsl") / "data"`` (e.g. ``~/.cache/tzsl/data`` on Linux).

Under the data home the layout is the same as the shared data folder:
``phac2/...``, ``fabric/...``, ``gelsight_press/...`` (see ``data/README.md``).
"""

from __future__ import annotations

import os
from pathlib import Path

import platformdirs

#: Environment variable naming the data home.
DATA_DIR_ENV = "TZSL_DATA_DIR"
#: Environment variable naming the cache directory (joblib.Memory and similar).
CACHE_DIR_ENV = "TZSL_CACHE_DIR"
_APP = "tzsl"


def get_data_home(data_dir: str | os.PathLike | None = None) -> Path:
    """The folder holding the datasets.

    Parameters
    ----------
    data_dir : str or path-like or None
        Explicit folder; wins over everything else. ``~`` is expanded.

    Returns
    -------
    Path
        Absolute path of the data home: ``data_dir``, else ``$TZSL_DATA_DIR``, else the
        per-user cache directory (``platformdirs.user_cache_dir("tzsl") / "data"``). The folder is
        not created and need not exist; loaders report missing files with
        :class:`tzsl.exceptions.DataMissingError`.
    """
    if data_dir is not None and str(data_dir) != "":
        return Path(data_dir).expanduser().resolve()
    env = os.environ.get(DATA_DIR_ENV)
    if env:
        return Path(env).expanduser().resolve()
    return (Path(platformdirs.user_cache_dir(_APP)) / "data").resolve()


def get_cache_dir(cache_dir: str | os.PathLike | None = None) -> Path:
    """The folder for on-disk caches (e.g. ``joblib.Memory``).

    Parameters
    ----------
    cache_dir : str or path-like or None
        Explicit folder; wins over everything else.

    Returns
    -------
    Path
        ``cache_dir``, else ``$TZSL_CACHE_DIR``, else
        ``platformdirs.user_cache_dir("tzsl") / "joblib"``. Not created here.
    """
    if cache_dir is not None and str(cache_dir) != "":
        return Path(cache_dir).expanduser().resolve()
    env = os.environ.get(CACHE_DIR_ENV)
    if env:
        return Path(env).expanduser().resolve()
    return (Path(platformdirs.user_cache_dir(_APP)) / "joblib").resolve()
