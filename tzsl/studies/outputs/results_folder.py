"""Writing results: atomic files, no silent overwrite, a manifest beside every study.

Every file a study writes goes through :class:`ResultsDir`: it is written to a temporary
file in the same folder and moved into place with :func:`os.replace`, so a crash or Ctrl-C
never leaves a half-written table. Existing results are only replaced when ``force=True``.
A run of the engine stages its files in :data:`STAGING_FOLDER` inside the output folder and
moves them into place when it completes (:meth:`ResultsDir.commit`): a crashed run leaves only
that hidden folder, which the rerun reuses, so it never blocks the rerun with "already exists".

Numbers in CSV tables are written in one format (:func:`csv_ready`): floats with
:data:`CSV_FLOAT_FORMAT` (6 significant digits: ``0.42`` rather than
``0.42000000000000004``, and a gamma of ``1e-05`` survives, which a fixed ``%.4f`` would
print as ``0.0000``), and float columns holding only whole numbers (object counts read
back or averaged as floats) as integers (``10``, not ``10.0``; missing values stay empty).
"""

from __future__ import annotations

import functools
import json
import os
import platform
import shutil
import subprocess
import sys
from collections.abc import Callable, Iterable
from datetime import datetime, timezone
from importlib import metadata
from pathlib import Path
from typing import Any

import pandas as pd

from tzsl._io import atomic_write, ensure_folder, file_sha256
from tzsl._profile import timed
from tzsl.exceptions import ConfigError
from tzsl.studies.outputs.environment import environment_record

__all__ = [
    "CSV_FLOAT_FORMAT", "RECORDED_PACKAGES", "STAGING_FOLDER", "STAGING_LOCK", "PrefixedResults", "ResultsDir",
    "csv_ready", "package_versions", "prefixed", "source_commit",
]

#: Hidden folder inside the output folder where a staged run writes until it completes.
STAGING_FOLDER = ".tzsl-partial"

#: Lock file inside the staging folder: the process id of the run writing there.
STAGING_LOCK = ".lock"

#: printf-style format of every float written to a CSV table (6 significant digits).
CSV_FLOAT_FORMAT = "%.6g"

#: Packages whose versions every manifest records.
RECORDED_PACKAGES: tuple[str, ...] = (
    "tzsl", "numpy", "scipy", "scikit-learn", "pandas", "joblib", "pydantic", "skops",
    "h5py", "matplotlib", "scikit-image", "imageio", "jinja2", "dask", "distributed", "torch",
)


@functools.lru_cache(maxsize=1)
def source_commit() -> str | None:
    """The git commit of the tzsl source that runs (``<sha>-dirty`` when tracked files differ from it).

    Read once per process, when the first results folder is opened (:class:`ResultsDir`): the code a
    run imported, even if the checkout moves on while it runs. None when tzsl does not run from a
    git checkout (an installed wheel) or git is missing: the manifest then says so instead of
    naming a commit.
    """
    source = Path(__file__).resolve().parents[3]

    def git(*args: str) -> str | None:
        try:
            done = subprocess.run(["git", "-C", str(source), *args], capture_output=True, text=True, check=False,
                                  timeout=30)
        except (OSError, subprocess.SubprocessError):
            return None
        return done.stdout.strip() if done.returncode == 0 else None

    if not (source / ".git").exists() or (sha := git("rev-parse", "--short=12", "HEAD")) is None:
        return None
    changed = git("status", "--porcelain", "--untracked-files=no")
    return f"{sha}-dirty" if changed else sha


def package_versions(names: Iterable[str] = RECORDED_PACKAGES) -> dict[str, str | None]:
    """Installed version of each package, ``None`` when it is not installed."""
    versions: dict[str, str | None] = {}
    for name in names:
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = None
    return versions


def csv_ready(table: pd.DataFrame) -> pd.DataFrame:
    """A copy of ``table`` whose float columns of whole numbers are integers (nullable ``Int64``).

    A float column counts as whole when every non-missing value is an integer below 2**53
    in magnitude and at least one value is present (counts such as ``n_objects`` that
    became floats through a NaN or a mean row). Other columns are unchanged; floats are
    formatted at write time with :data:`CSV_FLOAT_FORMAT`.
    """
    out = table.copy()
    for column in out.columns:
        values = out[column]
        if not pd.api.types.is_float_dtype(values):
            continue
        present = values.dropna()
        if len(present) and (present == present.round()).all() and (present.abs() < 2.0**53).all():
            out[column] = values.astype("Int64")
    return out


