"""The papers' numbers do not move with the last bit, or their table says that they can (issue 41).

``tzsl reproduce-tables`` runs three times on the real data: as shipped, then with every study's
features multiplied by ``1 + 1e-12 * u`` (``u`` uniform in [-1, 1], seeded) under one BLAS thread, and
again (another draw of ``u``) under two BLAS threads; numbers that agree to a relative 1e-4 are the same
(:data:`RELATIVE_DIGITS`). In the suite (so in CI) the three runs hold the
PHAC-2 and hand studies (:data:`STABLE_STUDIES`); ``make test-last-bit`` adds the fabric study to the
reference and the one-thread run. Every number of every paper CSV must be the same as written (the CSVs'
own float format), but the wall-clock columns, unless its row's ``note`` says that it can move with the
last bit (:data:`tzsl.models.protocol.LAST_BIT_NOTE`: a choice scored by a count, which the fabric
study's ESZSL and embedding searches make). A number a last bit could move would make the README
irreproducible on another machine (another CPU's BLAS kernels round differently), so it must say so
(docs/user_guide/reproducing.md#numbers-a-last-bit-can-move).

The features are perturbed where each study receives them, in the parent process (the fits in the
workers see the perturbed arrays): PHAC-2's Penn feature set, the fabric descriptors of both
conditions, and the hand study's grasp features of each simulated seed. The study cache is off and
the fit store is a fresh folder, so nothing of the unperturbed run is reused.
"""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from threadpoolctl import threadpool_limits

from tzsl.models.protocol import LAST_BIT_NOTE
from tzsl.studies.reproduce import REPRODUCE_STUDIES, reproduce_tables

pytestmark = [pytest.mark.slow, pytest.mark.realdata]

#: Relative size of the perturbation.
RELATIVE = 1e-12
#: Columns that hold wall-clock time, not results.
TIMING_COLUMNS = ("fit_seconds",)


def perturbed(value, rng: np.random.Generator):
    """``value`` with every float array (at any depth of dataclasses, dicts, lists, tuples) times ``1 + 1e-12 u``."""
    if isinstance(value, np.ndarray) and np.issubdtype(value.dtype, np.floating):
        return value * (1.0 + RELATIVE * rng.uniform(-1.0, 1.0, size=value.shape))
    if isinstance(value, pd.DataFrame):
        out = value.copy()
        for column in out.columns[[pd.api.types.is_float_dtype(t) for t in out.dtypes]]:
            out[column] = perturbed(out[column].to_numpy(), rng)
        return out
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        changes = {f.name: perturbed(getattr(value, f.name), rng) for f in dataclasses.fields(value) if f.init}
        return dataclasses.replace(value, **changes)
    if isinstance(value, tuple):
        return tuple(perturbed(v, rng) for v in value)
    if isinstance(value, list):
        return [perturbed(v, rng) for v in value]
    if isinstance(value, dict):
        return {k: perturbed(v, rng) for k, v in value.items()}
    return value


def perturb_features(monkeypatch: pytest.MonkeyPatch, seed: int) -> None:
    """Perturb the features each paper study is handed (see the module docstring)."""
    import tzsl.features._dataset_features as dataset_features
    import tzsl.studies.fabric.study as fabric_study
    import tzsl.studies.hand.study as hand_study

    rng = np.random.default_rng(seed)

    def wrap(module, name):
        original = getattr(module, name)
        monkeypatch.setattr(module, name, lambda *a, **k: perturbed(original(*a, **k), rng))

    wrap(dataset_features, "penn_feature_set")
    wrap(fabric_study, "depth_samples")
    wrap(hand_study, "hand_features")


def paper_csvs(folder: Path) -> dict[str, pd.DataFrame]:
    """Every CSV of a reproduce-tables folder, as written (strings), without the wall-clock columns."""
    tables = {}
    for path in sorted(folder.glob("*.csv")):
        table = pd.read_csv(path, dtype=str, keep_default_na=False)
        tables[path.name] = table.drop(columns=[c for c in TIMING_COLUMNS if c in table.columns])
    return tables


#: Two numbers as written that agree to this relative difference are the same: a published number shows three
#: decimals, and a choice or a prediction that flips moves an accuracy by a whole trial, far more; an iterative
#: solver's stopping tolerance (the Platt sigmoids behind the hand study's attribute distances) moves a
#: posterior's sixth digit.
RELATIVE_DIGITS = 1e-4


def same_to_digits(a: str, b: str) -> bool:
    """Whether two CSV cells are numbers equal to :data:`RELATIVE_DIGITS` (text cells must be equal)."""
    try:
        x, y = float(a), float(b)
    except ValueError:
        return False
    return bool(np.isfinite(x) and np.isfinite(y) and abs(x - y) <= RELATIVE_DIGITS * max(abs(x), abs(y)))


