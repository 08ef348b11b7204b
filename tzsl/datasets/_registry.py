"""The dataset registry: every known data file with its sha256, verified on first use.

The registry lives in ``registry.txt`` beside this module (pooch's registry-file format,
generated once from the sha256 tables of the shared data's PROVENANCE.md files; the
file header names the source of every hash). :func:`fetch` resolves a registered path
under the data home, checks that it exists and that its sha256 matches (once per
process and file state), and returns its absolute path.

Nothing here touches the network unless :func:`fetch` is called with
``download=True`` (then :func:`download_file` gets the file from its public URL, when the
registry has one, within a deadline, and pooch checks its hash).
"""

from __future__ import annotations

import os
import threading
from functools import lru_cache
from importlib import resources
from pathlib import Path
from typing import NamedTuple

import pooch

from tzsl.datasets._download import FETCH_STALL_S, DownloadFailed, download, fetch_timeout
from tzsl.datasets._home import DATA_DIR_ENV, get_data_home
from tzsl.datasets._transfer import DownloadCancelled, FetchProgress, Transfer
from tzsl.exceptions import ChecksumError, DataMissingError, first_line

#: Registry value meaning "listed, but no hash known" (the fabric depth PNGs).
NO_HASH = "none"

# Where each group of files comes from (prefix -> human-readable public source).
_SOURCES: tuple[tuple[str, str], ...] = (
    (
        "phac2/penn_bolt_ml_data/static_adjective_phase_set/",
        "the Penn static feature pickles from https://github.com/IanTheEngineer/Penn-haptics-bolt "
        "at commit a89498a58d82ba0d4fac22e85cc2e755eeb67aaf, folder "
        "ml_data/mkl_unstandard_1_28/static/adjective_phase_set/",
    ),
    (
        "phac2/imperial_cvpr2021_hold/",
        "the HOLD-phase MATLAB files from https://github.com/arahosu/cvpr_imperial2 at commit "
        "04932b5235f0b8026bed13547941a61cb7adcf60, folder data/ (Imperial College CVPR "
        "coursework 2021 copy of PHAC-2)",
    ),
    (
        "phac2/penn_bolt_pilot_2012_training_tests/",
        "the Penn 2012 pilot recordings from https://github.com/IanTheEngineer/Penn-haptics-bolt "
        "at commit 441c64d94cbc898c65ee7e3d684857fab96f6782, folder training_tests/",
    ),
    (
        "phac2/derived/",
        "the derived PHAC-2 files (built from the Penn static pickles; see data/README.md and "
        "phac2/PROVENANCE.md section 7)",
    ),
    (
        "fabric/fabric_properties_100x4.npy",
        "https://github.com/GitGroot/gelsight_zeroshot_for_instance at commit "
        "87991b140864d225790bfd7966b773051c9c5d0c, file data/class_attribute_matrix.npy "
        "(save it under the registered name)",
    ),
    (
        "fabric/fabric_groups.csv",
        "the fabric group list (re-typed from Data2.py of "
        "https://github.com/GitGroot/gelsight_zeroshot_category; see data/README.md)",
    ),
    (
        "fabric/",
        "https://github.com/GitGroot/gelsight_zeroshot_category at commit "
        "a20cbfa4057a33888f6c1be106407e8a607a89ad, folder data/",
    ),
    (
        "biotac-slide/",
        "https://github.com/dexrob/BioTac_slide_20_50 at commit c19638b040791b7b32f2fcf12eee315ca901f80a, "
        "folder raw_data/ (the catalog's biotac-slide; docs/user_guide/dataset_catalog.md)",
    ),
    (
        "bts3/",
        "https://github.com/yayaneath/biotac-sp-images at commit bdd90cc376e673d8ac2f7c879af47c99ecc56783 "
        "(the BioTacSP Stability Set; docs/user_guide/dataset_catalog.md)",
    ),
    (
        "icub-grasp/",
        "https://github.com/clear-nus/icub_grasp_dataset at commit 87dceecaa2f8056025f2ad42b55cb5f46fb77229, "
        "folder iCubGraspDataset/ (the iCub Grasp Dataset; docs/user_guide/dataset_catalog.md)",
    ),
    (
        "physiclear/",
        "https://github.com/clear-nus/octopi at commit b7f0b0b56a5be950a10c46aa40277dfd51050eab, folder dataset/ "
        "and utils/constants.py (PhysiCLeAR; docs/user_guide/dataset_catalog.md)",
    ),
    (
        "gelsight_press/",
        "https://github.com/GelSight-lab/EstimateModulus at commit "
        "12cb13717ac71c09aae428b1efd0fe0190599372, folder example_data/2023-12-06/",
    ),
)

