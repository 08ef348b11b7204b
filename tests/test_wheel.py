"""A plain (non-editable) wheel install runs built-in studies from outside the repository."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests" / "studies"))
from test_reproduce import TINY_HAND  # noqa: E402

pytestmark = pytest.mark.schedule_first(35)  # a wheel built and installed: handed out first (conftest.py)


@pytest.mark.slow
def test_wheel_install_runs_builtin_studies(tmp_path):
    source = tmp_path / "src"
    source.mkdir()
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(REPO / name, source / name)
    shutil.copytree(REPO / "tzsl", source / "tzsl", ignore=shutil.ignore_patterns("__pycache__"))
    wheels = tmp_path / "wheels"
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q", "-w",
                    str(wheels), str(source)], check=True, capture_output=True)
    (wheel,) = wheels.glob("tzsl-*.whl")
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True)
    # install the wheel with this interpreter's pip into the fresh environment, no dependencies
    target = subprocess.run([str(venv / "bin" / "python"), "-c", "import sysconfig; print(sysconfig.get_paths()"
                             "['purelib'])"], check=True, capture_output=True, text=True).stdout.strip()
    subprocess.run([sys.executable, "-m", "pip", "install", "--no-deps", "--no-index", "-q", "--target", target,
                    str(wheel)], check=True, capture_output=True)
    # dependencies from this environment's site-packages (PYTHONPATH does not run its .pth files, so an
    # editable tzsl there stays invisible)
    env = {"PATH": f"{venv / 'bin'}:/usr/bin:/bin", "PYTHONPATH": sysconfig.get_paths()["purelib"],
           "HOME": str(tmp_path), "TZSL_CACHE_DIR": str(tmp_path / "cache"), "MPLBACKEND": "Agg"}
    work = tmp_path / "elsewhere"
    work.mkdir()
    python = str(venv / "bin" / "python")

    def tzsl(*args):
        return subprocess.run([python, "-c", "from tzsl.cli import main; main()", *args], cwd=work, env=env,
                              capture_output=True, text=True)

    where = subprocess.run([python, "-c", "import tzsl; print(tzsl.__file__)"], cwd=work, env=env,
                           capture_output=True, text=True, check=True).stdout.strip()
    assert where.startswith(target) and not where.startswith(str(REPO)), where
    printed = tzsl("run", "phac2-dap", "--print-config")
    assert printed.returncode == 0, printed.stderr
    assert 'kinds = ["random", "challenging"]' in printed.stdout
    (work / "hand.toml").write_text(TINY_HAND)
    ran = tzsl("run", "hand.toml", "--out", "res")
    assert ran.returncode == 0, ran.stdout + ran.stderr
    assert (work / "res" / "hand_table5.csv").is_file() and (work / "res" / "manifest.json").is_file()
    assert not any(p.name == "tzsl" for p in work.iterdir())
    assert os.path.isdir(os.path.join(target, "tzsl", "studies", "builtin"))
