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
  packages every manifest records (:data:`tzsl.studies.outputs.results_folder.RECORDED_PACKAGES`) and of Python;
  and the source files of plug-ins outside the package that a study may run: its study kind's
  hooks and the classes of every registered method. A study whose plug-in source cannot be read
  (code defined in a notebook) is not cached;
* the data: the path, size and modification time of every file under the dataset folders the
  settings name (for a built-in dataset: the data home), so an edited, added or removed data
  file is a new key.

It lives in ``<cache folder>/studies/<key>/``, the cache folder of :func:`tzsl.cache.get_cache_dir`
(``$TZSL_CACHE_DIR``, else the user cache folder), and is on by default: ``TZSL_STUDY_CACHE=0``
turns it off while keeping the fit store, and a study whose settings say ``compute.cache =
false`` is never cached. A run that failed, or whose tables hold a failed (split, method) fit other
than a refusal (:func:`tzsl.studies.outputs.failures.only_refusals`: the method declined that split's
input, as it will on every run with this key), is not stored, so the next run tries it again. After
an entry is stored, the study cache and the fit store are pruned to the size cap, least recently
used first (:func:`tzsl.cache.enforce_size_cap`); a restored entry is marked used before it is
read, so a concurrent prune keeps it (see :mod:`tzsl.cache`).
"""

from __future__ import annotations

import hashlib
import importlib.util
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
from tzsl._warnings import recorded_warnings, warn_again
from tzsl.cache import (
    STUDIES_FOLDER,
    STUDY_CACHE_ENV,
    enforce_size_cap,
    format_size,
    get_cache_dir,
    mark_used,
    size_cap_gb,
    study_cache_on,
)
from tzsl.datasets import get_data_home
from tzsl.studies.config import DATASET_PATHS, get_study
from tzsl.studies.outputs.failures import only_refusals
from tzsl.studies.outputs.results_folder import ResultsDir, package_versions
from tzsl.studies.outputs.study_run import StudyRun

__all__ = ["NEUTRAL_SETTINGS", "run_cached", "study_cache_folder", "study_key"]

#: Settings (``table.key``) that cannot change what a study writes, left out of its key.
NEUTRAL_SETTINGS = frozenset({"output.folder", "compute.progress"})
_ENTRY_FORMAT = 2  # 2: warnings kept with their category and count
_RUN_FILE = "run.joblib"
_FILES = "files"


def study_cache_folder() -> Path | None:
    """``<cache folder>/studies`` (:func:`tzsl.cache.get_cache_dir`), or None when ``TZSL_STUDY_CACHE`` turns it off."""
    return get_cache_dir() / STUDIES_FOLDER if study_cache_on() else None


@cache
def _code_digest() -> str:
    """Digest of every file of the installed tzsl package (caches excluded) and the recorded package versions."""
    package = Path(__file__).resolve().parents[2]
    digest = hashlib.sha256(f"{_ENTRY_FORMAT} {sys.version}".encode())
    digest.update(json.dumps(package_versions(), sort_keys=True).encode())
    for path in sorted(package.rglob("*")):
        if path.is_file() and "__pycache__" not in path.parts:
            digest.update(str(path.relative_to(package)).encode() + b"\0")
            digest.update(path.read_bytes())
    return digest.hexdigest()


def _plugin_digest(exp) -> tuple[str | None, str]:
    """Digest of the source files outside tzsl that ``exp`` may run (its study kind's hooks, every registered
    method's classes), and ``""``; or None and the name of a module without a readable source file."""
    from tzsl.models import available_methods, get_method  # noqa: PLC0415 (the registry, read when a study runs)

    kind = get_study(exp.study)
    modules = {hook.partition(":")[0] for hook in (kind.runner, kind.results, kind.outputs, kind.notes) if hook}
    for name in available_methods():
        method = get_method(name)
        modules.update(cls.__module__ for cls in (method.attribute_model, method.decision_rule, method.estimator)
                       if cls is not None)
    digest = hashlib.sha256()
    for module in sorted(m for m in modules if m != "tzsl" and not m.startswith("tzsl.")):
        try:
            loaded = sys.modules.get(module)
            if loaded is not None:
                source = loaded.__file__
            else:
                spec = importlib.util.find_spec(module)
                source = None if spec is None else spec.origin
            if source is None:  # no source file
                return None, module
            digest.update(f"{module}\0".encode() + Path(source).read_bytes())
        except (AttributeError, ImportError, OSError, TypeError, ValueError):  # no source file (a notebook)
            return None, module
    return digest.hexdigest(), ""


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


def study_key(exp) -> str | None:
    """The cache key of a checked experiment: hex sha256 of its settings, the code and its data files.

    None when the study cannot be keyed (a plug-in without a source file): it is then not cached.
    """
    plugins, _ = _plugin_digest(exp)
    if plugins is None:
        return None
    settings = exp.config.model_dump(mode="json")
    for neutral in NEUTRAL_SETTINGS:
        table, name = neutral.split(".")
        if isinstance(settings.get(table), dict):
            settings[table].pop(name, None)
    digest = hashlib.sha256(f"{_code_digest()} {plugins}".encode())
    digest.update(json.dumps({"study": exp.study, "settings": settings}, sort_keys=True, default=str).encode())
    for path in _data_paths(exp):
        digest.update("\n".join(_listing(path)).encode())
    return digest.hexdigest()


def _cacheable(exp) -> bool:
    return getattr(getattr(exp.config, "compute", None), "cache", True) is not False


def run_cached(exp, results: ResultsDir, runner: Callable[[Callable[[str], None]], StudyRun],
               echo: Callable[[str], None], study_echo: Callable[[str], None] | None = None) -> StudyRun:
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
        Where the cache's own notes are printed (restored, not kept, size cap).
    study_echo : callable or None
        Where the study's lines (its tables; replayed when restored) are printed; default ``echo``.
        They are stored in the cache entry whatever is printed.

    Returns
    -------
    StudyRun
        The study's run; ``record["study_cache"]`` says whether it was restored, with the key.
    """
    study_say = echo if study_echo is None else study_echo
    folder = study_cache_folder()
    if folder is None or not _cacheable(exp):
        return runner(study_say)
    size_cap_gb()  # a bad $TZSL_CACHE_MAX_GB fails now, not after the study has run
    key = study_key(exp)
    if key is None:
        echo(f"note: not kept in the study cache: the plug-in module {_plugin_digest(exp)[1]} has no source file, "
             "so a change to it could not be seen")
        return runner(study_say)
    entry = folder / key
    if (entry / _RUN_FILE).is_file():
        mark_used(entry)  # before reading it: a prune running now keeps the entry (tzsl.cache)
        with stage("restore"):
            payload = _load(entry)
            if payload is not None:
                return _restore(payload, entry, key, results, echo, study_say)
    n_written, splits_before, data_before = len(results.written), set(results.splits), set(results.data_files)
    lines: list[str] = []

    def say(message: str) -> None:
        lines.append(message)
        study_say(message)

    start = time.perf_counter()
    with recorded_warnings() as shown:
        run = runner(say)
    if only_refusals(run.failures):
        with stage("write"):
            _store(folder, key, results, results.written[n_written:], {
                "run": run, "lines": lines, "warnings": shown.shown, "seconds": time.perf_counter() - start,
                "created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
                "splits": {k: v for k, v in results.splits.items() if k not in splits_before},
                "data_files": {k: v for k, v in results.data_files.items() if k not in data_before}})
            pruned = [e for e in enforce_size_cap(folder.parent).removed if not e.temporary]
        if pruned:
            echo(f"note: the study cache and fit store were over their size cap ({size_cap_gb():g} GB): "
                 f"removed the {len(pruned)} least recently used entries ({format_size(sum(e.size for e in pruned))}); "
                 "'tzsl cache info' shows what is left")
    run.record["study_cache"] = {"key": key, "restored": False}
    return run


def _store(folder: Path, key: str, results: ResultsDir, written: list[Path], payload: dict[str, Any]) -> None:
    """Write the entry into a temporary folder beside it (a name starting with ``.``, which pruning leaves
    alone while it is new), then move it into place in one step. A failed write leaves the results as they
    are, with one warning."""
    ensure_folder(folder, "study cache folder")
    tmp = folder / f".{key}.{os.getpid()}.tmp"
    shutil.rmtree(tmp, ignore_errors=True)
    try:
        names = []
        for path in written:
            if path.exists():
                name = str(path.relative_to(results.root))
                (tmp / _FILES / name).parent.mkdir(parents=True, exist_ok=True)
                shutil.copyfile(path, tmp / _FILES / name)
                names.append(name)
        joblib.dump({**payload, "files": names, "format": _ENTRY_FORMAT}, tmp / _RUN_FILE)
    except OSError as exc:  # a full disk, a removed folder: the study's results stand, only the entry is lost
        shutil.rmtree(tmp, ignore_errors=True)
        warnings.warn(f"{folder / key}: study not stored in the study cache ({type(exc).__name__}: {exc})",
                      UserWarning, stacklevel=3)
        return
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
             echo: Callable[[str], None], study_echo: Callable[[str], None]) -> StudyRun:
    """Copy an entry's files into ``results`` and replay its lines (through ``study_echo``) and warnings."""
    for name in payload["files"]:
        results.copy_file(name, entry / _FILES / name)
    results.splits.update(payload["splits"])
    results.data_files.update(payload["data_files"])
    echo(f"note: restored from the study cache (the run of {payload['created']}, computed in "
         f"{payload['seconds']:.1f} s); {STUDY_CACHE_ENV}=0 computes it again")
    for line in payload["lines"]:
        study_echo(line)
    warn_again(payload["warnings"])  # each with its category and count: the terminal groups them as it did
    run: StudyRun = payload["run"]
    run.record["study_cache"] = {"key": key, "restored": True, "created": payload["created"],
                                 "seconds": round(payload["seconds"], 3)}
    return run
