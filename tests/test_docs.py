"""The documentation site builds with warnings as errors, and holds what it promises.

One full Sphinx build (``make docs`` does the same into ``docs/_build/html``): the generated API
reference, command reference and method list, every user-guide page (``docs/user_guide/*.md``,
found by a glob, so pages added later are built too) and the gallery, whose examples run.
"""

from __future__ import annotations

import fcntl
import html as html_escape
import importlib
import os
import pkgutil
import re
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.schedule_first(150)  # a Sphinx build of minutes: handed out first (conftest.py)

REPO = Path(__file__).resolve().parents[1]
DOCS = REPO / "docs"


def _text(page: Path) -> str:
    """The visible text of an HTML page (tags removed, entities decoded)."""
    return html_escape.unescape(re.sub(r"<[^>]+>", "", page.read_text(encoding="utf-8")))


#: One Sphinx build per test run: it writes the API stubs into the source tree (``docs/``), so two builds at once
#: remove each other's files, and a build costs minutes. ``make test`` keeps this file on one pytest-xdist worker
#: (``--dist loadfile``); whatever the scheduling, the build is made once under a lock shared by the workers and
#: read by every worker that needs it.


@pytest.fixture(scope="module")
def html(run_folder) -> Path:
    run = run_folder
    out = run / "docs-build"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")]),
           "MPLBACKEND": "Agg"}
    with open(run / "sphinx-build.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        outcome = out / "outcome.txt"
        if not outcome.exists():
            out.mkdir(parents=True, exist_ok=True)
            build = _sphinx(out, env)
            outcome.write_text(f"{build.returncode}\n{build.stdout[-3000:]}\n{build.stderr[-6000:]}", encoding="utf-8")
    code, _, logs = outcome.read_text(encoding="utf-8").partition("\n")
    assert code == "0", f"sphinx-build -W failed:\n{logs}"
    return out / "html"


def _sphinx(out: Path, env: dict) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "sphinx", "-b", "html", "-W", "--keep-going", "-q", "-d", str(out / "doctrees"),
         str(DOCS), str(out / "html")],
        env=env, capture_output=True, text=True, cwd=REPO,
    )


@pytest.mark.slow
def test_every_user_guide_page_is_built_and_linked(html):
    pages = sorted(p.stem for p in (DOCS / "user_guide").glob("*.md"))
    assert {"datasets", "methods", "evaluation", "model_files", "dask"} <= set(pages)
    guide = (html / "user_guide" / "index.html").read_text(encoding="utf-8")
    for page in pages:
        assert (html / "user_guide" / f"{page}.html").is_file(), page
        if page != "index":
            assert f'href="{page}.html"' in guide, f"{page} is not in the user guide's table of contents"
    start = _text(html / "getting_started.html")
    assert "make reproduce-tables" in start and "make test" in start and "tzsl validate" in start


@pytest.mark.slow
def test_api_reference_documents_every_public_name(html):
    models = importlib.import_module("tzsl.models")  # and its public submodules (tzsl.models.dap, ...)
    helpers = [m.name for m in pkgutil.iter_modules(models.__path__, "tzsl.models.") if "._" not in m.name]
    for package in ("tzsl.datasets", "tzsl.features", "tzsl.models", *helpers, "tzsl.fit_store", "tzsl.evaluation"):
        page = (html / "_generated" / "api" / f"{package}.html").read_text(encoding="utf-8")
        for name in importlib.import_module(package).__all__:
            own = html / "_generated" / "api" / "generated" / f"{package}.{name}.html"
            assert own.is_file() or f'id="{package}.{name}"' in page or f"{package}.{name}</span>" in page, \
                f"{package}.{name} is neither documented nor linked"
    bank = (html / "_generated" / "api" / "generated" / "tzsl.models.ZeroShotClassifier.html").read_text("utf-8")
    assert "class_attributes" in bank and "Parameters" in bank  # numpydoc sections rendered
    # a name's page has no section navigation (every name of every module: most of a build's time, see conf.py);
    # its module's page has it
    assert "bd-docs-nav" not in bank and "bd-breadcrumbs" in bank
    assert "bd-docs-nav" in (html / "_generated" / "api" / "tzsl.models.html").read_text(encoding="utf-8")


@pytest.mark.slow
def test_generated_pages_follow_the_code(html):
    from tzsl.models import available_methods

    methods = (html / "user_guide" / "methods.html").read_text(encoding="utf-8")
    for name in available_methods():
        assert f'<span class="pre">{name}</span>' in methods, name
    cli = _text(html / "cli.html")
    for command in ("validate", "run", "report", "predict", "train-attributes", "methods"):
        assert f"tzsl {command}" in cli, command
    assert 'study = "active-touch"' in _text(html / "user_guide" / "experiment_files.html")


@pytest.mark.slow
def test_gallery_examples_ran_on_simulated_data(html):
    examples = sorted((REPO / "examples").glob("plot_*.py"))
    assert len(examples) >= 4
    for example in examples:
        assert "simulated" in example.read_text(encoding="utf-8").lower(), example.name
        page = html / "auto_examples" / f"{example.stem}.html"
        assert page.is_file(), example.name
        assert list((html / "_images").glob(f"sphx_glr_{example.stem}_*.png")), f"{example.name} drew no figure"


def test_readme_is_short_and_points_into_the_docs():
    text = (REPO / "README.md").read_text(encoding="utf-8")
    assert "make test" in text and "make reproduce-tables" in text and "make docs" in text
    assert "tzsl validate" in text and "tzsl run" in text and "tzsl report" in text
    outside = re.sub(r"<!-- results:begin.*?<!-- results:end[^>]*-->", "", text, flags=re.S)
    assert len(outside.encode()) < 6000, "README (outside the generated Results block) grew: move it into docs/"
    for target in re.findall(r"\]\((docs/[^)#]+)", text):
        assert (REPO / target).is_file(), f"README links to a missing {target}"
