"""``tzsl data fetch`` against a local HTTP server serving a small registry (never the network)."""

from __future__ import annotations

import hashlib
import logging
import os
import re
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pooch
import pytest
from click.testing import CliRunner

from tests.datasets.fetch_server import DRIP_S, registry_of, serve_folder
from tzsl.cli import cli
from tzsl.datasets import fetch_datasets, registered_datasets
from tzsl.exceptions import ChecksumError, ConfigError, DataMissingError

FILES = {"alpha/one.csv": b"a,b\n1,2\n", "alpha/sub/two.bin": bytes(range(200)) * 50, "beta/three.txt": b"three\n"}


@pytest.fixture
def server(tmp_path):
    """A loopback HTTP server over a folder holding FILES (:func:`serve_folder`); yields (base URL, folder)."""
    root = tmp_path / "served"
    for name, content in FILES.items():
        (root / name).parent.mkdir(parents=True, exist_ok=True)
        (root / name).write_bytes(content)
    with serve_folder(root) as (base, _requested):
        yield base, root


def _registry(tmp_path: Path, base: str, *, urls: bool = True) -> pooch.Pooch:
    lines = [f"{name} sha256:{hashlib.sha256(content).hexdigest()}" + (f" {base}/{name}" if urls else "")
             for name, content in FILES.items()]
    lines.append("beta/local.csv sha256:" + "0" * 64)  # built locally: no URL
    return registry_of(tmp_path / "registry.txt", lines)


def test_fetch_downloads_verifies_and_skips_what_is_there(tmp_path, server):
    base, _ = server
    pup = _registry(tmp_path, base)
    assert registered_datasets(pup) == ["alpha", "beta"]
    home = tmp_path / "home"
    lines: list[str] = []
    [report] = fetch_datasets(["alpha"], home, pup=pup, progress=False, echo=lines.append)
    assert sorted(report.downloaded) == ["alpha/one.csv", "alpha/sub/two.bin"] and not report.present
    assert (home / "alpha/sub/two.bin").read_bytes() == FILES["alpha/sub/two.bin"]
    assert lines == ["alpha: 0 present, 2 downloaded"]
    # a rerun downloads nothing; a half-written file is replaced (resume after an interruption)
    (home / "alpha/one.csv").write_bytes(b"a,")
    [again] = fetch_datasets(["alpha"], home, pup=pup, progress=False)
    assert again.present == ["alpha/sub/two.bin"] and again.downloaded == ["alpha/one.csv"]
    assert (home / "alpha/one.csv").read_bytes() == FILES["alpha/one.csv"]


def test_fetch_reports_files_without_url_and_refuses_a_bad_hash(tmp_path, server):
    base, root = server
    pup = _registry(tmp_path, base)
    home = tmp_path / "home"
    [report] = fetch_datasets(["beta"], home, pup=pup, progress=False)
    assert report.downloaded == ["beta/three.txt"] and report.missing == ["beta/local.csv"]
    (root / "alpha/one.csv").write_bytes(b"changed on the server\n")
    with pytest.raises(ChecksumError) as info:
        fetch_datasets(["alpha"], home, pup=pup, progress=False)
    assert len(str(info.value).splitlines()) == 1 and base in str(info.value)
    assert not (home / "alpha/one.csv").exists()  # never kept under its final name
    with pytest.raises(ConfigError, match="unknown dataset"):
        fetch_datasets(["gamma"], home, pup=pup)


def test_mirror_replaces_the_registry_urls(tmp_path, server, monkeypatch):
    base, _ = server
    pup = _registry(tmp_path, "http://127.0.0.1:9/unreachable", urls=True)
    monkeypatch.setenv("TZSL_DATA_MIRROR", base)
    reports = fetch_datasets([], tmp_path / "home", pup=pup, progress=False)
    assert [len(r.downloaded) for r in reports] == [2, 1]


def test_cli_refuses_an_unknown_dataset_in_one_line():
    result = CliRunner().invoke(cli, ["data", "fetch", "no-such-dataset", "--no-progress"])
    assert result.exit_code == 3
    assert result.stderr.strip().splitlines() == [
        f"tzsl: error: unknown dataset(s) ['no-such-dataset']; known: {', '.join(registered_datasets())}"]


