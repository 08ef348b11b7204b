"""The study cache: a finished study's outputs, kept and restored when the same study is run again unchanged.

The fit store (:mod:`tzsl.fit_store`) keeps fitted models; a run with every fit cached still
predicts, bootstraps, draws figures and writes tables. The study cache keeps what a study
*wrote*: every file it put in the results folder, the tables and manifest record it returned,
the splits and data checksums it recorded, its warnings and the lines it printed. When a study is
run again with the same key, :func:`run_cached` copies those files into the new results folder,
prints the same lines, raises the same warnings and returns the same :class:`StudyRun`, so every
CSV is byte-identical to the run that computed it and the manifest says where it came from
(``study_cache`` in the study's record).

The key is everything that decides a study's output:

* the study kind and its checked settings (:meth:`Experiment.config`), leaving out only the
  output folder and the progress bar (:data:`NEUTRAL_SETTINGS`);
* the code: a digest of every file of the installed ``tzsl`` package and the versions of the
  packages every manifest records (:data:`tzsl.studies._outputs.RECORDED_PACKAGES`) and of Python;
* the data: the path, size and modification time of every file under the dataset folders the
  settings name (for a built-in dataset: the data home), so an edited, added or removed data
  file is a new key.

It lives in ``$TZSL_CACHE_DIR/studies/<key>/`` and, like the fit store, only when
``TZSL_CACHE_DIR`` is set; ``TZSL_STUDY_CACHE=0`` turns it off while keeping the fit store, and a
study whose settings say ``compute.cache = false`` is never cached. A run that failed, or whose
tables hold failed (split, method) fits, is not stored.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import sys
import time
import warnings
from collections.abc import Callable
from datetime import datetime, timezone
from functools import cache
from pathlib import Path
from typing import Any

import joblib

from tzsl._io import ensure_folder
from tzsl._profile import stage
from tzsl._warnings import recorded_warnings
from tzsl.datasets import CACHE_DIR_ENV, get_data_home
from tzsl.studies._outputs import ResultsDir, package_versions
from tzsl.studies.config import DATASET_PATHS
from tzsl.studies.study_settings import StudyRun

__all__ = ["NEUTRAL_SETTINGS", "STUDIES_FOLDER", "STUDY_CACHE_ENV", "run_cached", "study_cache_folder",
           "study_key"]

#: Sub-folder of ``$TZSL_CACHE_DIR`` holding the study cache.
STUDIES_FOLDER = "studies"
#: Environment variable: ``0`` (or ``off``, ``false``, ``no``) turns the study cache off.
STUDY_CACHE_ENV = "TZSL_STUDY_CACHE"
#: Settings (``table.key``) that cannot change what a study writes, left out of its key.
NEUTRAL_SETTINGS = frozenset({"output.folder", "compute.progress"})
_ENTRY_FORMAT = 1
_RUN_FILE = "run.joblib"
_FILES = "files"


def study_cache_folder() -> Path | None:
    """``$TZSL_CACHE_DIR/studies``, or None when the study cache is off (see the module docstring)."""
    root = os.environ.get(CACHE_DIR_ENV) or None
    if root is None or os.environ.get(STUDY_CACHE_ENV, "1").strip().lower() in {"0", "off", "false", "no"}:
        return None
    return Path(root).expanduser() / STUDIES_FOLDER


@cache
def _code_digest() -> str:
    """Digest of every file of the installed tzsl package (caches excluded) and the recorded package versions."""
    package = Path(__file__).resolve().parents[1]
    digest = hashlib.sha256(f"{_ENTRY_FORMAT} {sys.version}".encode())
    digest.update(json.dumps(package_versions(), sort_keys=True).encode())
    for path in sorted(package.rglob("*")):
        if path.is_file() and "__pycache__" not in path.parts:
            digest.update(str(path.relative_to(package)).encode() + b"\0")
            digest.update(path.read_bytes())
    return digest.hexdigest()


def _listing(path: Path) -> list[str]:
    """``relative path, size, mtime_ns`` of every file under ``path`` (or of ``path`` itself), sorted."""
    if path.is_file():
        st = path.stat()
        return [f"{path} {st.st_size} {st.st_mtime_ns}"]
    if not path.is_dir():
        return [f"{path} missing"]
    lines = [str(path)]
    for folder, dirs, files in os.walk(path):
        dirs.sort()
        for name in sorted(files):
            full = Path(folder, name)
            st = full.stat()
            lines.append(f"{full.relative_to(path)} {st.st_size} {st.st_mtime_ns}")
    return lines


def _data_paths(exp) -> list[Path]:
    """The files and folders a study's settings point its dataset (and split file) at."""
    dataset = getattr(exp.config, "dataset", None)
    paths = [exp.resolve(value) for key in DATASET_PATHS if (value := getattr(dataset, key, None)) is not None]
    if getattr(dataset, "builtin", None) is not None and getattr(dataset, "data_dir", None) is None:
        paths.append(get_data_home())
    split_file = getattr(getattr(exp.config, "splits", None), "file", None)
    if split_file is not None:
        paths.append(exp.resolve(split_file))
    return paths


