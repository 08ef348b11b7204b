"""``tzsl report RESULTS_DIR``: one self-contained HTML page of a results folder.

The report of a **generic study** (a lab's dataset run with ``study = "zero-shot"``) opens with the
dataset's name and card (what ``tzsl validate`` knows: classes, attributes, trials, sensors;
:mod:`tzsl.reporting.summary`), then a summary: the most accurate method against chance and the
trivial baseline with intervals, whether any method's interval clears chance, what the run
relaxed to fit the dataset and the method it would deploy (:mod:`tzsl.reporting.deployment`). Its
sections are named for what they show (:data:`SECTIONS`), and no paper heading, paper text or paper
number appears.

The report of the **paper studies** (``tzsl reproduce-tables``, the presets ``phac2-dap``,
``fabric``, ``hand``) is organised by the papers' tables and figures, each accuracy shown as
``ours (ci95 low-high) [paper]``, and a "Deviations from the paper" section is generated from the
manifests (features, split rules, tuning, grids, simulated data).
:mod:`tzsl.reporting.manifests` tells the two apart.

Either way: each section says what was run (counts read from its tables), shows its tables -
a wide table its key columns, the rest behind a toggle (:mod:`tzsl.reporting.tables`) - with the
figure beside them, and the best method per split kind with its paired difference as evidence
(:mod:`tzsl.reporting.best_method`); where a method's calibrated posterior equals its uncalibrated
one, the calibration section says calibration was skipped. Results from simulated data carry a
SIMULATED banner. Tables and figures the sections do not name follow under "Other results", so
nothing in the folder is left out; provenance (versions, data checksums, outputs, the full
manifests, collapsible) closes the page.

The page is rendered with jinja2 from ``templates/report.html.j2`` (autoescaped), embeds figures
as base64 ``data:`` URIs, and needs no other file, script or network: it can be mailed or archived
as it is. It is written atomically.
"""

from __future__ import annotations

import base64
import os
from collections.abc import Sequence
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import jinja2
import pandas as pd

from tzsl._io import atomic_write
from tzsl.evaluation import INTERVAL_DOC
from tzsl.exceptions import ConfigError, DataFileError
from tzsl.reporting.best_method import findings
from tzsl.reporting.deployment import deploy_choice, deployment_lines
from tzsl.reporting.manifests import (
    config_items,
    dataset_names,
    deviations,
    is_paper_record,
    read_manifest,
    relaxations,
    study_records,
)
from tzsl.reporting.sections import SECTIONS, Section, fill, table_facts
from tzsl.reporting.summary import dataset_card_items, headline
from tzsl.reporting.tables import read_table, table_entry

__all__ = ["REPORT_FILE", "collect_results", "render_report", "write_report"]

#: Default report file name inside the results folder.
REPORT_FILE = "report.html"


def collect_results(folder: str | os.PathLike, exclude: Sequence[Path] = ()) -> dict[str, list[Path]]:
    """The CSV tables, PNG figures and manifests of a results folder (recursive, hidden skipped).

    Returns
    -------
    dict with keys ``"csv"``, ``"png"``, ``"manifest"``: lists of paths sorted by relative path.
    """
    root = Path(folder)
    skip = {Path(p).resolve() for p in exclude}
    found: dict[str, list[Path]] = {"csv": [], "png": [], "manifest": []}
    for path in sorted(root.rglob("*")):
        rel = path.relative_to(root)
        if any(part.startswith(".") for part in rel.parts) or not path.is_file() or path.resolve() in skip:
            continue
        suffix = path.suffix.lower()
        if suffix == ".csv":
            found["csv"].append(path)
        elif suffix == ".png":
            found["png"].append(path)
        elif suffix == ".json" and "manifest" in path.name:
            found["manifest"].append(path)
    return found


def _environment() -> jinja2.Environment:
    env = jinja2.Environment(
        loader=jinja2.PackageLoader("tzsl.reporting", "templates"),
        autoescape=True, undefined=jinja2.StrictUndefined, trim_blocks=True, lstrip_blocks=True,
    )
    # headers like n_test_objects may break after an underscore (zero-width space), not mid-word
    env.filters["breakable"] = lambda text: str(text).replace("_", "_\u200b")
    return env


