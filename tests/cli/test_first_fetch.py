"""First use: ``tzsl reproduce-tables`` / ``evidence`` / ``run`` fetch the registered files their studies read
that are missing, before the first study (issue 33, deliverable 1), against a loopback server (never the network).

The study is a plug-in study kind registered by the test (one table of the sizes of the files it reads through
the registry's verifier), so a run takes a fraction of a second; the registry is a small one of fake files with
their right hashes, served on 127.0.0.1.
"""

from __future__ import annotations

import errno
import hashlib
import re
import socket
from pathlib import Path
from typing import Literal

import pandas as pd
import pytest
from click.testing import CliRunner
from pydantic import Field

from tests.datasets.fetch_server import registry_of, serve_folder
from tzsl.cli import cli
from tzsl.studies.config import Compute, Output, register_study, unregister_study
from tzsl.studies.config._common import Section
from tzsl.studies.outputs.study_run import StudyRun

PLUGIN = "fetch-test"
#: The fake registry dataset "alpha" the plug-in study reads (``builtin = "alpha"``: every file of the folder).
FILES = {"alpha/one.csv": b"a,b\n1,2\n", "alpha/sub/two.bin": bytes(range(200)) * 50}


class FetchDataset(Section):
    builtin: str = "alpha"
    data_dir: str | None = None


class FetchStudy(Section):
    """A study that reads the registered files of its ``[dataset] builtin``."""

    study: Literal["fetch-test"] = PLUGIN
    description: str = ""
    dataset: FetchDataset = Field(default_factory=FetchDataset)
    compute: Compute = Field(default_factory=Compute)
    output: Output = Field(default_factory=Output)


def run_fetch_test(exp, results, say) -> StudyRun:
    """Reads every registered file of the dataset through the registry (hash-checked), writes their sizes."""
    from tzsl.datasets import builtin_data_files, fetch

    ds = exp.config.dataset
    paths = [fetch(rel, exp.resolve(ds.data_dir)) for rel in builtin_data_files(ds.builtin)]
    table = pd.DataFrame({"file": [p.name for p in paths], "bytes": [p.stat().st_size for p in paths]})
    results.write_csv("sizes.csv", table)
    return StudyRun({"sizes": table}, {"study_kind": PLUGIN}, data_files=[str(p) for p in paths])


@pytest.fixture
def setup(tmp_path, monkeypatch):
    """The plug-in study in an experiment file, the served files and tzsl's registry replaced by theirs;
    yields (experiment file, data home, served folder, base URL, requested paths)."""
    import tzsl.datasets._fetch as fetch_module
    import tzsl.datasets._registry as registry_module

    register_study(PLUGIN, schema=FetchStudy, runner=f"{__name__}:run_fetch_test", main_table="sizes",
                   description="reads the files of a registry folder")
    served = tmp_path / "served"
    for name, content in FILES.items():
        (served / name).parent.mkdir(parents=True, exist_ok=True)
        (served / name).write_bytes(content)
    experiment = tmp_path / "fetch_test.toml"
    experiment.write_text(f'study = "{PLUGIN}"\n[dataset]\nbuiltin = "alpha"\n')
    monkeypatch.delenv("TZSL_DATA_MIRROR", raising=False)
    try:
        with serve_folder(served) as (base, requested):
            pup = registry_of(tmp_path / "registry.txt", [f"{name} sha256:{hashlib.sha256(content).hexdigest()} "
                                                          f"{base}/{name}" for name, content in FILES.items()])
            monkeypatch.setattr(registry_module, "registry", lambda: pup)
            monkeypatch.setattr(fetch_module, "registry", lambda: pup)
            registry_module.clear_verification_cache()
            (tmp_path / "home").mkdir()  # --data-dir names an existing folder (checked before any fetch)
            yield experiment, tmp_path / "home", served, base, requested
    finally:
        unregister_study(PLUGIN)
        registry_module.clear_verification_cache()


def _invoke(*args: str):
    return CliRunner().invoke(cli, list(args))


def _files_under(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file()) if folder.exists() else []


@pytest.mark.parametrize("command", ["reproduce-tables", "evidence"])
def test_an_empty_data_home_is_fetched_then_the_study_runs_and_a_rerun_makes_no_request(setup, tmp_path, command):
    experiment, home, _, _, requested = setup
    out = tmp_path / "results"
    args = (command, "--study", str(experiment), "--out", str(out), "--data-dir", str(home), "--no-progress")
    result = _invoke(*args)
    assert result.exit_code == 0, result.output
    lines = result.stdout.splitlines()
    assert lines[0] == (f"first use: fetching 2 data files of alpha for {experiment} into {home}, from their "
                        "public URLs (--no-fetch: stop instead)")
    assert lines[1] == "alpha: 0 present, 2 downloaded"
    assert lines.index(f"== {experiment} ({experiment}) ==") > 1  # the fetch came before the first study
    assert sorted(requested) == ["/alpha/one.csv", "/alpha/sub/two.bin"]
    assert {name: (home / name).read_bytes() for name in FILES} == FILES
    sizes = pd.read_csv(out / "sizes.csv")
    assert sizes["bytes"].tolist() == [len(content) for content in FILES.values()]
    assert (out / "manifest.json").is_file()
    again = _invoke(*args, "--force")
    assert again.exit_code == 0, again.output
    assert "first use" not in again.stdout and len(requested) == 2  # present files: no request at all


