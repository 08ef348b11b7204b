"""The downloads of one fetch, several at a time: one progress bar, one stop, kept-alive connections.

A fetch (``tzsl data fetch``, a study's first-use fetch) downloads its files on
:func:`fetch_workers` threads (:func:`download_all`); each file still goes through
:func:`tzsl.datasets._download.download` (deadline, stall limit, retries, hash check, atomic
placement). What the files of a fetch share is a :class:`Transfer`:

- one :class:`FetchProgress` bar (bytes of the fetch, files done), not one bar per file or thread;
- one stop: the first file that fails stops the others at once (their sockets are shut, so a
  download waiting for bytes ends now, not at its deadline; pooch removes its temporary file),
  and no file starts after it; Ctrl-C does the same before it propagates (the sockets are shut
  with urllib3's ``HTTPResponse.shutdown``, urllib3 2.3 and later);
- one :class:`requests.Session` per thread, so that a thread's downloads reuse its connection to
  the server (keep-alive) instead of opening one per file.
"""

from __future__ import annotations

import contextlib
import os
import threading
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_EXCEPTION, Future, ThreadPoolExecutor, wait
from typing import Any, TypeVar

import requests

from tzsl._progress import progress_bar
from tzsl.exceptions import ConfigError

__all__ = ["DEFAULT_FETCH_WORKERS", "FETCH_WORKERS_ENV", "MAX_FETCH_WORKERS", "DownloadCancelled",
           "FetchProgress", "Transfer", "download_all", "fetch_workers"]

#: Environment variable: how many files a fetch downloads at a time (``tzsl data fetch --workers`` wins).
FETCH_WORKERS_ENV = "TZSL_FETCH_WORKERS"
#: Files downloaded at a time without ``--workers`` or ``$TZSL_FETCH_WORKERS``: enough to hide the
#: round trip of each of the many small files (the fabric depth images), few enough for one server.
DEFAULT_FETCH_WORKERS = 8
#: The most files a fetch downloads at a time (a politeness limit towards the servers).
MAX_FETCH_WORKERS = 32
#: How often (s) a thread waiting for a server's status and headers looks whether the fetch stopped.
STOP_POLL_S = 0.05

Job = TypeVar("Job")
Result = TypeVar("Result")


def fetch_setting(name: str, value: Any, env: str, default: Any, parse: Callable[[str], Any],
                  valid: Callable[[Any], bool], expected: str, shown: Callable[[Any], str] = repr) -> Any:
    """A fetch setting: ``value`` when given, else ``$env`` parsed with ``parse``, else ``default``.

    Raises
    ------
    ConfigError
        ``<name or $env>=<value>: give <expected>`` when ``$env`` cannot be parsed (the text shown with
        ``repr``) or the value is not ``valid`` (shown with ``shown``).
    """
    where = name
    if value is None:
        text = os.environ.get(env, "").strip()
        if not text:
            return default
        where = f"${env}"
        try:
            value = parse(text)
        except ValueError:
            raise ConfigError(f"{where}={text!r}: give {expected}") from None
    if not valid(value):
        raise ConfigError(f"{where}={shown(value)}: give {expected}")
    return value


def fetch_workers(workers: int | None = None) -> int:
    """Files downloaded at a time: ``workers``, else ``$TZSL_FETCH_WORKERS``, else
    :data:`DEFAULT_FETCH_WORKERS`.

    Raises
    ------
    ConfigError
        A value that is not a whole number from 1 to :data:`MAX_FETCH_WORKERS` (naming where it came from).
    """
    return fetch_setting(
        "workers", workers, FETCH_WORKERS_ENV, DEFAULT_FETCH_WORKERS, int,
        lambda v: not isinstance(v, bool) and isinstance(v, int) and 1 <= v <= MAX_FETCH_WORKERS,
        f"the files downloaded at a time as a whole number from 1 to {MAX_FETCH_WORKERS}")


class DownloadCancelled(Exception):
    """A download ended because its fetch stopped (another file failed, or Ctrl-C): not a failure
    of its own, never reported."""


class FetchProgress:
    """One tqdm bar (stderr, erased at the end) for the files of a fetch, fed from any thread.

    Parameters
    ----------
    files : int
        Files the fetch downloads (shown as ``done/files files``).
    total_bytes : int or None
        Their size in bytes when known (``registry_sizes.txt``), else None (a count without total).
    label : str
        The bar's label (the dataset, or the file).
    enabled : bool
        False: nothing is shown.
    """

    def __init__(self, files: int, total_bytes: int | None, *, label: str, enabled: bool = True) -> None:
        self._lock = threading.Lock()
        self._files = files
        self._done = 0
        self._bar = progress_bar(total=total_bytes, unit="B", unit_scale=True, ncols=79, leave=False, desc=label,
                                 show=enabled, postfix=self._postfix())

    def _postfix(self) -> str:
        return f"{self._done}/{self._files} files"

    def add_bytes(self, nbytes: int) -> None:
        """``nbytes`` more received (negative: a failed attempt's bytes taken back)."""
        with self._lock:
            self._bar.update(nbytes)

    def file_done(self) -> None:
        """One more file in place."""
        with self._lock:
            self._done += 1
            self._bar.set_postfix_str(self._postfix(), refresh=False)

    def close(self) -> None:
        """Erase the bar."""
        with self._lock:
            self._bar.close()