def study_key(exp) -> str:
    """The cache key of a checked experiment: hex sha256 of its settings, the code and its data files."""
    settings = exp.config.model_dump(mode="json")
    for neutral in NEUTRAL_SETTINGS:
        table, name = neutral.split(".")
        if isinstance(settings.get(table), dict):
            settings[table].pop(name, None)
    digest = hashlib.sha256(_code_digest().encode())
    digest.update(json.dumps({"study": exp.study, "settings": settings}, sort_keys=True, default=str).encode())
    for path in _data_paths(exp):
        digest.update("\n".join(_listing(path)).encode())
    return digest.hexdigest()


def _cacheable(exp) -> bool:
    return getattr(getattr(exp.config, "compute", None), "cache", True) is not False


def run_cached(exp, results: ResultsDir, runner: Callable[[Callable[[str], None]], StudyRun],
               echo: Callable[[str], None]) -> StudyRun:
    """Restore the study of ``exp`` from the cache into ``results``, or run it and store what it wrote.

    Parameters
    ----------
    exp : Experiment
        The checked experiment.
    results : ResultsDir
        Where the study writes (staged or not).
    runner : callable
        ``runner(say)`` runs the study, printing through ``say``, and returns its :class:`StudyRun`.
    echo : callable
        Where the study's lines are printed.

    Returns
    -------
    StudyRun
        The study's run; ``record["study_cache"]`` says whether it was restored, with the key.
    """
    folder = study_cache_folder()
    if folder is None or not _cacheable(exp):
        return runner(echo)
    key = study_key(exp)
    entry = folder / key
    if (entry / _RUN_FILE).is_file():
        with stage("restore"):
            payload = _load(entry)
            if payload is not None:
                return _restore(payload, entry, key, results, echo)
    n_written, splits_before, data_before = len(results.written), set(results.splits), set(results.data_files)
    lines: list[str] = []

    def say(message: str) -> None:
        lines.append(message)
        echo(message)

    start = time.perf_counter()
    with recorded_warnings() as shown:
        run = runner(say)
    if not run.failures:
        with stage("write"):
            _store(folder, key, results, results.written[n_written:], {
                "run": run, "lines": lines, "warnings": shown.lines, "seconds": time.perf_counter() - start,
                "created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
                "splits": {k: v for k, v in results.splits.items() if k not in splits_before},
                "data_files": {k: v for k, v in results.data_files.items() if k not in data_before}})
    run.record["study_cache"] = {"key": key, "restored": False}
    return run


def _store(folder: Path, key: str, results: ResultsDir, written: list[Path], payload: dict[str, Any]) -> None:
    """Write the entry into a temporary folder beside it, then move it into place in one step."""
    ensure_folder(folder, "study cache folder")
    tmp = folder / f".{key}.{os.getpid()}.tmp"
    shutil.rmtree(tmp, ignore_errors=True)
    names = []
    for path in written:
        if path.exists():
            name = str(path.relative_to(results.root))
            (tmp / _FILES / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(path, tmp / _FILES / name)
            names.append(name)
    joblib.dump({**payload, "files": names, "format": _ENTRY_FORMAT}, tmp / _RUN_FILE)
    try:
        os.replace(tmp, folder / key)
    except OSError:  # another run stored the same key meanwhile: keep theirs
        shutil.rmtree(tmp, ignore_errors=True)


def _load(entry: Path) -> dict[str, Any] | None:
    """An entry's payload; None, with one warning and the entry removed, when it is unreadable or incomplete."""
    try:
        payload = joblib.load(entry / _RUN_FILE)
        missing = [name for name in payload["files"] if not (entry / _FILES / name).is_file()]
        if payload.get("format") != _ENTRY_FORMAT or missing:
            raise ValueError(f"file {missing[0]} is missing" if missing else "another format")
    except Exception as exc:  # noqa: BLE001 - whatever broke the entry, the study is computed again
        reason = (str(exc).splitlines() or [""])[0]
        warnings.warn(f"{entry}: study cache entry unreadable ({type(exc).__name__}: {reason}); "
                      "computing the study again", UserWarning, stacklevel=3)
        shutil.rmtree(entry, ignore_errors=True)
        return None
    return payload


def _restore(payload: dict[str, Any], entry: Path, key: str, results: ResultsDir,
             echo: Callable[[str], None]) -> StudyRun:
    """Copy an entry's files into ``results`` and replay its lines and warnings."""
    for name in payload["files"]:
        results.copy_file(name, entry / _FILES / name)
    results.splits.update(payload["splits"])
    results.data_files.update(payload["data_files"])
    echo(f"(restored from the study cache: the run of {payload['created']}, {payload['seconds']:.1f} s; "
         f"unset {CACHE_DIR_ENV} or set {STUDY_CACHE_ENV}=0 to recompute)")
    for line in payload["lines"]:
        echo(line)
    for line in payload["warnings"]:
        warnings.warn(line, UserWarning, stacklevel=2)
    run: StudyRun = payload["run"]
    run.record["study_cache"] = {"key": key, "restored": True, "created": payload["created"],
                                 "seconds": round(payload["seconds"], 3)}
    return run
