"""Several downloads at a time (:mod:`tzsl.datasets._transfer`) against a loopback server: every
file arrives with its hash checked, over kept-alive connections, under one progress bar; the first
failure stops the others at once, in one line naming its file, and leaves nothing half-written."""

from __future__ import annotations

import hashlib
import os
import threading
import time
from pathlib import Path

import pooch
import pytest
from click.testing import CliRunner

from tests.datasets.fetch_server import registry_of, serve_folder
from tzsl.cli import cli
from tzsl.datasets import DEFAULT_FETCH_WORKERS, FETCH_WORKERS_ENV, MAX_FETCH_WORKERS, fetch_datasets
from tzsl.datasets._transfer import FetchProgress, fetch_workers
from tzsl.exceptions import ChecksumError, ConfigError, DataMissingError

#: Small files, as the fabric depth images are: (registered path, content).
MANY = {f"many/f{i:03d}.bin": os.urandom(100 + 37 * i) for i in range(120)}
WORKERS = 6


@pytest.fixture
def served(tmp_path):
    """MANY served from a loopback server answering each request 20 ms late; yields (base URL,
    served folder, paths requested)."""
    root = tmp_path / "served"
    for name, content in MANY.items():
        (root / name).parent.mkdir(parents=True, exist_ok=True)
        (root / name).write_bytes(content)
    with serve_folder(root, delay_s=0.02) as (base, requested):
        yield base, root, requested


def _pup(tmp_path: Path, urls: dict[str, str]) -> pooch.Pooch:
    return registry_of(tmp_path / "registry.txt", [f"{name} sha256:{hashlib.sha256(MANY[name]).hexdigest()} {url}"
                                                   for name, url in urls.items()])


def _files_under(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in folder.rglob("*") if p.is_file()}


def _fetch_threads() -> list[threading.Thread]:
    """The download threads of a fetch still alive (the pool's: ``tzsl-fetch_<n>``)."""
    return [t for t in threading.enumerate() if t.name.startswith("tzsl-fetch_")]


def test_many_files_arrive_verified_over_kept_alive_connections_under_one_bar(tmp_path, served, monkeypatch):
    base, _, requested = served
    bars: list[FetchProgress] = []

    class Recorded(FetchProgress):
        def __init__(self, *args, **kwargs) -> None:
            super().__init__(*args, **kwargs)
            self.received = 0
            bars.append(self)

        def add_bytes(self, nbytes: int) -> None:
            super().add_bytes(nbytes)
            self.received += nbytes

    import tzsl.datasets._fetch as fetch_module
    import tzsl.datasets._registry as registry_module

    monkeypatch.setattr(fetch_module, "FetchProgress", Recorded)
    monkeypatch.setattr(registry_module, "FetchProgress", Recorded)  # a bar per file would be made there
    home = tmp_path / "home"
    [report] = fetch_datasets(["many"], home, pup=_pup(tmp_path, {n: f"{base}/{n}" for n in MANY}), progress=True,
                              workers=WORKERS)
    assert report.downloaded == sorted(MANY) and not report.retried
    assert _files_under(home) == MANY  # every file, each with its registered content (pooch checked the hash)
    assert len(requested) == len(MANY) and len(requested.ports) <= WORKERS  # one connection per thread, reused
    [bar] = bars  # one bar for the fetch, counting every byte and file
    assert bar.received == sum(len(c) for c in MANY.values()) and bar._done == len(MANY)
    assert _fetch_threads() == []


def test_one_bad_hash_among_many_stops_the_fetch_in_one_line_naming_it(tmp_path, served):
    base, root, _ = served
    bad = sorted(MANY)[40]
    (root / bad).write_bytes(b"not the registered content")
    home = tmp_path / "home"
    with pytest.raises(ChecksumError) as info:
        fetch_datasets(["many"], home, pup=_pup(tmp_path, {n: f"{base}/{n}" for n in MANY}), progress=False,
                       workers=WORKERS)
    message = str(info.value)
    assert len(message.splitlines()) == 1
    assert message.startswith(f"many file {bad[5:]}: SHA256 hash of downloaded file") and f"{base}/{bad}" in message
    assert message.endswith("downloaded); a rerun goes on from there")
    kept = _files_under(home)
    assert bad not in kept and all(MANY[name] == content for name, content in kept.items())  # nothing partial
    # the failure stopped the rest: no file after the ones already in flight was started
    assert len(kept) <= 40 + WORKERS
    assert _fetch_threads() == []


