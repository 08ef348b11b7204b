"""Load a script of ``experiments/benchmarks/`` as a module, for the tests of its pieces."""

from __future__ import annotations

import importlib.util
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from types import ModuleType

#: The benchmark scripts' folder.
BENCHMARKS = Path(__file__).resolve().parents[1] / "experiments" / "benchmarks"


@contextmanager
def benchmark_script(file_name: str) -> Iterator[ModuleType]:
    """The script ``experiments/benchmarks/<file_name>`` loaded as module ``<stem>_probe``.

    Its folder is on ``sys.path`` while the block runs (a script may import its siblings); the module
    and the path entry are removed afterwards.
    """
    name = f"{Path(file_name).stem}_probe"
    spec = importlib.util.spec_from_file_location(name, BENCHMARKS / file_name)
    module = importlib.util.module_from_spec(spec)
    sys.path.insert(0, str(BENCHMARKS))
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
        yield module
    finally:
        sys.modules.pop(name, None)
        sys.path.remove(str(BENCHMARKS))