def test_a_missing_file_names_the_command_that_gets_it(tmp_path):
    from tzsl.datasets import fetch
    from tzsl.exceptions import DataMissingError

    with pytest.raises(DataMissingError, match=r"get it with `tzsl data fetch phac2`"):
        fetch("phac2/derived/phac2_labels_60x24.csv", tmp_path)


def test_the_penn_label_table_is_rebuilt_byte_for_byte_from_the_pickles(data_dir):
    """The one locally built file phac2-penn needs: fetch builds it, identical to the registered one."""
    from tzsl.datasets import fetch, registered_files
    from tzsl.datasets._phac2_penn import PENN_STATIC_DIR, labels_csv_bytes, read_penn_static_pickles
    from tzsl.datasets._registry import registered_hash

    data = read_penn_static_pickles([fetch(rel, data_dir) for rel in registered_files(PENN_STATIC_DIR)])
    built = hashlib.sha256(labels_csv_bytes(data.labels)).hexdigest()
    assert f"sha256:{built}" == registered_hash("phac2/derived/phac2_labels_60x24.csv")


# A Data2.py in the shape of the fabric paper's (Python 2, never executed): fabrics 1..5 in 3 groups.
DATA2 = """import numpy as np
class Data():
    def __init__(self, attr_num):
        self.large_classify = [
            [4, 1],
            [2, 5],
            [3]
        ]
        print 'python 2'
"""
GROUPS_CSV = b"fabric_id,fabric_name,group\n1,F0001,0\n2,F0002,1\n3,F0003,2\n4,F0004,0\n5,F0005,1\n"


def test_fabric_groups_are_built_from_the_papers_group_lists(tmp_path):
    from tzsl.datasets._fabric import fabric_groups_csv_bytes
    from tzsl.exceptions import DataFileError

    assert fabric_groups_csv_bytes(DATA2) == GROUPS_CSV
    for bad in ("no groups here", DATA2.replace("[3]", "[3, 4]"), DATA2.replace("[3]", "[__import__]")):
        with pytest.raises(DataFileError) as info:
            fabric_groups_csv_bytes(bad, origin="Data2.py")
        assert str(info.value).startswith("Data2.py: ") and len(str(info.value).splitlines()) == 1


def test_fetch_builds_fabric_groups_and_leaves_reference_copies_out(tmp_path):
    from tzsl.datasets import REFERENCE_ONLY

    served = tmp_path / "served"
    (served / "fabric/sources").mkdir(parents=True)
    (served / "fabric/sources/Data2.py").write_text(DATA2)
    with serve_folder(served) as (base, _requested):
        reference = sorted(REFERENCE_ONLY)[0]
        pup = registry_of(tmp_path / "registry.txt", [
            f"fabric/fabric_groups.csv sha256:{hashlib.sha256(GROUPS_CSV).hexdigest()}",
            f"{reference} sha256:{'0' * 64}"])
        home = tmp_path / "home"
        sources = {"fabric/fabric_groups.csv": {"fabric/sources/Data2.py": (
            f"sha256:{hashlib.sha256(DATA2.encode()).hexdigest()}", f"{base}/fabric/sources/Data2.py")}}
        fabric, phac2 = fetch_datasets([], home, pup=pup, progress=False, build_sources=sources)
    assert fabric.built == ["fabric/fabric_groups.csv"] and (home / "fabric/sources/Data2.py").read_text() == DATA2
    assert (home / "fabric/fabric_groups.csv").read_bytes() == GROUPS_CSV
    assert phac2.reference == [reference] and phac2.missing == []
    assert "no study reads them" in phac2.line()


# --------------------------------------------------------------------------- deadline, retries, one line


def _pup(tmp_path: Path, urls: dict[str, str]) -> pooch.Pooch:
    """A registry of FILES' hashes with the given URLs (written as a registry file, as tzsl's is)."""
    return registry_of(tmp_path / "registry.txt",
                       [f"{name} sha256:{hashlib.sha256(FILES[name]).hexdigest()} {url}" for name, url in urls.items()])


def _files_under(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file()) if folder.exists() else []