def test_a_stalled_file_hits_its_deadline_while_the_others_complete(tmp_path, served):
    base, _, _ = served
    names = sorted(MANY)[:30]
    stalled = names[-1]  # started last: the others are complete by its deadline
    urls = {n: f"{base}/{n}" for n in names} | {stalled: f"{base}/stall/{stalled}"}
    home = tmp_path / "home"
    start = time.monotonic()
    with pytest.raises(DataMissingError) as info:
        fetch_datasets(["many"], home, pup=_pup(tmp_path, urls), progress=False, timeout=1.5, workers=WORKERS)
    assert 1.5 <= time.monotonic() - start < 1.5 + 3  # at its deadline, not at the 30 s stall limit
    assert str(info.value).startswith(f"many file {stalled[5:]}: no complete download within 1.5 s from "
                                      f"{urls[stalled]} (1 attempt: 0 of 1000 bytes received)")
    assert str(info.value).endswith("many: 29 of 30 files in place (0 present, 29 downloaded); a rerun goes on "
                                    "from there")
    assert _files_under(home) == {n: MANY[n] for n in names[:-1]}
    assert _fetch_threads() == []


def test_the_first_failure_cuts_the_downloads_in_flight_at_once(tmp_path, served):
    """A refusal stops the fetch: the files started before it, stalled far from their deadline and
    stall limit, end now (their sockets shut) and keep nothing."""
    base, _, _ = served
    names = sorted(MANY)[:WORKERS]  # all started at once, the refused one last
    refused = f"{base}/status/404/{names[-1]}"
    urls = {n: f"{base}/stall/{n}" for n in names[:-1]} | {names[-1]: refused}
    home = tmp_path / "home"
    start = time.monotonic()
    with pytest.raises(DataMissingError) as info:
        fetch_datasets(["many"], home, pup=_pup(tmp_path, urls), progress=False, timeout=30, workers=WORKERS)
    assert time.monotonic() - start < 5  # not the stalls' 30 s deadline and stall limit
    assert str(info.value) == (f"many file {names[-1][5:]}: cannot download from {refused} (1 attempt: HTTP 404 "
                               f"Not Found); many: 0 of {WORKERS} files in place (0 present, 0 downloaded); a rerun "
                               "goes on from there")
    assert _files_under(home) == {}  # the cut downloads' temporary files are gone
    assert _fetch_threads() == []


def test_the_workers_setting_is_read_once_and_checked(monkeypatch, tmp_path):
    monkeypatch.delenv(FETCH_WORKERS_ENV, raising=False)
    assert fetch_workers() == DEFAULT_FETCH_WORKERS and fetch_workers(3) == 3
    monkeypatch.setenv(FETCH_WORKERS_ENV, "2")
    assert fetch_workers() == 2 and fetch_workers(1) == 1
    for bad in ("many", "0", "-1", "2.5", str(MAX_FETCH_WORKERS + 1)):
        monkeypatch.setenv(FETCH_WORKERS_ENV, bad)
        with pytest.raises(ConfigError, match=rf"^\$TZSL_FETCH_WORKERS={bad!r}|^\$TZSL_FETCH_WORKERS=-?\d+:"):
            fetch_workers()
    monkeypatch.delenv(FETCH_WORKERS_ENV)
    result = CliRunner().invoke(cli, ["data", "fetch", "--workers", "0", "--no-progress",
                                      "--data-dir", str(tmp_path / "home")])
    assert result.exit_code == 3 and result.stderr.strip().splitlines() == [
        f"tzsl: error: workers=0: give the files downloaded at a time as a whole number from 1 to {MAX_FETCH_WORKERS}"]