def _alive(pid: int) -> bool:
    """Whether process ``pid`` exists (on this machine)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # e.g. another user's process
        return True
    return True


class ResultsDir:
    """A results folder that refuses to overwrite earlier results unless forced.

    Parameters
    ----------
    root : Path
        Output folder (created when missing).
    force : bool
        Replace files that already exist. Without it, writing an existing file raises
        :class:`~tzsl.exceptions.ConfigError` naming the file and the ``--force`` option.
    staging : bool
        Write into ``root / STAGING_FOLDER`` (reused, overwritten freely: it is this run's own
        partial folder) and move the files into ``root`` on :meth:`commit`. The overwrite check
        is against ``root``, again at the commit. ``self.root`` is where files are being written
        (the staging folder until the commit); ``self.final_root`` is ``root``. The first write
        takes the staging folder's lock file (the process id): a second run into the same folder
        while this one is alive is refused; the lock of a crashed run is taken over.
    """

    def __init__(self, root: str | Path, force: bool = False, staging: bool = False) -> None:
        self.final_root = Path(root)
        self.staging = staging
        self.root = self.final_root / STAGING_FOLDER if staging else self.final_root
        self.force = force
        self.written: list[Path] = []
        self.splits: dict[str, dict[str, Any]] = {}  # every split written, for the manifest
        self.data_files: dict[str, str] = {}  # every data file a manifest recorded: path -> sha256
        self._locked = False
        self.code_commit = source_commit()  # the git commit of the code that runs, read before it runs

    def path(self, name: str) -> Path:
        """Where to write ``name`` (in the staging folder when staging), checked against overwriting."""
        final, target = self.final_root / name, self.root / name
        if final.exists() and not self.force and final not in self.written and target not in self.written:
            raise ConfigError(
                f"{final} already exists; use --force to overwrite existing results "
                "or choose another --out folder"
            )
        return target

    def _target(self, name: str) -> Path:
        """:meth:`path` for a write: takes the staging lock first (see ``staging``)."""
        if self.staging and not self._locked:
            self._lock()
        return self.path(name)

    def _lock(self) -> None:
        lock = self.root / STAGING_LOCK
        ensure_folder(self.root)
        for _ in range(2):
            try:
                fd = os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
            except FileExistsError:
                try:
                    pid = int(lock.read_text().strip() or 0)
                except (OSError, ValueError):
                    pid = 0
                if pid and pid != os.getpid() and _alive(pid):
                    raise ConfigError(f"{self.final_root}: another tzsl run (process {pid}) is writing into this "
                                      "folder; wait for it or choose another --out folder") from None
                lock.unlink(missing_ok=True)  # a crashed run's lock: take its partial folder over
                continue
            with os.fdopen(fd, "w") as fh:
                fh.write(str(os.getpid()))
            self._locked = True
            return
        raise ConfigError(f"{lock}: cannot take the staging lock")

    def commit(self) -> None:
        """Move the staged files into the output folder, then remove the staging folder (no-op unstaged).

        Raises
        ------
        ConfigError
            A file appeared in the output folder meanwhile (another run) and ``force`` is off;
            nothing is moved and this run's files stay in the staging folder.
        """
        if not self.staging:
            return
        pairs = [(p, self.final_root / p.relative_to(self.root)) for p in self.written if p.exists()]
        clash = [dest for _, dest in pairs if dest.exists()] if not self.force else []
        if clash:
            raise ConfigError(f"{clash[0]} appeared while this run was writing (another run into the same folder?); "
                              f"this run's results stay in {self.root}; use --force or another --out folder")
        for path, dest in pairs:
            dest.parent.mkdir(parents=True, exist_ok=True)
            os.replace(path, dest)
        shutil.rmtree(self.root, ignore_errors=True)
        self.root, self.staging, self.written = self.final_root, False, [dest for _, dest in pairs]

    def check_free(self, names: Iterable[str]) -> None:
        """Fail early, before any computation, if one of ``names`` would be overwritten."""
        for name in names:
            self.path(name)

    def _record(self, path: Path) -> Path:
        self.written.append(path)
        return path

    @timed("write")
    def write_csv(self, name: str, table: pd.DataFrame, index: bool = False) -> Path:
        """Write ``table`` as CSV, numbers formatted by :func:`csv_ready` and :data:`CSV_FLOAT_FORMAT`."""
        target = self._target(name)
        ready = csv_ready(table)
        return self._record(
            atomic_write(target, lambda p: ready.to_csv(p, index=index, float_format=CSV_FLOAT_FORMAT))
        )

    def write_json(self, name: str, payload: Any) -> Path:
        """Write ``payload`` as indented JSON."""
        target = self._target(name)
        text = json.dumps(payload, indent=2, sort_keys=True, default=str)

        def write(p: Path) -> None:
            p.write_text(text + "\n")

        return self._record(atomic_write(target, write))

    def write_splits(self, name: str, splits: Iterable[Any]) -> Path:
        """Write object splits in the format ``--splits`` reads back (:func:`tzsl.evaluation.write_splits_csv`).

        Each split's train/test (and dropped) objects are also recorded for the manifest.
        """
        from tzsl.evaluation import write_splits_csv  # noqa: PLC0415

        splits = list(splits)
        target = self._target(name)
        write_splits_csv(splits, target)
        for s in splits:
            self.splits[s.name] = {"kind": s.kind, "seed": s.seed, "train": list(s.train_objects),
                                   "test": list(s.test_objects), "dropped": [o for o, _ in s.dropped_objects],
                                   "attributes": list(s.kept_attributes), "file": name}
        return self._record(target)

    def copy_file(self, name: str, source: str | Path) -> Path:
        """Write a copy of the file ``source`` as ``name`` (a study restored from the study cache)."""
        target = self._target(name)

        def write(p: Path) -> None:
            shutil.copyfile(source, p)

        return self._record(atomic_write(target, write))

    def write_file(self, name: str, write: Callable[[Path], object]) -> Path:
        """Write ``name`` with ``write(path)`` (a model bundle's writer), atomically and checked like the others."""
        return self._record(atomic_write(self._target(name), write))

    @timed("figures")
    def write_figure(self, name: str, figure: Any, dpi: int = 120) -> Path:
        """Save a matplotlib figure as PNG and close it."""
        import matplotlib.pyplot as plt  # noqa: PLC0415  # matplotlib is heavy, imported only to save a figure

        target = self._target(name)
        try:
            return self._record(
                atomic_write(target, lambda p: figure.savefig(p, format="png", dpi=dpi, bbox_inches="tight"))
            )
        finally:
            plt.close(figure)

    def write_manifest(
        self,
        config: dict[str, Any],
        data_files: Iterable[Path] = (),
        name: str = "manifest.json",
        extra: dict[str, Any] | None = None,
    ) -> Path:
        """Record configuration, seeds, data checksums, splits and package versions.

        The manifest lists every file written so far by this object with its sha256, every
        data file read (``data_files``, and those of earlier manifests of this folder object)
        with its sha256, and every split written by :meth:`write_splits` with its train and
        test classes (``splits``).
        """
        self.data_files.update({str(p): file_sha256(Path(p)) for p in data_files if str(p) not in self.data_files})
        manifest = {
            "created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
            "command": " ".join(sys.argv),
            "commit": self.code_commit,
            "python": sys.version.split()[0],
            "platform": platform.platform(),
            "packages": package_versions(),
            "environment": environment_record(),
            "config": config,
            "data_files": dict(sorted(self.data_files.items())),
            "splits": self.splits,
            "outputs": {
                str(p.relative_to(self.root)): file_sha256(p) for p in self.written if p.exists()
            },
        }
        if extra:
            manifest.update(extra)
        return self.write_json(name, manifest)


def prefixed(prefix: str, name: str) -> str:
    """File ``name`` of a run with ``[output] prefix``: ``<prefix>_<name>`` (unchanged without one)."""
    return f"{prefix}_{name}" if prefix else name


class PrefixedResults:
    """A view of a :class:`ResultsDir` that writes every file as ``<prefix>_<name>`` (``[output] prefix``).

    Two runs of one study kind share a results folder this way (``evidence``: the PHAC-2
    method comparison and its many-split headlines). Every other attribute is the folder's.
    """

    def __init__(self, results: ResultsDir, prefix: str) -> None:
        self.results, self.prefix = results, prefix

    def name(self, name: str) -> str:
        """``name`` as written (:func:`prefixed`)."""
        return prefixed(self.prefix, name)

    def __getattr__(self, attribute: str) -> Any:
        return getattr(self.results, attribute)

    def check_free(self, names: Iterable[str]) -> None:
        self.results.check_free(self.name(n) for n in names)

    def write_csv(self, name: str, table: pd.DataFrame, index: bool = False) -> Path:
        return self.results.write_csv(self.name(name), table, index)

    def write_splits(self, name: str, splits: Iterable[Any]) -> Path:
        return self.results.write_splits(self.name(name), splits)

    def write_figure(self, name: str, figure: Any, dpi: int = 120) -> Path:
        return self.results.write_figure(self.name(name), figure, dpi)

