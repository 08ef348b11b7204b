"""One file over HTTP(S): an overall deadline, stall detection, silent retries, a quiet pooch.

:func:`download` is the one way tzsl downloads a registered file (``tzsl data fetch``,
:func:`tzsl.datasets.fetch_datasets`, ``fetch(..., download=True)``). pooch still does the
bookkeeping (a temporary file beside the target, the hash check, the move into place); the
bytes come through :class:`DeadlineDownloader`, which gives up on a file

- when it is not complete within its deadline (``timeout`` seconds from the first attempt,
  retries and waits between them included; :func:`fetch_timeout`), however the server
  sends it (a byte now and then, headers included), and
- for this attempt, when no byte arrives for :data:`FETCH_STALL_S` seconds (a stall; retried while the
  deadline allows).

Failed attempts are retried silently (:data:`FETCH_ATTEMPTS`), except a refusal (HTTP 4xx) and a
hash mismatch, and counted in the one line that reports the file. pooch's own log lines
(``Downloading file ...``) never reach the terminal: :func:`quiet_pooch_logger` drops them and
turns pooch's warnings, if any, into Python warnings (one ``tzsl: warning:`` line on the command
line). A download killed outright (SIGKILL, power cut) leaves pooch's temporary file
(``tmp`` + 8 characters) behind, a build tzsl's own (``.<name>.<8 characters>.tmp``);
:func:`remove_leftovers` deletes those in the folders the next fetch writes to, under
:func:`fetch_lock` so that no running fetch loses its file.

The files of one fetch share a :class:`~tzsl.datasets._transfer.Transfer` (several downloads at a
time, one progress bar, one stop, kept-alive connections): :mod:`tzsl.datasets._transfer`.
"""

from __future__ import annotations

import contextlib
import logging
import os
import re
import threading
import time
import warnings
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

import pooch
import requests
from urllib3.exceptions import ReadTimeoutError

from tzsl.datasets._transfer import STOP_POLL_S, Transfer, fetch_setting
from tzsl.exceptions import first_line

try:  # POSIX: an advisory lock on the data home, released by the system when its process dies
    import fcntl
except ImportError:  # pragma: no cover - Windows: a file in use cannot be deleted there anyway
    fcntl = None  # type: ignore[assignment]

__all__ = ["FETCH_ATTEMPTS", "DEFAULT_FETCH_TIMEOUT_S", "FETCH_TIMEOUT_ENV", "FETCH_STALL_S", "DeadlineDownloader",
           "DownloadFailed", "download", "fetch_lock", "fetch_timeout", "is_leftover",
           "quiet_pooch_logger", "remove_leftovers"]

#: Environment variable: the deadline per file, in seconds (``tzsl data fetch --timeout`` wins).
FETCH_TIMEOUT_ENV = "TZSL_FETCH_TIMEOUT"
#: Deadline per file (s) without ``--timeout`` or ``$TZSL_FETCH_TIMEOUT``. The largest registered
#: file is a few MB, so this allows for a connection of some 10 kB/s.
DEFAULT_FETCH_TIMEOUT_S = 300.0
#: An attempt that receives no byte for this long (s) is abandoned (and retried within the deadline).
FETCH_STALL_S = 30.0
#: Attempts per file, within its deadline (network failures, HTTP 5xx, stalls and truncations are
#: retried; an HTTP 4xx or a hash mismatch is not).
FETCH_ATTEMPTS = 3
#: Bytes asked for per read (one read returns what has arrived, up to this).
CHUNK_BYTES = 1 << 16
#: The name of pooch's temporary download files: :func:`tempfile.NamedTemporaryFile`'s ``tmp``
#: followed by 8 characters of ``[a-z0-9_]`` (pooch 1.x, ``pooch.utils.temporary_file``).
POOCH_TEMPORARY = re.compile(r"tmp[a-z0-9_]{8}")
#: The name of tzsl's own temporary files (:func:`tzsl._io.atomic_write`, which writes the files a
#: fetch builds): ``.<final name>.`` + 8 characters of ``[a-z0-9_]`` + ``.tmp``, beside the final file.
ATOMIC_TEMPORARY = re.compile(r"\.(?P<target>.+)\.[a-z0-9_]{8}\.tmp")