def test_tzsl_run_fetches_first_too_and_no_fetch_gives_the_missing_file_error(setup, tmp_path):
    experiment, home, _, _, requested = setup
    refused = _invoke("run", str(experiment), "--out", str(tmp_path / "a"), "--data-dir", str(home), "--no-fetch")
    assert refused.exit_code == 3 and requested == []
    [line] = refused.stderr.strip().splitlines()
    assert line.startswith(f"tzsl: error: {home / 'alpha/one.csv'}: dataset file 'alpha/one.csv' is missing: "
                           "get it with `tzsl data fetch alpha`")
    listed = _invoke("reproduce-tables", "--study", str(experiment), "--out", str(tmp_path / "b"), "--data-dir",
                     str(home), "--no-fetch")
    assert listed.exit_code == 3 and requested == [] and listed.stderr.strip().splitlines() == [line]
    done = _invoke("run", str(experiment), "--out", str(tmp_path / "c"), "--data-dir", str(home), "--no-progress")
    assert done.exit_code == 0, done.output
    assert done.stdout.startswith("first use: fetching 2 data files of alpha") and len(requested) == 2
    assert (tmp_path / "c" / "sizes.csv").is_file()


def test_a_wrong_hash_stops_before_the_first_study_in_one_line_and_keeps_nothing(setup, tmp_path, monkeypatch):
    experiment, home, served, base, _ = setup
    (served / "alpha/sub/two.bin").write_bytes(b"another version")
    monkeypatch.setenv("TZSL_FETCH_WORKERS", "1")  # one at a time: alpha/one.csv is in place before the failure
    out = tmp_path / "results"
    result = _invoke("reproduce-tables", "--study", str(experiment), "--out", str(out), "--data-dir", str(home))
    assert result.exit_code == 3, result.output
    [line] = [shown for text in result.stderr.split("\n") if (shown := text.split("\r")[-1].strip())]
    assert line.startswith(f"tzsl: error: fetching the data of {experiment}: alpha file sub/two.bin: ")
    assert f"(downloaded from {base}/alpha/sub/two.bin; not kept)" in line
    assert line.endswith("alpha: 1 of 2 files in place (0 present, 1 downloaded); a rerun goes on from there; see "
                         "`tzsl data fetch --help` for a mirror or a longer deadline")
    assert _files_under(home) == ["alpha/one.csv"]  # the good file stays; nothing half-written
    assert "==" not in result.stdout and not (out / "manifest.json").exists()  # no study started


def test_no_network_stops_in_one_line_naming_the_file(setup, tmp_path, monkeypatch):
    experiment, home, _, _, _ = setup
    with socket.socket() as probe:  # a loopback port nobody listens on
        probe.bind(("127.0.0.1", 0))
        closed = f"http://127.0.0.1:{probe.getsockname()[1]}"
    monkeypatch.setenv("TZSL_DATA_MIRROR", closed)
    monkeypatch.setenv("TZSL_FETCH_TIMEOUT", "1")
    result = _invoke("run", str(experiment), "--out", str(tmp_path / "r"), "--data-dir", str(home), "--no-progress")
    assert result.exit_code == 3, result.output
    assert result.stdout.splitlines() == [f"first use: fetching 2 data files of alpha for {experiment} into {home}, "
                                          f"from {closed} (--no-fetch: stop instead)"]
    [line] = result.stderr.strip().splitlines()  # both files fail at once: the line names the first that did
    assert re.match(re.escape(f"tzsl: error: fetching the data of {experiment}: alpha file ")
                    + r"(one\.csv|sub/two\.bin)"
                    + re.escape(f": no complete download within 1 s from {closed}/alpha/") + r"\1 \(", line), line
    assert "Connection refused" in line and _files_under(home) == []


def test_a_full_disk_stops_in_one_line_and_leaves_no_temporary_file(setup, tmp_path, monkeypatch):
    from tzsl.datasets._download import DeadlineDownloader

    experiment, home, _, _, _ = setup

    def fill_the_disk(self, url: str, output_file: str, pup=None) -> None:
        with open(output_file, "wb") as out:
            out.write(b"half")
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(DeadlineDownloader, "__call__", fill_the_disk)
    result = _invoke("run", str(experiment), "--out", str(tmp_path / "r"), "--data-dir", str(home), "--no-progress")
    assert result.exit_code == 3, result.output
    [line] = result.stderr.strip().splitlines()
    assert re.match(re.escape(f"tzsl: error: fetching the data of {experiment}: alpha file ")
                    + r"(one\.csv|sub/two\.bin): cannot download from ", line), line
    assert "OSError: [Errno 28] No space left on device" in line
    assert _files_under(home) == []
