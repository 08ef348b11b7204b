"""``tzsl data fetch``: every registered file of the papers' datasets, downloaded and verified.

The registry (``registry.txt``: path, sha256, public URL) says what to get; pooch downloads
each missing file to a temporary name, checks its sha256 and only then moves it into place, so
an interrupted fetch leaves no half file and a rerun goes on where it stopped (files present and
verified are skipped). Several files download at a time (``workers``, ``$TZSL_FETCH_WORKERS``,
else :data:`~tzsl.datasets._transfer.DEFAULT_FETCH_WORKERS`; :mod:`tzsl.datasets._transfer`),
under one progress bar per dataset; the first file that fails stops the others. Every file has a
deadline (``timeout``, ``$TZSL_FETCH_TIMEOUT``, else
:data:`~tzsl.datasets._download.DEFAULT_FETCH_TIMEOUT_S`), failed attempts are retried silently
within it, pooch prints nothing, and the temporary files a killed fetch left in the dataset's
folders are removed first (:mod:`tzsl.datasets._download`). One fetch at a time writes to a data
home. ``mirror`` (or ``$TZSL_DATA_MIRROR``) is a base URL laid out like the data home
(``MIRROR/phac2/...``): every file is taken from there instead, the locally built ones too.
Files the registry lists without a URL are built from downloaded ones where tzsl can
(``phac2/derived/phac2_labels_60x24.csv`` from the Penn pickles, ``fabric/fabric_groups.csv`` from
the fabric paper's ``Data2.py``); derived reference copies that no study reads
(:data:`REFERENCE_ONLY`) are reported and left out; anything else is reported missing.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Collection, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import pooch

from tzsl._io import atomic_write_bytes
from tzsl.datasets._download import FETCH_STALL_S, fetch_lock, fetch_timeout, remove_leftovers
from tzsl.datasets._fabric import FABRIC_GROUPS_CSV, FABRIC_GROUPS_SOURCE, fabric_groups_csv_bytes
from tzsl.datasets._home import get_data_home
from tzsl.datasets._registry import download_file, registered_size, registry, source_of, verify_file
from tzsl.datasets._transfer import FetchProgress, Transfer, download_all, fetch_workers
from tzsl.exceptions import ChecksumError, ConfigError, DataFileError, DataMissingError, first_line

__all__ = ["MIRROR_ENV", "REFERENCE_ONLY", "FetchReport", "fetch_datasets", "fetch_missing", "registered_datasets"]

#: Environment variable naming a mirror (see the module docstring).
MIRROR_ENV = "TZSL_DATA_MIRROR"


@dataclass
class FetchReport:
    """What :func:`fetch_datasets` did for one dataset (lists of registered paths)."""

    name: str
    present: list[str] = field(default_factory=list)
    downloaded: list[str] = field(default_factory=list)
    built: list[str] = field(default_factory=list)
    missing: list[str] = field(default_factory=list)
    reference: list[str] = field(default_factory=list)
    #: Downloaded files that took more than one attempt.
    retried: list[str] = field(default_factory=list)
    #: Temporary files of an earlier, killed download removed before this one.
    leftovers: list[Path] = field(default_factory=list)
    #: Registered files of the dataset.
    total: int = 0

    def line(self) -> str:
        retried = f" ({len(self.retried)} after a retry)" if self.retried else ""
        parts = [f"{len(self.present)} present", f"{len(self.downloaded)} downloaded{retried}"]
        if self.built:
            parts.append(f"{len(self.built)} built from them")
        if self.missing:
            parts.append(f"{len(self.missing)} not downloadable (no public URL; {source_of(self.missing[0])})")
        if self.reference:
            parts.append(f"{len(self.reference)} reference cop{'y' if len(self.reference) == 1 else 'ies'} without "
                         "a public URL left out (no study reads them)")
        if self.leftovers:
            parts.append(f"{len(self.leftovers)} temporary file(s) of an interrupted download removed")
        return f"{self.name}: " + ", ".join(parts)

    def stopped_at(self, done: Sequence[str]) -> str:
        """Where a fetch that failed on one file of this dataset stopped (``done``: the datasets
        fetched before it), for the end of its error line."""
        finished = f"; {', '.join(done)} complete" if done else ""
        in_place = len(self.present) + len(self.downloaded) + len(self.built)
        return (f"{self.name}: {in_place} of {self.total} files in place ({len(self.present)} present, "
                f"{len(self.downloaded)} downloaded){finished}; a rerun goes on from there")


def _mirror(mirror: str | None) -> str | None:
    """The mirror a fetch uses: ``mirror``, else ``$TZSL_DATA_MIRROR``, else None (the registry's URLs)."""
    return mirror if mirror is not None else os.environ.get(MIRROR_ENV) or None


def registered_datasets(pup: pooch.Pooch | None = None) -> list[str]:
    """Names of the datasets of the registry: the first folder of every registered path."""
    return sorted({name.split("/", 1)[0] for name in (pup or registry()).registry})


def _penn_pickles(pup: pooch.Pooch) -> list[str]:
    """The registered Penn static pickles (what the PHAC-2 label table is built from)."""
    from tzsl.datasets._phac2_penn import PENN_STATIC_DIR  # noqa: PLC0415

    return [name for name in sorted(pup.registry) if name.startswith(PENN_STATIC_DIR)]


def _build_penn_labels(home: Path, pup: pooch.Pooch) -> bytes:
    """The registered object x adjective CSV, rebuilt from the downloaded Penn pickles."""
    from tzsl.datasets._phac2_penn import labels_csv_bytes, read_penn_static_pickles  # noqa: PLC0415

    return labels_csv_bytes(read_penn_static_pickles([home / name for name in _penn_pickles(pup)]).labels)


def _build_fabric_groups(home: Path, pup: pooch.Pooch) -> bytes:
    """The registered fabric x group CSV, rebuilt from the downloaded ``Data2.py`` of the paper's code."""
    source = home / FABRIC_GROUPS_SOURCE
    return fabric_groups_csv_bytes(source.read_text(encoding="utf-8"), origin=str(source))


#: The PHAC-2 label table's registered path (``LABELS_CSV`` of the HOLD reader, which imports scipy).
_PENN_LABELS = "phac2/derived/phac2_labels_60x24.csv"

#: Registered files without a public URL that tzsl builds from downloaded ones.
BUILDERS: dict[str, Callable[[Path, pooch.Pooch], bytes]] = {
    _PENN_LABELS: _build_penn_labels,
    FABRIC_GROUPS_CSV: _build_fabric_groups,
}

#: Registered files a builder reads (fetched with the file it builds): built path -> their paths.
BUILD_INPUTS: dict[str, Callable[[pooch.Pooch], list[str]]] = {
    _PENN_LABELS: _penn_pickles,
}

#: Public files a builder reads that are not data (so not in the registry): path in the data
#: home -> (sha256 of the file at that commit, URL). Downloaded (and hash-checked) only to build.
BUILD_SOURCES: dict[str, dict[str, tuple[str, str]]] = {
    FABRIC_GROUPS_CSV: {
        FABRIC_GROUPS_SOURCE: (
            "sha256:e3c5567299d0ec313047bb76802bb8967a5df2acdc0f74e76c77768c962c3501",
            "https://raw.githubusercontent.com/GitGroot/gelsight_zeroshot_category/"
            "a20cbfa4057a33888f6c1be106407e8a607a89ad/Data2.py"),
    },
}


def _fetch_build_sources(relpath: str, home: Path, mirror: str | None, progress: bool,
                         sources: dict[str, dict[str, tuple[str, str]]], timeout: float, stall: float) -> None:
    """Download (hash-checked, kept for reruns) the public files the builder of ``relpath`` reads."""
    needed = sources.get(relpath, {})
    if not needed:
        return
    pup = pooch.create(path=home, base_url="", registry={p: h for p, (h, _) in needed.items()},
                       urls={p: u for p, (_, u) in needed.items()})
    for source in needed:
        if not _present(home / source, source, pup):
            download_file(source, home, url=f"{mirror.rstrip('/')}/{source}" if mirror else None, pup=pup,
                          progress=progress, timeout=timeout, stall=stall)

#: Registered files no study reads: derived reference copies of ``../shared/data`` (no public URL)
#: that the test suite compares tzsl's own readers with. A fetch reports them, and does not fail.
REFERENCE_ONLY: frozenset[str] = frozenset({
    "phac2/derived/phac2_penn_original_adjective_splits.json",
    "phac2/derived/phac2_penn_static_features.npz",
    "phac2/derived/phac2_trials_600.csv",
})


def _present(path: Path, relpath: str, pup: pooch.Pooch) -> bool:
    """Whether ``path`` exists with the registered hash (a corrupt file is replaced)."""
    if not path.is_file():
        return False
    try:
        verify_file(path, relpath, pup.registry[relpath])
    except ChecksumError:
        path.unlink()
        return False
    return True


def fetch_datasets(
    names: Sequence[str] = (),
    data_dir: str | os.PathLike | None = None,
    *,
    mirror: str | None = None,
    progress: bool = True,
    timeout: float | None = None,
    stall: float = FETCH_STALL_S,
    pup: pooch.Pooch | None = None,
    echo: Callable[[str], None] | None = None,
    build_sources: dict[str, dict[str, tuple[str, str]]] | None = None,
    files: Collection[str] | None = None,
    workers: int | None = None,
) -> list[FetchReport]:
    """Download and verify every registered file of ``names`` (all datasets when empty).

    The temporary files a killed fetch left in a dataset's folders are removed first; one fetch
    at a time writes to a data home (another one waits); pooch prints nothing.

    Parameters
    ----------
    names : sequence of str
        Dataset names (:func:`registered_datasets`: ``phac2``, ``fabric``, ``gelsight_press``, and the
        catalog's public datasets such as ``biotac-slide``).
    data_dir : path-like, optional
        Data home (:func:`tzsl.datasets.get_data_home`).
    mirror : str, optional
        Base URL laid out like the data home; default ``$TZSL_DATA_MIRROR``, else the
        registry's public URLs.
    progress : bool
        A tqdm progress bar (on stderr, erased when done) per dataset: bytes and files downloaded.
    timeout : float, optional
        Deadline per file in seconds, every attempt included; default ``$TZSL_FETCH_TIMEOUT``,
        else :data:`~tzsl.datasets._download.DEFAULT_FETCH_TIMEOUT_S`.
    stall : float
        Seconds without a byte after which an attempt is abandoned (then retried within the deadline).
    pup : pooch.Pooch, optional
        The registry (default tzsl's own; tests pass a small one).
    echo : callable, optional
        Receives one line per dataset (and one if another fetch holds the data home).
    build_sources : dict, optional
        The public files builders read (default :data:`BUILD_SOURCES`; tests pass their own).
    files : collection of str, optional
        Only these registered paths of the datasets (default: all of them; :func:`fetch_missing`).
    workers : int, optional
        Files downloaded at a time; default ``$TZSL_FETCH_WORKERS``, else
        :data:`~tzsl.datasets._transfer.DEFAULT_FETCH_WORKERS`. The first file that fails stops
        the others (those complete are kept; the others leave nothing).

    Returns
    -------
    list of FetchReport
        One per dataset, in the order fetched.

    Raises
    ------
    ConfigError
        An unknown dataset name, a deadline that is not a number of seconds above 0, or a
        number of workers that is not a whole number from 1 to
        :data:`~tzsl.datasets._transfer.MAX_FETCH_WORKERS`.
    DataMissingError
        A file with no complete download (the deadline passed, the server refused, the
        attempts failed). One line: the dataset and file, the URL, why, then what this fetch
        did before it (the dataset's files in place of its registered ones, the datasets complete).
    ChecksumError
        A downloaded file whose sha256 differs from the registry's (it is not kept); the same
        one line.
    """
    pup = pup or registry()
    build_sources = BUILD_SOURCES if build_sources is None else build_sources
    known = registered_datasets(pup)
    unknown = [n for n in names if n not in known]
    if unknown:
        raise ConfigError(f"unknown dataset(s) {unknown}; known: {', '.join(known)}")
    mirror = _mirror(mirror)
    timeout = fetch_timeout(timeout)
    workers = fetch_workers(workers)
    home = get_data_home(data_dir)
    files = None if files is None else frozenset(files)
    reports: list[FetchReport] = []
    with fetch_lock(home, on_wait=echo):
        for name in names or known:
            report = FetchReport(name)
            try:
                _fetch_dataset(report, home, pup, mirror=mirror, progress=progress, timeout=timeout, stall=stall,
                               build_sources=build_sources, only=files, workers=workers)
            except DataFileError as exc:  # one line: the file's failure, then where this fetch stopped
                raise type(exc)(None, f"{exc}; {report.stopped_at([r.name for r in reports])}") from None
            reports.append(report)
            if echo is not None:
                echo(report.line())
    return reports


def _fetch_dataset(report: FetchReport, home: Path, pup: pooch.Pooch, *, mirror: str | None, progress: bool,
                   timeout: float, stall: float, build_sources: dict[str, dict[str, tuple[str, str]]],
                   only: Collection[str] | None = None, workers: int = 1) -> None:
    """Fill ``report`` (its dataset's files, or those of them in ``only``: present, downloaded, built,
    missing, left out), downloading on ``workers`` threads."""
    files = [f for f in sorted(pup.registry) if f.split("/", 1)[0] == report.name and (only is None or f in only)]
    report.total = len(files)
    sources = [home / source for f in files for source in build_sources.get(f, {})]
    report.leftovers = remove_leftovers([home / f for f in files] + sources)
    jobs: list[tuple[str, str]] = []  # (registered path, URL) of the files to download
    for relpath in files:
        if _present(home / relpath, relpath, pup):
            report.present.append(relpath)
            continue
        url = f"{mirror.rstrip('/')}/{relpath}" if mirror else pup.urls.get(relpath)
        if url is not None:  # else built below, or missing
            jobs.append((relpath, url))

    def get(job: tuple[str, str]) -> None:
        relpath, url = job
        try:
            attempts = download_file(relpath, home, url=url, pup=pup, timeout=timeout, stall=stall,
                                     transfer=transfer).attempts
        except DataMissingError:
            if relpath in pup.urls:
                raise
            return  # a locally built file the mirror does not hold: built below, or missing
        report.downloaded.append(relpath)  # list.append is atomic: safe from the download threads
        if attempts > 1:
            report.retried.append(relpath)

    sizes = [registered_size(relpath) for relpath, _ in jobs]
    bar = FetchProgress(len(jobs), None if None in sizes else sum(sizes), label=report.name,  # type: ignore[arg-type]
                        enabled=progress and bool(jobs))
    try:
        with Transfer(bar) as transfer:
            download_all(jobs, get, workers=workers, transfer=transfer)
    finally:  # in the registry's order, whichever thread finished first
        order = {relpath: i for i, relpath in enumerate(files)}
        report.downloaded.sort(key=order.__getitem__)
        report.retried.sort(key=order.__getitem__)
    for relpath in files:
        if relpath in report.present or relpath in report.downloaded:
            continue
        if relpath in BUILDERS:
            _fetch_build_sources(relpath, home, mirror, progress, build_sources, timeout, stall)
            path = home / relpath
            atomic_write_bytes(path, BUILDERS[relpath](home, pup))
            verify_file(path, relpath, pup.registry[relpath])
            report.built.append(relpath)
        elif relpath in REFERENCE_ONLY:
            report.reference.append(relpath)
        else:
            report.missing.append(relpath)


def _size_text(relpaths: Sequence[str]) -> str:
    """The download size of ``relpaths`` from ``registry_sizes.txt`` ("24.9 MB"; "" when it lists none)."""
    sizes = [registered_size(r) for r in relpaths]
    known = sum(size for size in sizes if size is not None)
    if known == 0:
        return ""
    return f"{'at least ' if None in sizes else ''}{known / 1e6:.1f} MB"


def fetch_missing(
    relpaths: Iterable[str],
    data_dir: str | os.PathLike | None = None,
    *,
    needed_by: str = "the study",
    progress: bool = True,
    echo: Callable[[str], None] | None = None,
    mirror: str | None = None,
    timeout: float | None = None,
    pup: pooch.Pooch | None = None,
    build_sources: dict[str, dict[str, tuple[str, str]]] | None = None,
    workers: int | None = None,
) -> list[FetchReport]:
    """Fetch the registered files among ``relpaths`` that are not in the data home (a study's first use).

    Nothing happens when every file is there: no network, no lock, no hashing (the study's
    readers verify the hashes, as always). Otherwise ``echo`` gets one line (how many files of
    which datasets, their size from ``registry_sizes.txt``, the data home, the source), then
    :func:`fetch_datasets` gets just the missing files (and the registered files a missing
    built file is built from): the same downloads (several at a time), deadline, retries, hash
    checks, progress bar, lock and cleanup as ``tzsl data fetch``.

    Parameters
    ----------
    relpaths : iterable of str
        Registered paths (:func:`tzsl.datasets.builtin_data_files`).
    data_dir : path-like, optional
        Data home (:func:`tzsl.datasets.get_data_home`).
    needed_by : str
        Who reads the files (``"phac2-dap, fabric"``), for the line printed and the error.
    progress, echo, mirror, timeout, pup, build_sources, workers
        As for :func:`fetch_datasets`.

    Returns
    -------
    list of FetchReport
        One per dataset fetched (empty when nothing was missing).

    Raises
    ------
    DataMissingError, ChecksumError
        One line: what was being fetched for ``needed_by``, the file, the URL and why (no network,
        a hash mismatch, the deadline, a full disk), where the fetch stopped, and what to do.
        Nothing is left half-written (downloads and builds go to temporary files first).
    """
    pup = pup or registry()
    home = get_data_home(data_dir)
    missing = {r for r in relpaths if not (home / r).is_file()}
    for relpath in sorted(missing):
        inputs = BUILD_INPUTS.get(relpath)
        missing |= {r for r in (inputs(pup) if inputs is not None else []) if not (home / r).is_file()}
    if not missing:
        return []
    mirror = _mirror(mirror)
    names = sorted({r.split("/", 1)[0] for r in missing})
    size = _size_text(sorted(missing))
    say = echo or (lambda _line: None)
    files = f"{len(missing)} data file{'s' if len(missing) > 1 else ''} of {', '.join(names)}"
    say(f"first use: fetching {files}{f' ({size})' if size else ''} for {needed_by} into {home}, from "
        f"{mirror or 'their public URLs'} (--no-fetch: stop instead)")
    todo = "; see `tzsl data fetch --help` for a mirror or a longer deadline"
    try:
        reports = fetch_datasets(names, home, mirror=mirror, progress=progress, timeout=timeout, pup=pup, echo=echo,
                                 build_sources=build_sources, files=missing, workers=workers)
    except DataFileError as exc:
        raise type(exc)(None, f"fetching the data of {needed_by}: {exc}{todo}") from None
    except OSError as exc:  # a build or the data home itself: full disk, no permission
        raise DataMissingError(None, f"fetching the data of {needed_by}: cannot write into {home}: "
                                     f"{type(exc).__name__}: {first_line(exc)}{todo}") from None
    absent = [r for report in reports for r in report.missing]
    if absent:
        raise DataMissingError(home / absent[0], f"{len(absent)} file(s) of {needed_by} have no public URL "
                                                 f"(source: {source_of(absent[0])}); give a mirror "
                                                 f"(${MIRROR_ENV}) or put them in {home}")
    return reports