def _figure_entry(path: Path, root: Path) -> dict[str, str]:
    return {"name": str(path.relative_to(root)), "src": "data:image/png;base64,"
            + base64.b64encode(path.read_bytes()).decode("ascii")}


def _is_simulated_section(section: Section, tables: list[dict], manifests: dict[str, dict]) -> bool:
    if any(t["simulated"] for t in tables):
        return True
    if not section.simulated:
        return False
    configs = {n: config_items(m.get("config") or {}) for n, m in manifests.items()}
    flags = [c.get("simulated") for n, c in configs.items() if "hand" in n]
    flags += [c.get("hand_data") == "simulated" for c in configs.values() if "hand_data" in c]
    return not flags or any(flag is True for flag in flags)


def _blocks(tables: list[dict], stems: list[str], figure_stems: list[str], png_by_stem: dict[str, Path],
            root: Path) -> list[dict]:
    """Tables with the figure of the same name beside them; other figures beside the first table."""
    blocks: list[dict[str, Any]] = [
        {"tables": [t], "figures": [_figure_entry(png_by_stem[s], root)] if s in figure_stems else []}
        for t, s in zip(tables, stems, strict=True)]
    loose = [_figure_entry(png_by_stem[s], root) for s in figure_stems if s not in stems]
    if blocks:
        blocks[0]["figures"] += loose
    elif loose:
        blocks.append({"tables": [], "figures": loose})
    for block in blocks:
        block["stacked"] = any(t["wide"] for t in block["tables"])
    return blocks


def _calibration_notes(frames: list[pd.DataFrame]) -> list[str]:
    """Sentences naming the methods whose calibrated reliability points equal their uncalibrated ones."""
    from tzsl.studies.comparison.calibration import calibration_skipped  # noqa: PLC0415 (one rule for figure and page)

    out = []
    for frame in frames:
        skipped = calibration_skipped(frame)
        if skipped:
            out.append(f"Calibration was skipped for {', '.join(skipped)}: the \"calibrated\" posterior equals the "
                       "uncalibrated one (too few training classes for pseudo-unseen folds; the manifest's warnings "
                       "say why), so their calibrated ECE and Brier score are the uncalibrated ones.")
    return out


def _layout(manifests: dict[str, dict], frames: dict[str, pd.DataFrame]) -> tuple[bool, dict[str, dict]]:
    """(paper layout, study records): paper when a manifest names a paper study, or - when no manifest
    names a study - when a table carries the paper's numbers (``paper_*`` columns)."""
    records = {name: record for m in manifests.values() for name, record in study_records(m).items()}
    if records:
        return any(is_paper_record(r) for r in records.values()), records
    return any(str(c).startswith("paper_") for t in frames.values() for c in t.columns), records


def _opening(root: Path, paper: bool, records: dict[str, dict], manifests: dict[str, dict],
             frames: dict[str, pd.DataFrame]) -> dict[str, Any]:
    """Title, the dataset card and the summary of a generic study (the title only, for the papers)."""
    names = dataset_names(records)
    if paper:
        lists = [s for s in (m.get("reproduce_studies") for m in manifests.values()) if s]
        studies = ", ".join(lists[0] if lists else records) or root.resolve().name
        return {"title": f"tzsl results: {studies}", "dataset": None, "description": None, "card": [],
                "card_note": None, "summary": [], "relaxed": [], "deploy": []}
    data_files = {k: v for m in manifests.values() for k, v in (m.get("data_files") or {}).items()}
    card, note = dataset_card_items(next(iter(records.values())), data_files) if len(records) == 1 else ([], None)
    descriptions = [m.get("description") for m in manifests.values() if m.get("description")]
    return {"title": f"{', '.join(names) or root.resolve().name}: zero-shot study",
            "dataset": ", ".join(names) or None, "description": descriptions[0] if descriptions else None,
            "card": card, "card_note": note, "summary": headline(frames), "relaxed": relaxations(records),
            "deploy": [line.removeprefix("deploy: ") for record in records.values() if deploy_choice(record)
                       for line in deployment_lines(record, root)]}