def fetch_timeout(timeout: float | None = None) -> float:
    """The deadline per file in seconds: ``timeout``, else ``$TZSL_FETCH_TIMEOUT``, else
    :data:`DEFAULT_FETCH_TIMEOUT_S`.

    Raises
    ------
    ConfigError
        A value that is not a number of seconds above 0 (naming where it came from).
    """
    return float(fetch_setting("timeout", timeout, FETCH_TIMEOUT_ENV, DEFAULT_FETCH_TIMEOUT_S, float,
                               lambda v: 0 < v < float("inf"), "the deadline per file as a number of seconds above 0",
                               shown=lambda v: f"{v:g}"))


class DownloadFailed(Exception):
    """A failed download: ``reason`` (the last attempt's failure, in a few words), whether it is
    worth another attempt (``retry``), whether the deadline passed (``deadline``) and how many
    attempts were made (``attempts``, set by :func:`download`)."""

    def __init__(self, reason: str, *, retry: bool, deadline: bool = False) -> None:
        super().__init__(reason)
        self.reason = reason
        self.retry = retry
        self.deadline = deadline
        self.attempts = 1


@dataclass
class DeadlineDownloader:
    """A pooch downloader (``downloader(url, output_file, pooch)``) that abandons a download at
    ``deadline`` and an attempt after ``stall`` seconds without a byte.

    Parameters
    ----------
    deadline : float
        :func:`time.monotonic` time (s) by which the file must be complete.
    stall : float
        Seconds without a byte after which this attempt fails (retryable).
    transfer : Transfer
        The fetch this download belongs to: its HTTP session (this thread's), its progress bar
        (bytes counted as they arrive, taken back when the attempt fails) and its stop (the
        download then ends with :class:`~tzsl.datasets._transfer.DownloadCancelled`).
    """

    deadline: float
    stall: float = FETCH_STALL_S
    transfer: Transfer = field(default_factory=Transfer)

    def _remaining(self) -> float:
        remaining = self.deadline - time.monotonic()
        if remaining <= 0:
            raise DownloadFailed("status and headers not received", retry=False, deadline=True)
        return remaining

    def _get(self, url: str) -> requests.Response:
        """The response (status and headers read) within the deadline, however slowly the server
        sends them: the request runs in a daemon thread that is abandoned at the deadline (or when
        the fetch stops)."""
        box: dict[str, requests.Response] = {}  # "response", set by the request thread
        failure: dict[str, Exception] = {}  # "error", set by the request thread
        done, abandoned = threading.Event(), threading.Event()
        wait = min(self.stall, self._remaining())
        session = self.transfer.session()

        def request() -> None:
            try:
                box["response"] = session.get(url, stream=True, timeout=(wait, wait))
            except Exception as exc:  # noqa: BLE001 - reported by the caller's thread
                failure["error"] = exc
            finally:
                done.set()
                if abandoned.is_set() and "response" in box:
                    box["response"].close()

        threading.Thread(target=request, name="tzsl-fetch-request", daemon=True).start()
        try:  # wake up at the deadline, and every STOP_POLL_S to see whether the fetch stopped
            while not done.wait(min(STOP_POLL_S, self._remaining())):
                self.transfer.check()
        except BaseException:
            abandoned.set()
            if done.is_set() and "response" in box:
                box["response"].close()
            raise
        error = failure.get("error")
        if isinstance(error, requests.Timeout):
            raise DownloadFailed(f"no response for {wait:g} s", retry=True)
        if isinstance(error, requests.RequestException):
            raise DownloadFailed(_connection_reason(error), retry=True)
        if error is not None:
            raise error
        response = box["response"]
        if response.status_code >= 400:
            response.close()
            retry = response.status_code >= 500 or response.status_code in (408, 429)
            raise DownloadFailed(f"HTTP {response.status_code} {response.reason}", retry=retry)
        return response

    def __call__(self, url: str, output_file: str, pup: pooch.Pooch | None = None) -> None:
        """Write the body at ``url`` to ``output_file`` (pooch's temporary file).

        Raises
        ------
        DownloadFailed
            The deadline passed, the attempt stalled or was cut short, or the server refused.
        """
        response = self._get(url)
        raw = response.raw  # urllib3's response: read1() returns what has arrived
        # the socket's timeout is set before each read; without a socket to reach (not seen with
        # requests and urllib3 2) the deadline is checked between reads, at most one stall limit late
        settimeout = getattr(getattr(raw.connection, "sock", None), "settimeout", None)
        expected = response.headers.get("content-length")
        total = int(expected) if expected and expected.isdigit() else None
        of = f" of {total}" if total is not None else ""

        def on_time() -> float:
            """Seconds left; at the deadline, this attempt and the file fail."""
            remaining = self.deadline - time.monotonic()
            if remaining <= 0:
                raise DownloadFailed(f"{raw.tell()}{of} bytes received", retry=False, deadline=True)
            return remaining

        progress = self.transfer.progress
        counted = 0  # bytes of this attempt on the fetch's bar
        try:
            with self.transfer.reading(raw), open(output_file, "wb") as out:
                while True:
                    remaining = on_time()
                    if settimeout is not None:  # wake up at the deadline or after a stall, whichever is first
                        settimeout(min(self.stall, remaining))
                    try:
                        chunk = raw.read1(CHUNK_BYTES, decode_content=True)
                    except (ReadTimeoutError, TimeoutError):
                        self.transfer.check()
                        on_time()
                        raise DownloadFailed(f"no byte for {self.stall:g} s after {raw.tell()}{of} bytes",
                                             retry=True) from None
                    except Exception as exc:  # noqa: BLE001 - urllib3's IncompleteRead, a reset connection
                        self.transfer.check()  # the fetch stopped: its socket was shut
                        on_time()
                        raise DownloadFailed(f"connection ended after {raw.tell()}{of} bytes "
                                             f"({type(exc).__name__})", retry=True) from None
                    self.transfer.check()  # a shut socket reads as the end of the body
                    if not chunk:
                        break
                    out.write(chunk)
                    if progress is not None:
                        progress.add_bytes(raw.tell() - counted)
                        counted = raw.tell()
        except BaseException:
            if progress is not None and counted:
                progress.add_bytes(-counted)  # this attempt's bytes are not kept
            raise
        finally:
            response.close()
        if total is not None and raw.tell() < total:
            raise DownloadFailed(f"connection ended after {raw.tell()}{of} bytes", retry=True)


