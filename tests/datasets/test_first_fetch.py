"""What a study's first use fetches: the registered files of its built-in dataset (decided from its config),
their sizes, and a real fetch of phac2-dap's files from a loopback mirror of the shared data (never the network).
The command-line side (reproduce-tables, evidence, run, --no-fetch, the error lines) is tests/cli/test_first_fetch.py.
"""

from __future__ import annotations

from pathlib import Path

import pytest

import tzsl.datasets
from tests.datasets.biotac_slide_release import catalog_files
from tests.datasets.fetch_server import serve_folder
from tzsl.datasets import builtin_data_files, fetch_missing, registered_files
from tzsl.datasets._registry import registered_size
from tzsl.studies.reproduce import EVIDENCE_STUDIES, REPRODUCE_STUDIES, fetch_study_data, reproduce_experiments

PENN = "phac2/penn_bolt_ml_data/static_adjective_phase_set/"
LABELS = "phac2/derived/phac2_labels_60x24.csv"


def test_each_builtin_dataset_names_the_registered_files_it_reads():
    penn = builtin_data_files("phac2-penn")
    assert penn == sorted(registered_files(PENN) + [LABELS]) and len(penn) == 97
    assert builtin_data_files("phac2-hold-mat") == sorted(registered_files("phac2/imperial_cvpr2021_hold/") + [LABELS])
    assert builtin_data_files("phac2-h5") == [LABELS]  # the release itself is the user's file
    depth = builtin_data_files("fabric-depth")
    assert depth == sorted(registered_files("fabric/depth224/") + ["fabric/a8.npy", "fabric/fabric_groups.csv"])
    assert builtin_data_files("fabric") == registered_files("fabric/")  # a registry folder: all of it
    assert set(depth) < set(builtin_data_files("fabric"))
    assert builtin_data_files("hand-simulated") == [] and builtin_data_files("my-own-data") == []


def _wanted(studies, tmp_path, monkeypatch) -> list[tuple[list[str], Path, str]]:
    calls = []
    monkeypatch.setattr(tzsl.datasets, "fetch_missing", lambda files, home, **kw: calls.append(
        (files, home, kw["needed_by"])))
    fetch_study_data(reproduce_experiments(studies, data_dir=str(tmp_path)), studies)
    return calls


def test_the_study_lists_fetch_what_their_configs_read(tmp_path, monkeypatch):
    assert _wanted(REPRODUCE_STUDIES, tmp_path, monkeypatch) == [
        (sorted(set(builtin_data_files("phac2-penn")) | set(registered_files("fabric/"))), tmp_path,
         "phac2-dap, fabric")]  # hand-simulated reads no registered file
    [(files, home, needed_by)] = _wanted(EVIDENCE_STUDIES, tmp_path, monkeypatch)
    assert needed_by == "phac2-evidence, fabric-evidence, active-touch, phac2-headlines" and home == tmp_path
    assert _wanted(("hand-simulated",), tmp_path, monkeypatch) == []


def test_every_registered_file_has_its_size_and_the_sizes_are_the_shared_datas(data_dir):
    every = registered_files()
    sizes = {relpath: registered_size(relpath) for relpath in every}
    assert None not in sizes.values()
    catalog = set(catalog_files())  # read once: the catalog's files are not in the shared data
    shared = {r: s for r, s in sizes.items() if r not in catalog}
    assert len(shared) < len(sizes)
    wrong = {r: (s, (data_dir / r).stat().st_size) for r, s in shared.items() if (data_dir / r).stat().st_size != s}
    assert wrong == {}


def test_phac2_dap_files_are_fetched_from_a_mirror_and_the_label_table_is_built(data_dir, tmp_path, monkeypatch):
    """The real registry and the real Penn pickles, served on 127.0.0.1 without the label table (so it is built
    from them, hash-checked); then the study's reader loads the home, and a second call makes no request."""
    from tzsl.datasets import load_phac2_penn

    served = tmp_path / "served"
    (served / PENN).parent.mkdir(parents=True)
    (served / PENN).symlink_to(data_dir / PENN, target_is_directory=True)
    home = tmp_path / "home"
    lines: list[str] = []
    with serve_folder(served) as (base, requested):
        monkeypatch.setenv("TZSL_DATA_MIRROR", base)
        [report] = fetch_missing(builtin_data_files("phac2-penn"), home, needed_by="phac2-dap", progress=False,
                                 echo=lines.append)
        assert len(requested) == 96 + 1  # the pickles, then the label table the mirror does not hold
        assert fetch_missing(builtin_data_files("phac2-penn"), home, echo=lines.append) == []
        assert len(requested) == 97
    size = sum(registered_size(r) for r in builtin_data_files("phac2-penn")) / 1e6
    assert lines == [f"first use: fetching 97 data files of phac2 ({size:.1f} MB) for phac2-dap into {home}, from "
                     f"{base} (--no-fetch: stop instead)", "phac2: 0 present, 96 downloaded, 1 built from them"]
    assert report.built == [LABELS]
    assert load_phac2_penn(home).X.shape == load_phac2_penn(data_dir).X.shape


@pytest.mark.parametrize("present", [[LABELS], []])
def test_a_missing_built_file_brings_the_files_it_is_built_from(tmp_path, monkeypatch, present):
    """Only a missing label table pulls in the Penn pickles (built from them); a present one does not."""
    calls = []
    monkeypatch.setattr(tzsl.datasets._fetch, "fetch_datasets", lambda names, home, **kw: calls.append(
        (names, sorted(kw["files"]))) or [])
    for relpath in present:
        (tmp_path / relpath).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / relpath).write_text("x")
    fetch_missing([LABELS], tmp_path)
    assert calls == ([] if present else [(["phac2"], sorted(registered_files(PENN) + [LABELS]))])