# (resolved path, size, mtime_ns) -> None once the file was verified in this process.
_VERIFIED: set[tuple[str, int, int]] = set()
_LOCK = threading.Lock()


@lru_cache(maxsize=1)
def registry() -> pooch.Pooch:
    """The pooch registry (data home is substituted per call in :func:`fetch`)."""
    pup = pooch.create(path=".", base_url="", registry=None, retry_if_failed=0)
    with resources.files("tzsl.datasets").joinpath("registry.txt").open("r", encoding="utf-8") as fh:
        pup.load_registry(fh)
    return pup


def registered_files(prefix: str = "") -> list[str]:
    """All registered relative paths starting with ``prefix``, sorted.

    Parameters
    ----------
    prefix : str
        E.g. ``"phac2/imperial_cvpr2021_hold/"``.

    Returns
    -------
    list of str
        Paths relative to the data home, with ``/`` separators.
    """
    return sorted(name for name in registry().registry if name.startswith(prefix))


@lru_cache(maxsize=1)
def _registered_sizes() -> dict[str, int]:
    """Registered path -> its size in bytes (``registry_sizes.txt`` beside this module)."""
    sizes: dict[str, int] = {}
    with resources.files("tzsl.datasets").joinpath("registry_sizes.txt").open("r", encoding="utf-8") as fh:
        for line in fh:
            if line.strip() and not line.startswith("#"):
                relpath, size = line.split()
                sizes[relpath] = int(size)
    return sizes


def registered_size(relpath: str) -> int | None:
    """Size in bytes of the registered file ``relpath`` (None when ``registry_sizes.txt`` does not list
    it, as for the files of a test's own registry)."""
    return _registered_sizes().get(relpath)


def registered_hash(relpath: str) -> str | None:
    """The registered ``"sha256:<hex>"`` of ``relpath``, or None if it is listed without one.

    Raises
    ------
    KeyError
        ``relpath`` is not in the registry.
    """
    value = registry().registry[relpath]
    return None if value == NO_HASH else value


def source_of(relpath: str) -> str:
    """Human-readable public source of a registered file (used in error messages)."""
    url = registry().urls.get(relpath)
    for prefix, text in _SOURCES:
        if relpath.startswith(prefix):
            return text + (f"; direct link: {url}" if url else "")
    return f"see data/README.md{'; direct link: ' + url if url else ''}"


def missing_message(relpath: str, home: Path) -> str:
    """The one command that gets the file, then where it comes from and where it goes."""
    return (
        f"dataset file {relpath!r} is missing: get it with `tzsl data fetch {relpath.split('/', 1)[0]}` "
        f"(data home {home}; choose another with --data-dir or {DATA_DIR_ENV}). Source: "
        f"{source_of(relpath)}; data/README.md lists every source."
    )


def fetch(
    relpath: str,
    data_dir: str | os.PathLike | None = None,
    *,
    download: bool = False,
    downloader=None,
) -> Path:
    """Absolute path of a registered data file, verified against its sha256.

    The hash is checked on the first use of the file in this process; the verdict is
    cached for as long as the file's size and modification time do not change.

    Parameters
    ----------
    relpath : str
        Registered path relative to the data home, e.g.
        ``"phac2/derived/phac2_labels_60x24.csv"``.
    data_dir : str or path-like or None
        Data home; see :func:`tzsl.datasets.get_data_home`.
    download : bool
        If True and the file is missing, download it from its registered public URL
        with pooch (network access) and verify its hash. Never done implicitly.
    downloader : callable or None
        A pooch downloader (``downloader(url, output_file, pooch)``) used with
        ``download=True``; default: pooch's HTTP downloader.

    Returns
    -------
    Path
        ``<data home>/<relpath>``.

    Raises
    ------
    KeyError
        ``relpath`` is not registered (a programming error).
    DataMissingError
        The file does not exist (message: what to download, from where, and where to
        save it).
    ChecksumError
        The file's sha256 differs from the registry's (message gives both).
    """
    pup = registry()
    if relpath not in pup.registry:
        raise KeyError(f"{relpath!r} is not in the tzsl dataset registry")
    home = get_data_home(data_dir)
    path = home / relpath
    if not path.is_file():
        if download and relpath in pup.urls:
            return download_file(relpath, home, downloader=downloader).path
        raise DataMissingError(path, missing_message(relpath, home))
    stat = path.stat()
    key = (str(path.resolve()), stat.st_size, stat.st_mtime_ns)
    with _LOCK:
        if key in _VERIFIED:
            return path
    verify_file(path, relpath, pup.registry[relpath])
    with _LOCK:
        _VERIFIED.add(key)
    return path


