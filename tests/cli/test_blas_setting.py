"""The command line sets OpenBLAS's idle-thread timeout before numpy loads it (issue 33: CPU of the posteriors)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def _child(code: str, **env: str) -> str:
    environ = {k: v for k, v in os.environ.items() if k != "OPENBLAS_THREAD_TIMEOUT"}
    environ.update(env, PYTHONPATH=str(ROOT))
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=environ, check=True)
    return done.stdout.strip()


def test_the_timeout_is_set_before_numpy_is_loaded():
    code = ("import sys, os; import tzsl.cli; "
            "print('numpy' in sys.modules, os.environ['OPENBLAS_THREAD_TIMEOUT'])")
    from tzsl.cli import OPENBLAS_THREAD_TIMEOUT

    assert _child(code) == f"False {OPENBLAS_THREAD_TIMEOUT}"


def test_a_users_own_setting_wins():
    code = "import os; import tzsl.cli; print(os.environ['OPENBLAS_THREAD_TIMEOUT'])"
    assert _child(code, OPENBLAS_THREAD_TIMEOUT="20") == "20"