@pytest.mark.parametrize("kind", ["drip", "header-drip"])
def test_a_slow_drip_is_abandoned_at_the_deadline_and_leaves_nothing(tmp_path, server, kind):
    """1 byte every DRIP_S never stalls a read, body or headers: the deadline ends it, in one line."""
    base, _ = server
    url = f"{base}/{kind}/alpha/one.csv"
    pup = _pup(tmp_path, {"alpha/one.csv": url})
    home = tmp_path / "home"
    start = time.monotonic()
    with pytest.raises(DataMissingError) as info:
        fetch_datasets(["alpha"], home, pup=pup, progress=False, timeout=2)
    elapsed = time.monotonic() - start
    assert 2 <= elapsed < 2 + 3, elapsed  # at the deadline (with room for a busy machine), not at the drip's end
    message = str(info.value)
    assert message.startswith(f"alpha file one.csv: no complete download within 2 s from {url} (1 attempt: ")
    assert ("of 1000 bytes received" if kind == "drip" else "status and headers not received") in message
    assert len(message.splitlines()) == 1 and message.endswith("alpha: 0 of 1 files in place (0 present, "
                                                               "0 downloaded); a rerun goes on from there")
    assert _files_under(home) == []  # no partial file, no temporary file


def test_a_stall_is_retried_within_the_deadline_then_reported(tmp_path, server):
    base, _ = server
    url = f"{base}/stall/alpha/one.csv"
    pup = _pup(tmp_path, {"alpha/one.csv": url})
    start = time.monotonic()
    with pytest.raises(DataMissingError) as info:
        fetch_datasets(["alpha"], tmp_path / "home", pup=pup, progress=False, timeout=30, stall=0.5)
    assert time.monotonic() - start < 10  # 3 stalls of 0.5 s and waits of 1 + 2 s, far from the deadline
    assert str(info.value).startswith(f"alpha file one.csv: cannot download from {url} (3 attempts, the last: "
                                      "no byte for 0.5 s after 0 of 1000 bytes);")
    # a stall close to the deadline is reported as the deadline
    with pytest.raises(DataMissingError, match=r"no complete download within 1 s .*\(1 attempt: 0 of 1000 bytes "):
        fetch_datasets(["alpha"], tmp_path / "home", pup=pup, progress=False, timeout=1, stall=5)
    assert _files_under(tmp_path / "home") == []


def test_retries_are_silent_and_counted_and_a_refusal_is_not_retried(tmp_path, server):
    base, _ = server
    pup = _pup(tmp_path, {"alpha/one.csv": f"{base}/flaky/alpha/one.csv",
                          "alpha/sub/two.bin": f"{base}/alpha/sub/two.bin",
                          "beta/three.txt": f"{base}/truncate/beta/three.txt"})
    lines: list[str] = []
    [alpha] = fetch_datasets(["alpha"], tmp_path / "home", pup=pup, progress=False, echo=lines.append)
    assert alpha.retried == ["alpha/one.csv"] and lines == ["alpha: 0 present, 2 downloaded (1 after a retry)"]
    with pytest.raises(DataMissingError) as info:  # a truncation is retried, within the deadline
        fetch_datasets(["beta"], tmp_path / "home", pup=pup, progress=False)
    assert "(3 attempts, the last: connection ended after 10 of 1000 bytes" in str(info.value)
    refused = _pup(tmp_path, {"alpha/one.csv": f"{base}/status/404/alpha/one.csv"})
    with pytest.raises(DataMissingError, match=r"\(1 attempt: HTTP 404 Not Found\)"):
        fetch_datasets(["alpha"], tmp_path / "elsewhere", pup=refused, progress=False)


def test_the_failure_of_one_file_of_several_says_where_the_fetch_stopped(tmp_path, server):
    base, _ = server
    bad = f"{base}/status/404/alpha/sub/two.bin"
    pup = _pup(tmp_path, {"alpha/one.csv": f"{base}/alpha/one.csv", "alpha/sub/two.bin": bad,
                          "beta/three.txt": f"{base}/beta/three.txt"})
    home = tmp_path / "home"
    with pytest.raises(DataMissingError) as info:  # one at a time: alpha/one.csv is complete before the failure
        fetch_datasets(["beta", "alpha"], home, pup=pup, progress=False, workers=1)
    assert str(info.value) == (f"alpha file sub/two.bin: cannot download from {bad} (1 attempt: HTTP 404 Not "
                               "Found); alpha: 1 of 2 files in place (0 present, 1 downloaded); beta complete; "
                               "a rerun goes on from there")
    assert _files_under(home) == ["alpha/one.csv", "beta/three.txt"]


