"""``tzsl data fetch`` against a local HTTP server serving a small registry (never the network)."""

from __future__ import annotations

import functools
import hashlib
import http.server
import threading
from pathlib import Path

import pooch
import pytest
from click.testing import CliRunner

from tzsl.cli import cli

from tzsl.datasets import fetch_datasets, registered_datasets
from tzsl.exceptions import ChecksumError, ConfigError

FILES = {"alpha/one.csv": b"a,b\n1,2\n", "alpha/sub/two.bin": bytes(range(200)) * 50, "beta/three.txt": b"three\n"}


@pytest.fixture
def server(tmp_path):
    """A loopback HTTP server over a folder; yields (base URL, folder). Stops by itself."""
    root = tmp_path / "served"
    for name, content in FILES.items():
        (root / name).parent.mkdir(parents=True, exist_ok=True)
        (root / name).write_bytes(content)
    handler = functools.partial(http.server.SimpleHTTPRequestHandler, directory=str(root))
    handler.log_message = lambda *args: None
    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=httpd.serve_forever, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{httpd.server_address[1]}", root
    httpd.shutdown()
    httpd.server_close()


def _registry(tmp_path: Path, base: str, *, urls: bool = True) -> pooch.Pooch:
    lines = [f"{name} sha256:{hashlib.sha256(content).hexdigest()}" + (f" {base}/{name}" if urls else "")
             for name, content in FILES.items()]
    lines.append("beta/local.csv sha256:" + "0" * 64)  # built locally: no URL
    path = tmp_path / "registry.txt"
    path.write_text("\n".join(lines) + "\n")
    pup = pooch.create(path=".", base_url="", registry=None)
    pup.load_registry(str(path))
    return pup


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
    from tzsl.datasets import fetch  # noqa: PLC0415
    from tzsl.exceptions import DataMissingError  # noqa: PLC0415

    with pytest.raises(DataMissingError, match=r"get it with `tzsl data fetch phac2`"):
        fetch("phac2/derived/phac2_labels_60x24.csv", tmp_path)


def test_the_penn_label_table_is_rebuilt_byte_for_byte_from_the_pickles(data_dir):
    """The one locally built file phac2-penn needs: fetch builds it, identical to the registered one."""
    from tzsl.datasets import fetch, registered_files  # noqa: PLC0415
    from tzsl.datasets._phac2_penn import PENN_STATIC_DIR, labels_csv_bytes, read_penn_static_pickles  # noqa: PLC0415
    from tzsl.datasets._registry import registered_hash  # noqa: PLC0415

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
    from tzsl.datasets._fabric import fabric_groups_csv_bytes  # noqa: PLC0415
    from tzsl.exceptions import DataFileError  # noqa: PLC0415

    assert fabric_groups_csv_bytes(DATA2) == GROUPS_CSV
    for bad in ("no groups here", DATA2.replace("[3]", "[3, 4]"), DATA2.replace("[3]", "[__import__]")):
        with pytest.raises(DataFileError) as info:
            fabric_groups_csv_bytes(bad, origin="Data2.py")
        assert str(info.value).startswith("Data2.py: ") and len(str(info.value).splitlines()) == 1


def test_fetch_builds_fabric_groups_and_leaves_reference_copies_out(tmp_path):
    from tzsl.datasets import REFERENCE_ONLY  # noqa: PLC0415

    served = tmp_path / "served"
    (served / "fabric/sources").mkdir(parents=True)
    (served / "fabric/sources/Data2.py").write_text(DATA2)
    handler = functools.partial(http.server.SimpleHTTPRequestHandler, directory=str(served))
    handler.log_message = lambda *args: None
    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    threading.Thread(target=httpd.serve_forever, daemon=True).start()
    try:
        base = f"http://127.0.0.1:{httpd.server_address[1]}"
        reference = sorted(REFERENCE_ONLY)[0]
        lines = [
                 f"fabric/fabric_groups.csv sha256:{hashlib.sha256(GROUPS_CSV).hexdigest()}",
                 f"{reference} sha256:{'0' * 64}"]
        (tmp_path / "registry.txt").write_text("\n".join(lines) + "\n")
        pup = pooch.create(path=".", base_url="", registry=None)
        pup.load_registry(str(tmp_path / "registry.txt"))
        home = tmp_path / "home"
        sources = {"fabric/fabric_groups.csv": {"fabric/sources/Data2.py": (
            f"sha256:{hashlib.sha256(DATA2.encode()).hexdigest()}", f"{base}/fabric/sources/Data2.py")}}
        fabric, phac2 = fetch_datasets([], home, pup=pup, progress=False, build_sources=sources)
    finally:
        httpd.shutdown()
        httpd.server_close()
    assert fabric.built == ["fabric/fabric_groups.csv"] and (home / "fabric/sources/Data2.py").read_text() == DATA2
    assert (home / "fabric/fabric_groups.csv").read_bytes() == GROUPS_CSV
    assert phac2.reference == [reference] and phac2.missing == []
    assert "no study reads them" in phac2.line()