def render_report(folder: str | os.PathLike, title: str | None = None, exclude: Sequence[Path] = ()) -> str:
    """The HTML page of a results folder (see the module docstring).

    Raises
    ------
    DataFileError
        The folder does not exist or holds no CSV, PNG or manifest.
    """
    from tzsl import __version__  # noqa: PLC0415

    root = Path(folder)
    if not root.is_dir():
        raise DataFileError(root, "results folder not found")
    found = collect_results(root, exclude)
    if not any(found.values()):
        raise DataFileError(root, "no CSV table, PNG figure or manifest to report")
    manifests, manifest_text = {}, {}
    for path in found["manifest"]:
        rel = str(path.relative_to(root))
        manifests[rel], manifest_text[rel] = read_manifest(path)
    csv_by_stem = {p.stem: p for p in found["csv"]}
    png_by_stem = {p.stem: p for p in found["png"]}
    frames = {stem: t for stem, p in csv_by_stem.items() if isinstance(t := read_table(p), pd.DataFrame)}
    paper, records = _layout(manifests, frames)
    opening = _opening(root, paper, records, manifests, frames)
    dataset = opening["dataset"] or "the dataset"

    used: set[Path] = set()
    counter = iter(range(10**6))
    sections = []
    for section in SECTIONS:
        stems = [s for s in section.tables if s in csv_by_stem]
        tables = [table_entry(csv_by_stem[s], root, next(counter)) for s in stems]
        figure_stems = [s for s in section.figures if s in png_by_stem]
        if not tables and not figure_stems:
            continue
        used.update(csv_by_stem[s] for s in stems)
        used.update(png_by_stem[s] for s in figure_stems)
        heading, what = section.heading(paper)
        loaded = [frames[s] for s in stems if s in frames]
        notes = _calibration_notes([f for f in loaded if {"method", "posterior"} <= set(f.columns)])
        sections.append({"key": section.key, "title": heading, "what": fill(what, {"dataset": dataset,
                                                                                   **table_facts(loaded)}),
                         "notes": notes,
                         "findings": findings([csv_by_stem[s] for s in stems if s.endswith("method_comparison")]),
                         "blocks": _blocks(tables, stems, figure_stems, png_by_stem, root),
                         "simulated": _is_simulated_section(section, tables, manifests)})
    other_csv = [p for p in found["csv"] if p not in used]
    other_png = [p for p in found["png"] if p not in used]
    if other_csv or other_png:
        tables = [table_entry(p, root, next(counter)) for p in other_csv]
        sections.append({"key": "other", "title": "Other results", "notes": [], "findings": [],
                         "what": "Tables and figures of the folder that belong to no section above.",
                         "blocks": _blocks(tables, [p.stem for p in other_csv], [p.stem for p in other_png],
                                           {p.stem: p for p in other_png}, root),
                         "simulated": any(t["simulated"] for t in tables)})

    provenance = [{
        "name": rel, "created": manifest.get("created"), "command": manifest.get("command"),
        "packages": {k: v for k, v in (manifest.get("packages") or {}).items() if v},
        "data_files": manifest.get("data_files") or {}, "outputs": manifest.get("outputs") or {},
        "text": manifest_text[rel],
    } for rel, manifest in manifests.items()]
    return _environment().get_template("report.html.j2").render(
        **{**opening, "title": title or opening["title"]},
        paper=paper,
        version=__version__,
        written=datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
        folder=str(root.resolve()),
        n_tables=len(found["csv"]), n_figures=len(found["png"]),
        sections=sections,
        interval_doc=INTERVAL_DOC,
        deviations=deviations(manifests) if paper else [],
        provenance=provenance,
    )


def write_report(folder: str | os.PathLike, out: str | os.PathLike | None = None, force: bool = False) -> Path:
    """Write the report of ``folder`` to ``out`` (default ``folder/report.html``) atomically.

    Raises ConfigError when ``out`` exists and ``force`` is false.
    """
    target = Path(out) if out is not None else Path(folder) / REPORT_FILE
    if target.exists() and not force:
        raise ConfigError(f"{target} already exists; use --force to overwrite it or choose another --out")
    page = render_report(folder, exclude=[target])

    def write(p: Path) -> None:  # atomic_write's writer returns nothing
        p.write_text(page, encoding="utf-8")

    return atomic_write(target, write)