class Transfer:
    """What the downloads of one fetch share: its progress bar, its stop and one HTTP session per
    thread (see the module docstring). Close it (or use it in a ``with``) to close the sessions.

    Parameters
    ----------
    progress : FetchProgress, optional
        The bar fed by every download of the fetch.
    """

    def __init__(self, progress: FetchProgress | None = None) -> None:
        self.progress = progress
        self._lock = threading.Lock()
        self._stopped = threading.Event()
        self._reading: set[object] = set()
        self._local = threading.local()
        self._sessions: list[requests.Session] = []

    def __enter__(self) -> Transfer:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    @property
    def stopped(self) -> bool:
        """Whether the fetch stopped (no download starts or goes on)."""
        return self._stopped.is_set()

    def check(self) -> None:
        """Raise :class:`DownloadCancelled` when the fetch stopped."""
        if self._stopped.is_set():
            raise DownloadCancelled

    def pause(self, seconds: float) -> None:
        """Wait ``seconds`` (between two attempts), ended early by a stop (then DownloadCancelled)."""
        if self._stopped.wait(seconds):
            raise DownloadCancelled

    def stop(self) -> None:
        """Stop every download of the fetch now: the responses being read have their sockets shut
        (their reads end at once), and :meth:`check` fails from now on."""
        with self._lock:
            self._stopped.set()
            for raw in self._reading:
                with contextlib.suppress(Exception):  # already released or closed: nothing to cut
                    raw.shutdown()  # type: ignore[attr-defined]

    @contextlib.contextmanager
    def reading(self, raw: object) -> Iterator[None]:
        """While inside, :meth:`stop` shuts the socket of ``raw`` (urllib3's response)."""
        with self._lock:
            self.check()
            self._reading.add(raw)
        try:
            yield
        finally:
            with self._lock:
                self._reading.discard(raw)

    def session(self) -> requests.Session:
        """This thread's HTTP session (created on first use): its connection is kept for the next file."""
        session = getattr(self._local, "session", None)
        if session is None:
            session = self._local.session = requests.Session()
            with self._lock:
                self._sessions.append(session)
        return session

    def close(self) -> None:
        """Close the sessions (their connections) and the bar."""
        with self._lock:
            sessions, self._sessions = self._sessions, []
        for session in sessions:
            session.close()
        if self.progress is not None:
            self.progress.close()


def download_all(jobs: Sequence[Job], get: Callable[[Job], Result], *, workers: int,
                 transfer: Transfer) -> list[Result | None]:
    """``get(job)`` for every job, on up to ``workers`` threads; the first failure stops the rest.

    The first exception a job raises (other than :class:`DownloadCancelled`) stops ``transfer``:
    no other job starts, the running ones end promptly (cancelled), and once every thread has
    ended that exception is raised here. Ctrl-C (KeyboardInterrupt in the calling thread) stops
    the transfer the same way, waits for the threads, and propagates. No thread outlives the call.

    Parameters
    ----------
    jobs : sequence
        What to download (passed to ``get``), started in this order.
    get : callable
        Downloads one job (with ``transfer``), returning what the caller keeps.
    workers : int
        Threads at most (:func:`fetch_workers`); 1 runs the jobs one after another in this thread.
    transfer : Transfer
        The fetch's shared stop (and bar and sessions).

    Returns
    -------
    list
        ``get``'s results in the order of ``jobs``.
    """
    if workers == 1 or len(jobs) <= 1:
        results: list[Result | None] = []
        try:
            for job in jobs:
                transfer.check()
                results.append(get(job))
        except BaseException:
            transfer.stop()
            raise
        return results
    first: list[BaseException] = []

    def run(job: Job) -> Result | None:
        if transfer.stopped:
            return None  # not started: the fetch stopped
        try:
            return get(job)
        except DownloadCancelled:
            return None
        except BaseException as exc:
            first.append(exc)  # list.append is atomic: the first failure is first[0]
            transfer.stop()
            raise

    futures: list[Future[Result | None]] = []
    with ThreadPoolExecutor(max_workers=min(workers, len(jobs)), thread_name_prefix="tzsl-fetch") as pool:
        try:
            for job in jobs:
                futures.append(pool.submit(run, job))
            wait(futures, return_when=FIRST_EXCEPTION)
        except BaseException:  # Ctrl-C: stop the downloads in flight; leaving the block waits for them
            transfer.stop()
            for future in futures:
                future.cancel()
            raise
        if first:
            for future in futures:
                future.cancel()
    if first:
        raise first[0]
    return [future.result() for future in futures]