def _connection_reason(error: requests.RequestException) -> str:
    """Why a request failed, in a few words: urllib3's innermost reason without the pool and
    connection reprs (``Failed to establish a new connection: [Errno 111] Connection refused``)."""
    reason = getattr(error.args[0], "reason", None) if error.args else None
    text = first_line(reason) if isinstance(reason, BaseException) else first_line(error)
    return f"{type(error).__name__}: {text.split('): ', 1)[-1]}"




class _PoochRelay(logging.Filter):
    """Drops pooch's records (their info lines) and turns its warnings into Python warnings."""

    def filter(self, record: logging.LogRecord) -> bool:
        if record.levelno >= logging.WARNING:
            warnings.warn(f"pooch: {record.getMessage()}", stacklevel=2)
        return False


@contextlib.contextmanager
def quiet_pooch_logger() -> Iterator[None]:
    """While inside, nothing pooch logs is printed (its warnings become Python warnings)."""
    relay = _PoochRelay()
    logger = pooch.get_logger()
    logger.addFilter(relay)
    try:
        yield
    finally:
        logger.removeFilter(relay)


def download(pup: pooch.Pooch, relpath: str, url: str, *, timeout: float, stall: float = FETCH_STALL_S,
             transfer: Transfer, downloader: Callable | None = None) -> tuple[Path, int]:
    """Download ``relpath`` of ``pup`` (a one-file Pooch whose path is the data home) from ``url``.

    Safe to call from several threads at once (one file each) with the same ``transfer``.

    Parameters
    ----------
    pup : pooch.Pooch
        Holds ``relpath`` with its hash and URL; ``pup.path`` is the data home.
    relpath : str
        Path relative to the data home.
    url : str
        Where to get it (HTTP(S) goes through :class:`DeadlineDownloader`).
    timeout : float
        Deadline (s) for the file, every attempt and wait included.
    stall : float
        Seconds without a byte after which an attempt is abandoned.
    transfer : Transfer
        The fetch's shared progress bar (a file done is counted on it), stop and HTTP sessions.
    downloader : callable, optional
        Another pooch downloader (tests): tried once, without deadline.

    Returns
    -------
    (Path, int)
        The file in place (hash checked), and the number of attempts it took.

    Raises
    ------
    DownloadFailed
        No complete download (``deadline`` set when the deadline passed); ``reason`` names the last
        attempt's failure and ``attempts`` how many were made.
    ValueError
        pooch's hash mismatch (nothing is kept).
    DownloadCancelled
        The fetch stopped (``transfer``) before the file was complete (nothing is kept).
    """
    (Path(pup.abspath) / relpath).parent.mkdir(parents=True, exist_ok=True)  # pooch's own mkdir races
    start = time.monotonic()
    deadline = start + timeout
    http = downloader is None and url.startswith(("http://", "https://"))
    tries = FETCH_ATTEMPTS if http else 1
    for attempt in range(1, tries + 1):
        transfer.check()
        get = DeadlineDownloader(deadline, stall, transfer) if http else downloader
        try:
            with quiet_pooch_logger():
                path = Path(pup.fetch(relpath, downloader=get))
            if transfer.progress is not None:
                transfer.progress.file_done()
            return path, attempt
        except DownloadFailed as exc:
            exc.attempts = attempt
            if exc.deadline or not exc.retry or attempt == tries:
                raise
            wait = min(float(attempt), deadline - time.monotonic())
            if wait > 0:
                transfer.pause(wait)
            if time.monotonic() >= deadline:
                exc.deadline = True
                raise
    raise AssertionError("unreachable")  # pragma: no cover


