"""Where tzsl looks for datasets.

One place decides the data home, in this order:

1. an explicit ``data_dir`` argument (the CLI's ``--data-dir``),
2. the environment variable ``TZSL_DATA_DIR``,
3. the per-user cache directory of the platform:
   ``platformdirs.user_cache_dir("tzsl") / "data"`` (e.g. ``~/.cache/tzsl/data`` on Linux).

Under the data home the layout is the same as the shared data folder:
``phac2/...``, ``fabric/...``, ``gelsight_press/...`` (see ``data/README.md``). The cache folder
(:func:`tzsl.cache.get_cache_dir`, re-exported by :mod:`tzsl.datasets`) is decided in :mod:`tzsl.cache`.
"""

from __future__ import annotations

import os
from pathlib import Path

from tzsl.cache import user_cache_folder

#: Environment variable naming the data home.
DATA_DIR_ENV = "TZSL_DATA_DIR"


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
    return user_cache_folder() / "data"