def test_the_deadline_setting_is_read_once_and_checked(monkeypatch):
    from tzsl.datasets import DEFAULT_FETCH_TIMEOUT_S, FETCH_TIMEOUT_ENV
    from tzsl.datasets._download import fetch_timeout

    monkeypatch.delenv(FETCH_TIMEOUT_ENV, raising=False)
    assert fetch_timeout() == DEFAULT_FETCH_TIMEOUT_S and fetch_timeout(7) == 7
    monkeypatch.setenv(FETCH_TIMEOUT_ENV, "12.5")
    assert fetch_timeout() == 12.5 and fetch_timeout(3) == 3
    for bad in ("soon", "0", "-1", "inf"):
        monkeypatch.setenv(FETCH_TIMEOUT_ENV, bad)
        with pytest.raises(ConfigError, match=rf"^\$TZSL_FETCH_TIMEOUT={bad!r}|^\$TZSL_FETCH_TIMEOUT=-?[0-9a-z]+:"):
            fetch_timeout()
    result = CliRunner().invoke(cli, ["data", "fetch", "--timeout", "0", "--no-progress"])
    assert result.exit_code == 2 and "--timeout" in result.stderr


def _visible_lines(stderr: str) -> list[str]:
    """What a terminal shows of ``stderr``: each line as its last carriage return left it."""
    return [shown for line in stderr.split("\n") if (shown := line.split("\r")[-1].strip())]


@pytest.mark.parametrize("progress", [True, False])
@pytest.mark.parametrize("kind", ["drip", "status/404", "status/500"])
def test_the_command_prints_one_line_per_failure(tmp_path, server, kind, progress):
    """stderr holds the error line only (a progress bar is erased), and pooch logs nothing."""
    base, _ = server
    records: list[logging.LogRecord] = []
    catcher = logging.Handler()
    catcher.emit = records.append  # type: ignore[method-assign]
    pooch.get_logger().addHandler(catcher)
    try:
        result = CliRunner().invoke(cli, ["data", "fetch", "gelsight_press", "--mirror", f"{base}/{kind}",
                                          "--timeout", "1", "--data-dir", str(tmp_path / "home")]
                                    + ([] if progress else ["--no-progress"]))
    finally:
        pooch.get_logger().removeHandler(catcher)
    assert result.exit_code == 3, result.output
    [line] = _visible_lines(result.stderr)
    # several files download at a time: the line names the first that failed, with its own URL
    name = re.match(r"tzsl: error: gelsight_press file ([^ ]+): ", line)[1]  # type: ignore[index]
    url = f"{base}/{kind}/gelsight_press/{name}"
    assert line.startswith(f"tzsl: error: gelsight_press file {name}: "
                           + (f"no complete download within 1 s from {url} (1 attempt: " if kind == "drip" else
                              f"cannot download from {url} (1 attempt: HTTP 404" if kind.endswith("404") else
                              f"no complete download within 1 s from {url} (1 attempt: HTTP 500"))
    assert line.endswith("gelsight_press: 0 of 45 files in place (0 present, 0 downloaded); a rerun goes on from there")
    assert records == [] and result.stdout == ""
    assert _files_under(tmp_path / "home") == []


# --------------------------------------------------------------------------- a killed fetch, another fetch