def is_leftover(path: Path, registered: set[Path]) -> bool:
    """Whether ``path`` is a temporary file of a download or build of ``registered`` files: named
    like pooch's temporaries (:data:`POOCH_TEMPORARY`, and not registered itself) or like tzsl's
    atomic writes of a registered file (:data:`ATOMIC_TEMPORARY`)."""
    if POOCH_TEMPORARY.fullmatch(path.name):
        return path not in registered
    atomic = ATOMIC_TEMPORARY.fullmatch(path.name)
    return atomic is not None and path.with_name(atomic["target"]) in registered


def remove_leftovers(registered: Iterable[Path]) -> list[Path]:
    """Delete the temporary files a killed fetch left beside the ``registered`` files.

    Only regular files :func:`is_leftover` recognises are deleted, in the folders of the
    registered files (not in their subfolders). Call it under
    :func:`fetch_lock`: a running fetch's temporary file has the same kind of name.

    Returns
    -------
    list of Path
        The files deleted.
    """
    registered = {Path(p) for p in registered}
    removed = []
    for folder in sorted({p.parent for p in registered}):
        if not folder.is_dir():
            continue
        for path in sorted(folder.iterdir()):
            if is_leftover(path, registered) and path.is_file() and not path.is_symlink():
                with contextlib.suppress(FileNotFoundError, PermissionError):
                    path.unlink()
                    removed.append(path)
    return removed


@contextlib.contextmanager
def fetch_lock(home: Path, on_wait: Callable[[str], None] | None = None) -> Iterator[None]:
    """Hold the data home for one fetch at a time (other fetches into it wait).

    An advisory lock (``flock``) on the data home folder itself (created if missing): no lock
    file is left behind, and the system releases it when the process ends, killed or not.
    ``on_wait`` receives one line when another fetch holds it. Where ``fcntl`` is missing
    (Windows) nothing is locked.
    """
    home.mkdir(parents=True, exist_ok=True)
    if fcntl is None:  # pragma: no cover
        yield
        return
    fd = os.open(home, os.O_RDONLY)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            if on_wait is not None:
                on_wait(f"another fetch is writing to {home}: waiting for it to end")
            fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)  # releases the lock