def verify_file(path: Path, relpath: str, expected: str) -> None:
    """Raise ChecksumError unless ``path`` has the registered hash ``expected`` (``"alg:hex"``;
    ``"none"``: nothing to check)."""
    if expected == NO_HASH:
        return
    alg, _, want = expected.partition(":")
    got = pooch.file_hash(str(path), alg=alg)
    if got.lower() != want.lower():
        raise ChecksumError(
            path,
            f"{alg} mismatch for {relpath!r}: expected {want}, got {got}. The file is "
            f"corrupt or a different version; get it again with: tzsl data fetch {relpath.split('/', 1)[0]} "
            f"(source: {source_of(relpath)}).",
        )


class Downloaded(NamedTuple):
    """A file :func:`download_file` put in place, and the attempts it took."""

    path: Path
    attempts: int


def download_file(relpath: str, home: Path, *, url: str | None = None, pup: pooch.Pooch | None = None,
                  downloader=None, progress: bool = False, timeout: float | None = None,
                  stall: float = FETCH_STALL_S, transfer: Transfer | None = None) -> Downloaded:
    """Download one registered file into the data home with pooch, hash-checked before it is moved
    into place (an interrupted, abandoned or corrupt download leaves no file).

    Parameters
    ----------
    relpath : str
        Registered path relative to the data home.
    home : Path
        The data home.
    url : str, optional
        Where to get it (a mirror); default the registry's public URL.
    pup : pooch.Pooch, optional
        The registry (default tzsl's own; tests pass a small one).
    downloader : callable, optional
        A pooch downloader, tried once; default :class:`~tzsl.datasets._download.DeadlineDownloader`
        for HTTP(S) (retried within the deadline, with a tqdm bar when ``progress``).
    progress : bool, default False
        A progress bar for this file (without ``transfer``).
    timeout : float, optional
        Deadline (s) for the whole file, retries included; default
        :func:`~tzsl.datasets._download.fetch_timeout` (``$TZSL_FETCH_TIMEOUT``, else
        :data:`~tzsl.datasets._download.DEFAULT_FETCH_TIMEOUT_S`).
    stall : float
        Seconds without a byte after which an attempt is abandoned.
    transfer : Transfer, optional
        The fetch this file is one of (:func:`~tzsl.datasets._transfer.download_all`: its progress
        bar, stop and HTTP sessions); default a transfer of this file alone.

    Returns
    -------
    Downloaded
        ``home / relpath`` and the number of attempts.

    Raises
    ------
    ChecksumError
        The download's hash differs from the registry's (nothing is kept).
    DataMissingError
        No URL, or no complete download (one line: ``<dataset> file <name>: ...``, naming the URL,
        the deadline when it passed, the attempts and the last one's failure).
    DownloadCancelled
        ``transfer`` stopped (another file of the fetch failed) before this file was complete.
    """
    pup = pup or registry()
    url = url or pup.urls.get(relpath)
    if url is None:
        raise DataMissingError(home / relpath, missing_message(relpath, home))
    timeout = fetch_timeout(timeout)
    known = pup.registry[relpath]
    single = pooch.create(path=home, base_url="", registry={relpath: None if known == NO_HASH else known},
                          urls={relpath: url}, retry_if_failed=0)
    dataset, _, name = relpath.partition("/")
    what = f"{dataset} file {name}"
    own = transfer is None
    if transfer is None:
        transfer = Transfer(FetchProgress(1, registered_size(relpath), label=Path(name).name, enabled=progress))
    try:
        path, attempts = download(single, relpath, url, timeout=timeout, stall=stall, transfer=transfer,
                                  downloader=downloader)
    except DownloadCancelled:
        raise
    except DownloadFailed as exc:
        tries = f"{exc.attempts} attempt{'s, the last' if exc.attempts > 1 else ''}: {exc.reason}"
        raise DataMissingError(None, f"{what}: no complete download within {timeout:g} s from {url} ({tries})"
                               if exc.deadline else f"{what}: cannot download from {url} ({tries})") from None
    except ValueError as exc:  # pooch's hash mismatch: the file is not kept
        raise ChecksumError(None, f"{what}: {first_line(exc)} (downloaded from {url}; not kept)") from None
    except Exception as exc:  # noqa: BLE001 - a caller's or pooch's other downloaders: one line naming the URL
        raise DataMissingError(None, f"{what}: cannot download from {url}: {type(exc).__name__}: "
                                     f"{first_line(exc)}") from None
    finally:
        if own:
            transfer.close()
    stat = path.stat()
    with _LOCK:
        _VERIFIED.add((str(path.resolve()), stat.st_size, stat.st_mtime_ns))
    return Downloaded(path, attempts)


def clear_verification_cache() -> None:
    """Forget which files were verified (next :func:`fetch` re-hashes them)."""
    with _LOCK:
        _VERIFIED.clear()