def test_leftovers_of_a_killed_download_are_removed_by_the_next_fetch(tmp_path, server):
    """pooch's temporaries and tzsl's own (a build killed mid-write) go; files merely named alike stay."""
    from tzsl._io import atomic_write

    base, _ = server
    pup = _registry(tmp_path, base)
    home = tmp_path / "home"
    atomic: list[Path] = []  # the temporary name tzsl's atomic write gives a registered file
    atomic_write(home / "alpha/one.csv", lambda tmp: atomic.append(tmp) or tmp.write_bytes(b"a,"))
    (home / "alpha/one.csv").unlink()
    leftovers = [home / "alpha/tmpab_12cd3", home / "alpha/sub/tmp9x8y7z6w", *atomic]
    kept = [home / "alpha/tmp_notes.txt", home / "alpha/tmpfile", home / "alpha/TMPABCDEFGH",
            home / "alpha/tmpab12cd3e.csv", home / "gamma/tmpab12cd3e", home / "alpha/sub/deeper/tmpab12cd3e",
            home / "alpha/.notes.txt.ab12cd3e.tmp", home / "alpha/.one.csv.ab12cd3e.tmp.bak"]
    for path in leftovers + kept:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(b"half a download")
    (home / "alpha/tmpabcdefgh").mkdir()  # a folder: not a temporary file
    lines: list[str] = []
    [report] = fetch_datasets(["alpha"], home, pup=pup, progress=False, echo=lines.append)
    assert sorted(report.leftovers) == sorted(leftovers) and not any(p.exists() for p in leftovers)
    assert all(p.read_bytes() == b"half a download" for p in kept) and (home / "alpha/tmpabcdefgh").is_dir()
    assert lines == ["alpha: 0 present, 2 downloaded, 3 temporary file(s) of an interrupted download removed"]


_FETCH_SCRIPT = """
import signal, sys, pooch
# A user's Ctrl-C meets Python's own handler. A test run started in the background by a non-interactive shell
# (`pytest ... &`) has SIGINT ignored, and every child inherits that, so the child would never see the signal
# the test sends (seen: both tests timed out in such a run): record what was inherited, then reset it.
print(f"child SIGINT: {signal.getsignal(signal.SIGINT)!r}, "
      f"blocked: {sorted(signal.pthread_sigmask(signal.SIG_BLOCK, []))}",
      file=sys.stderr, flush=True)
signal.signal(signal.SIGINT, signal.default_int_handler)
signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
from tzsl.datasets import fetch_datasets
pup = pooch.create(path=".", base_url="", registry=None)
pup.load_registry(sys.argv[1])
fetch_datasets(["alpha"], sys.argv[2], pup=pup, progress=False, timeout=60)
"""