def differences(reference: dict[str, pd.DataFrame], other: dict[str, pd.DataFrame]) -> list[tuple[str, str, bool]]:
    """``(file, "column row k: a -> b", flagged)`` per cell that differs, and per file or shape that does.

    ``flagged``: the reference row's ``note`` says that its numbers can move with the last bit.
    """
    out = [(name, "missing", False) for name in reference if name not in other]
    for name, table in reference.items():
        if name not in other:
            continue
        theirs = other[name]
        if table.shape != theirs.shape or list(table.columns) != list(theirs.columns):
            out.append((name, f"shape {table.shape} -> {theirs.shape}", False))
            continue
        notes = table["note"] if "note" in table.columns else pd.Series("", index=table.index)
        flagged = notes.str.contains(LAST_BIT_NOTE, regex=False).to_numpy()
        unequal = [(i, j) for i, j in np.argwhere(table.to_numpy() != theirs.to_numpy())
                   if not same_to_digits(table.iat[i, j], theirs.iat[i, j])]
        out += [(name, f"{table.columns[j]} row {i}: {table.iat[i, j]} -> {theirs.iat[i, j]}", bool(flagged[i]))
                for i, j in unequal]
    return out


#: The studies whose numbers never move (no row says it can): every run of the test in the suite.
STABLE_STUDIES = ("phac2-dap", "hand-simulated")
#: ``make test-last-bit`` (this variable set): every paper study, the fabric study in the reference and the
#: one-thread run (it checks that every fabric number from a fit says it can move and nothing else moves).
ALL_STUDIES_ENV = "TZSL_LAST_BIT_ALL"
#: Set (to anything but 0) to run the test on the stable studies only; ``make test-last-bit`` sets ALL_STUDIES_ENV.
#: Without either, the test is skipped: its three reproduce-tables cost about five minutes of one CI worker,
#: more than the suite's time allows (CI runs under a quarter of an hour).
STABLE_STUDIES_ENV = "TZSL_LAST_BIT"


def run(out: Path, n_jobs: int, studies: tuple[str, ...] = REPRODUCE_STUDIES) -> dict[str, pd.DataFrame]:
    reproduce_tables(out, force=True, n_jobs=n_jobs, progress=False, studies=studies)
    return paper_csvs(out)


@pytest.fixture
def isolated_caches(tmp_path, monkeypatch, data_dir):
    """A fresh fit store and texture cache, the study cache off, the real data."""
    monkeypatch.setenv("TZSL_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setenv("TZSL_STUDY_CACHE", "0")
    monkeypatch.setenv("TZSL_DATA_DIR", str(data_dir))
    return tmp_path


def test_every_paper_number_survives_a_last_bit_perturbation_and_the_blas_thread_count(isolated_caches, monkeypatch):
    """``TZSL_LAST_BIT=1``: PHAC-2 and the hand study, three runs; ``make test-last-bit``: the fabric study too.

    The fabric study is most of reproduce-tables' cost and every number its tables compute from a fit says
    that it can move. The suite skips the test unless one of the two variables is set (CI's time).
    """
    everything = os.environ.get(ALL_STUDIES_ENV, "").strip() not in ("", "0")
    if not everything and os.environ.get(STABLE_STUDIES_ENV, "").strip() in ("", "0"):
        pytest.skip("three reproduce-tables runs: make test-last-bit (or TZSL_LAST_BIT=1 for PHAC-2 and hand only)")
    first = REPRODUCE_STUDIES if everything else STABLE_STUDIES
    reference = run(isolated_caches / "reference", n_jobs=2, studies=first)
    assert {"table1_fusion.csv", "hand_table5.csv"} <= set(reference)
    assert ("fabric_table1.csv" in reference) == everything
    flagged_files = {name for name, table in reference.items()
                     if "note" in table.columns and table["note"].str.contains(LAST_BIT_NOTE, regex=False).any()}
    assert flagged_files == ({"fabric_table1.csv", "fabric_runs.csv", "fabric_method_comparison.csv"}
                             if everything else set())  # PHAC-2 and hand promise it
    moved = {}
    for threads, seed, studies in ((1, 1, first), (2, 2, STABLE_STUDIES)):
        with monkeypatch.context() as patch, threadpool_limits(threads):
            perturb_features(patch, seed)
            other = run(isolated_caches / f"perturbed_{threads}", n_jobs=1, studies=studies)
        compared = {name: table for name, table in reference.items() if name in other or studies == first}
        assert len(compared) > 10
        moved[threads] = [f"{name}: {what}" for name, what, flagged in differences(compared, other) if not flagged]
    assert moved == {1: [], 2: []}, "\n".join(f"{t} BLAS thread(s): {d}" for t, ds in moved.items() for d in ds)