def _fetch_until_downloading(tmp_path: Path, pup_file: Path, home: Path) -> tuple[subprocess.Popen, Path]:
    """A fetch in a child process, once its temporary file exists in the data home (bounded wait)."""
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2])}
    child = subprocess.Popen([sys.executable, "-c", _FETCH_SCRIPT, str(pup_file), str(home)], env=env,
                             stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    end = time.monotonic() + 60
    while time.monotonic() < end and child.poll() is None:
        found = [p for p in (home / "alpha").glob("tmp*")] if (home / "alpha").is_dir() else []
        if found:
            time.sleep(2 * DRIP_S)  # a few bytes in
            return child, found[0]
        time.sleep(0.05)
    child.kill()
    pytest.fail(f"the child fetch never started downloading: {child.communicate()[1].decode()[-500:]}")


@pytest.mark.slow
def test_a_sigkill_mid_download_leaves_a_leftover_the_next_fetch_removes(tmp_path, server):
    base, _ = server
    _pup(tmp_path, {"alpha/one.csv": f"{base}/drip/alpha/one.csv"})
    home = tmp_path / "home"
    child, leftover = _fetch_until_downloading(tmp_path, tmp_path / "registry.txt", home)
    child.send_signal(signal.SIGKILL)
    child.communicate(timeout=10)
    assert leftover.is_file()  # what the tester saw
    [report] = fetch_datasets(["alpha"], home, pup=_pup(tmp_path, {"alpha/one.csv": f"{base}/alpha/one.csv"}),
                              progress=False)
    assert report.leftovers == [leftover] and _files_under(home) == ["alpha/one.csv"]


@pytest.mark.slow
def test_ctrl_c_mid_download_leaves_no_file(tmp_path, server):
    base, _ = server
    _pup(tmp_path, {"alpha/one.csv": f"{base}/drip/alpha/one.csv"})
    home = tmp_path / "home"
    child, _ = _fetch_until_downloading(tmp_path, tmp_path / "registry.txt", home)
    child.send_signal(signal.SIGINT)
    _, err = child.communicate(timeout=10)
    (tmp_path / "child_stderr.txt").write_bytes(err)
    assert child.returncode != 0 and b"KeyboardInterrupt" in err
    assert _files_under(home) == []


@pytest.mark.slow
def test_ctrl_c_during_several_downloads_stops_them_all_at_once_and_leaves_no_file(tmp_path, server):
    base, _ = server
    _pup(tmp_path, {"alpha/one.csv": f"{base}/drip/alpha/one.csv",
                    "alpha/sub/two.bin": f"{base}/drip/alpha/sub/two.bin"})  # two threads, both dripping
    home = tmp_path / "home"
    child, _ = _fetch_until_downloading(tmp_path, tmp_path / "registry.txt", home)
    start = time.monotonic()
    child.send_signal(signal.SIGINT)
    _, err = child.communicate(timeout=10)  # not the drips' 60 s deadline
    (tmp_path / "child_stderr.txt").write_bytes(err)
    assert time.monotonic() - start < 5 and child.returncode != 0 and b"KeyboardInterrupt" in err
    assert _files_under(home) == []


def test_a_second_fetch_into_the_same_data_home_waits_for_the_first(tmp_path, server):
    from tzsl.datasets._download import fetch_lock

    base, _ = server
    pup = _registry(tmp_path, base)
    home = tmp_path / "home"
    lines: list[str] = []
    done = threading.Event()
    with fetch_lock(home):
        second = threading.Thread(target=lambda: fetch_datasets(["beta"], home, pup=pup, progress=False,
                                                                echo=lines.append) and done.set(), daemon=True)
        second.start()
        end = time.monotonic() + 10
        while not lines and time.monotonic() < end:
            time.sleep(0.05)
        time.sleep(0.2)
        assert not done.is_set() and lines == [f"another fetch is writing to {home}: waiting for it to end"]
    second.join(timeout=10)
    assert done.is_set() and lines[1] == "beta: 0 present, 1 downloaded, 1 not downloadable (no public URL; " \
                                         "see data/README.md)"


@pytest.mark.slow
@pytest.mark.parametrize("args", [["--timeout", "1"], ["--no-progress"]])
def test_the_installed_command_prints_one_line_on_a_real_stderr(tmp_path, server, args):
    """In a process of its own (pooch's log handler writes to the stderr of the process), one line:
    the deadline with a progress bar (erased), three HTTP 500 answers without one."""
    base, _ = server
    kind = "drip" if "--timeout" in args else "status/500"
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2])}
    env.pop("TZSL_FETCH_TIMEOUT", None)
    done = subprocess.run([sys.executable, "-c", "from tzsl.cli import main; main()", "data", "fetch", "gelsight_press",
                           "--mirror", f"{base}/{kind}", "--data-dir", str(tmp_path / "home"), *args],
                          env=env, capture_output=True, timeout=120)  # bytes: text mode turns \r into \n
    assert done.returncode == 3 and done.stdout == b""
    [line] = _visible_lines(done.stderr.decode())
    assert re.match(r"tzsl: error: gelsight_press file [^ ]+: "
                    + ("no complete download within 1 s" if kind == "drip" else "cannot download"), line), line
    assert kind == "drip" or "(3 attempts, the last: HTTP 500 Internal Server Error)" in line
    assert _files_under(tmp_path / "home") == []


def test_a_refused_connection_is_named_in_a_few_words(tmp_path):
    import socket

    with socket.socket() as probe:  # a loopback port nobody listens on
        probe.bind(("127.0.0.1", 0))
        url = f"http://127.0.0.1:{probe.getsockname()[1]}/alpha/one.csv"
    with pytest.raises(DataMissingError) as info:
        fetch_datasets(["alpha"], tmp_path / "home", pup=_pup(tmp_path, {"alpha/one.csv": url}), progress=False,
                       timeout=2)
    assert re.match(re.escape(f"alpha file one.csv: no complete download within 2 s from {url} (2 attempts, the last: "
                              "ConnectionError: Failed to establish a new connection: [Errno ") + r"\d+\] Connection "
                    r"refused\);", str(info.value)), str(info.value)
