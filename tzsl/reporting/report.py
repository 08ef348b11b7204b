"""``tzsl report RESULTS_DIR``: one self-contained HTML page that reads like the papers.

The page is organised by the papers' tables and figures (:data:`SECTIONS`): for each, what
was run, our tables - each accuracy shown as ``ours (ci95 low-high) [paper]`` where the
CSV has ``paper_*`` and ``*ci95_low``/``*ci95_high`` columns - with chance and baseline
columns as written by the study, and the figure beside its table; the best method per split kind
with its paired difference as evidence (:mod:`tzsl.reporting.best_method`). Results from simulated
data (the hand study) carry a SIMULATED banner. Tables and figures the sections do not
name follow under "Other results", so nothing in the folder is left out. A "Deviations
from the paper" section is generated from the manifests (features, split rules, tuning,
grids, simulated data), and provenance (versions, data checksums, outputs, the full
manifests, collapsible) closes the page.

The page is rendered with jinja2 from ``templates/report.html.j2`` (autoescaped), embeds
figures as base64 ``data:`` URIs, and needs no other file, script or network: it can be
mailed or archived as it is. Wide tables wrap their headers, use a smaller font and scroll
inside their own box, never the page. It is written atomically.
"""

from __future__ import annotations

import base64
import json
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import jinja2
import pandas as pd

from tzsl._io import atomic_write
from tzsl.exceptions import ConfigError, DataFileError
from tzsl.evaluation import INTERVAL_DOC
from tzsl.reporting.best_method import findings

__all__ = ["REPORT_FILE", "SECTIONS", "Section", "collect_results", "render_report", "write_report"]

#: Default report file name inside the results folder.
REPORT_FILE = "report.html"

#: Tables longer than this (rows) are folded away by default.
FOLD_ROWS = 40

#: Tables with more columns than this (after merging paper and interval columns) use a smaller font.
WIDE_COLUMNS = 7

#: Columns a generic ``ci95_low``/``ci95_high`` pair belongs to (first one present).
INTERVAL_TARGETS = ("accuracy", "accuracy_mean", "mean", "value", "difference", "balanced_accuracy", "harmonic")


@dataclass(frozen=True)
class Section:
    """One paper table or figure: the files that show it and what was run."""

    key: str
    title: str
    what: str
    tables: tuple[str, ...] = ()
    figures: tuple[str, ...] = ()
    simulated: bool = False


#: Report order, as in the papers. ``tables``/``figures`` are file stems found anywhere in the folder.
SECTIONS: tuple[Section, ...] = (
    Section("dap-table1", "DAP paper, Table 1: sensor fusion (MAXDAP vs AVGDAP)",
            "DAP on PHAC-2 random object splits (10 test objects each), uniform attribute prior; "
            "per-sensor attribute posteriors fused by their maximum or average. The control row rescores "
            "the same posteriors with the test attribute rows shuffled among the test objects: it must "
            "be at chance. Intervals: per-split rows resample test objects, the mean row resamples "
            "splits and test objects.",
            tables=("table1_fusion",)),
    Section("dap-table2", "DAP paper, Table 2: attribute priors",
            "AVGDAP on the same random splits with a uniform, training-set or test-set attribute prior.",
            tables=("table2_priors",)),
    Section("dap-table3", "DAP paper, Table 3 and Fig. 3: challenging splits",
            "Five splits from a 2-D PCA map of the objects' haptic features, each testing on one region "
            "of the map; MAXDAP and AVGDAP; partition numbering is arbitrary, so only the means compare "
            "with the paper (which reports AVGDAP only).",
            tables=("table3_challenging", "object_map"), figures=("object_map",)),
    Section("dap-attributes", "DAP paper, Fig. 4: attribute accuracy",
            "Test accuracy of every attribute classifier over the random splits and sensors; balanced "
            "accuracy is the headline, beside the per-attribute majority baseline.",
            tables=("attribute_accuracy", "attribute_accuracy_per_split"), figures=("attribute_accuracy",)),
    Section("dap-sweep", "DAP paper, section 4.7: accuracy vs number of attributes",
            "AVGDAP with random subsets of j attributes, on the random splits.",
            tables=("attribute_sweep",), figures=("attribute_sweep",)),
    Section("dap-multilabel", "DAP paper, section 4.4: independent vs multi-label attribute classifiers",
            "AVGDAP, uniform prior, with attribute classifiers fitted one by one or jointly.",
            tables=("multilabel",)),
    Section("methods", "Every method x study, on the same splits",
            "Every registered method on each study's own splits and test trials: accuracy with its 95% "
            "interval [the paper's number where it has one], chance, seconds per fit, and the paired "
            "difference to the paper's method of the study (PHAC-2: DAP-AVG, uniform prior; fabric: the "
            "embedding at lambda 0.1; hand: LDAP, on SIMULATED grasps). Methods a study cannot run are "
            "listed with the reason.",
            tables=("method_comparison", "phac2_method_comparison", "phac2_methods", "fabric_method_comparison",
                    "hand_method_comparison")),
    Section("calibration", "Calibration: do the class posteriors mean what they say?",
            "Each method's class posterior on the test objects against what happened: ECE (trials sorted by top-class "
            "probability into equal-size bins; the trial-weighted mean gap between mean probability and share right) "
            "and the multi-class Brier score, with 95% intervals resampling splits and test objects (method comparison "
            "columns ece, brier; *_uncalibrated: the method's own posterior; ece_if_calibrated: the ECE a perfectly "
            "calibrated posterior shows on as many trials). The calibrator is one temperature per method and split, "
            "fitted on pseudo-unseen classes of the training objects: rankings and accuracy are unchanged. Reliability "
            "diagram: accuracy against mean top-class probability per bin; below the diagonal is over-confident.",
            tables=("reliability", "phac2_reliability", "fabric_reliability", "hand_reliability"),
            figures=("reliability", "phac2_reliability", "fabric_reliability", "hand_reliability")),
    Section("gzsl", "Generalised zero-shot recognition",
            "Seen and unseen classes compete; seen-class test trials are held-out trials of training "
            "objects. Per-class mean accuracy on seen and unseen classes and their harmonic mean.",
            tables=("gzsl",)),
    Section("active-touch", "Active touch: choosing the next EP on PHAC-2",
            "Per-EP attribute models and a sequential zero-shot posterior updated after each EP; the active "
            "policy picks the EP with the largest expected class-entropy reduction (confusion from grouped CV on "
            "training objects), against each of the 24 fixed EP orders (first:<ep> = the best order starting "
            "with that EP on training objects), the paper's recording order and a random order. "
            "best_fixed_test_optimistic is chosen on the test trials (an upper bound, not a method). The "
            "stopping table gives accuracy when the top posterior reaches a threshold, the paired difference to "
            "running all four EPs, and the EPs and seconds saved. The posterior is tempered (exponents fitted on "
            "pseudo-unseen training objects); the decided table checks the rule's promise: the accuracy of the trials "
            "decided at each threshold against the threshold, tempered and untempered, active and random order.",
            tables=("active_touch", "active_touch_stop", "active_touch_decided", "active_touch_curves"),
            figures=("active_touch", "active_touch_stopping")),
    Section("active-touch-hand", "Active touch on the hand: choosing the next grasp type",
            "The same policy on simulated Shadow-hand grasps: after each grasp the DF-MDAP posterior (sum of LDAP "
            "log-scores) is updated and the next grasp type (pinch: 1-2 touching BioTacs, tripod: 3, power: 4-5) "
            "is the one with the largest expected entropy reduction; against always one type, a random type and "
            "a random grasp (the paper's sequences), and the stopping rule.",
            tables=("active_touch_hand", "active_touch_hand_stop"), figures=("active_touch_hand",), simulated=True),
    Section("fabric-table1", "Fabric paper, Table 1: accuracy per lambda and ESZSL",
            "Fabric groups as classes, depth-image features; the embedding model for each lambda and ESZSL. "
            "In the a8 attribute matrix groups 3, 4 and 5 share one row, so the paper's split "
            "(protocol 'paper') is not zero-shot for test group 5; it is kept as a reproduction row. "
            "The headline is the 'zero-shot-drop' variant (group 5 dropped from the test set, training "
            "unchanged) and its per-class mean accuracy (the _pcma columns). fabric_partitions: ESZSL on every valid "
            "partition of the groups into >= 4 test groups and the rest (a12 attributes; a8 has none), mean over "
            "partitions (interval resampling partitions and test groups) beside chance and the majority baseline.",
            tables=("fabric_table1", "fabric_partitions", "fabric_runs"), figures=("fabric_lambda",)),
    Section("fabric-deep", "Fabric paper: deep attribute embedding",
            "The end-to-end network on GelSight frames.",
            tables=("fabric_deep_table", "fabric_deep_runs")),
    Section("hand-table5", "DAP paper, Table 5 and section 5.8: hand study",
            "LDAP and multi-grasp fusion on grasps of a dexterous hand.",
            tables=("hand_table5", "hand_multigrasp_T", "hand_multigrasp_k", "hand_confusion",
                    "hand_attribute_accuracy", "hand_attribute_distance"),
            figures=("hand_multigrasp_T", "hand_multigrasp_k", "hand_confusion", "hand_attribute_accuracy",
                     "hand_attribute_distance"),
            simulated=True),
)


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


# --------------------------------------------------------------------------- tables


#: First-column values of summary rows (their counts may be fractional means).
SUMMARY_ROWS = ("mean", "std", "sd", "average")

#: Tables with more columns than this and at most :data:`TRANSPOSE_MAX_ROWS` rows are shown transposed.
TRANSPOSE_COLUMNS = 12
TRANSPOSE_MAX_ROWS = 8


def _summary_mask(table: pd.DataFrame) -> pd.Series:
    if table.shape[1] == 0:
        return pd.Series(False, index=table.index)
    return table.iloc[:, 0].astype(str).str.lower().isin(SUMMARY_ROWS)


def _is_count(values: pd.Series, summary: pd.Series) -> bool:
    """Numeric column whose values are whole numbers outside the summary rows (a count)."""
    if not pd.api.types.is_numeric_dtype(values) or pd.api.types.is_bool_dtype(values):
        return False
    present = values[~summary].dropna()
    if not len(present):
        present = values.dropna()
    return bool(len(present)) and bool((present == present.round()).all())


def _number(value: Any, count: bool) -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "-"
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        if count:
            return f"{value:.0f}" if float(value).is_integer() else f"{value:.1f}"
        return f"{value:.3f}"
    return str(value).replace(";", "; ")


def _interval_pairs(columns: list[str]) -> dict[str, tuple[str, str]]:
    """Column -> its (low, high) interval columns, by name ``X_ci95_low`` or a generic pair."""
    pairs = {c: (f"{c}_ci95_low", f"{c}_ci95_high") for c in columns
             if f"{c}_ci95_low" in columns and f"{c}_ci95_high" in columns}
    if "ci95_low" in columns and "ci95_high" in columns:
        target = next((c for c in INTERVAL_TARGETS if c in columns), None)
        if target is not None and target not in pairs:
            pairs[target] = ("ci95_low", "ci95_high")
    return pairs


def table_view(table: pd.DataFrame) -> dict[str, Any]:
    """Header and cell strings of a table, ours beside the paper's and intervals in the cell.

    A column ``X`` with ``paper_X`` becomes ``X [paper]`` with cells ``ours [paper]``; with
    ``X_ci95_low``/``X_ci95_high`` (or a generic ``ci95_low``/``ci95_high`` pair, attached to
    the first of :data:`INTERVAL_TARGETS`), cells read ``ours (low-high)``. Counts (columns
    whole outside the mean/std rows) print without decimals (a mean count with one), other
    numbers with 3, missing values as ``-``. A short table with very many columns (more than
    :data:`TRANSPOSE_COLUMNS`, at most :data:`TRANSPOSE_MAX_ROWS` rows) is transposed: one
    row per column, one column per original row, labelled by its leading text/count cells.

    Returns
    -------
    dict with ``header`` (list of str), ``rows`` (list of list of str), ``classes`` (CSS
    class of each column: ``"paper"`` for columns of paper numbers only, ``"text"`` for
    text, left-aligned), ``n_rows``, ``n_columns``, ``transposed`` (bool).
    """
    columns = [str(c) for c in table.columns]
    table = table.set_axis(columns, axis=1)
    intervals = _interval_pairs(columns)
    merged = {c: f"paper_{c}" for c in columns if f"paper_{c}" in columns}
    hidden = set(merged.values()) | {x for pair in intervals.values() for x in pair}
    shown = [c for c in columns if c not in hidden]
    summary = _summary_mask(table)
    count = {c: _is_count(table[c], summary) for c in columns}
    labels = [c + (" (95% CI)" if c in intervals else "") + (" [paper]" if c in merged else "") for c in shown]
    cells = []
    for record in table.to_dict("records"):
        row = []
        for c in shown:
            text = _number(record[c], count[c])
            if c in intervals:
                low, high = (record[x] for x in intervals[c])
                if not (pd.isna(low) or pd.isna(high)):
                    text += f" ({low:.3f}\u2013{high:.3f})"
            if c in merged and not pd.isna(record[merged[c]]):
                text += f" [{_number(record[merged[c]], count[merged[c]])}]"
            row.append(text)
        cells.append(row)
    text_columns = {i for i, c in enumerate(shown) if not pd.api.types.is_numeric_dtype(table[c])}
    if len(shown) > TRANSPOSE_COLUMNS and 0 < len(cells) <= TRANSPOSE_MAX_ROWS:
        n_key = 0
        while n_key < min(2, len(shown) - 1) and (n_key in text_columns or count[shown[n_key]]):
            n_key += 1
        n_key = max(n_key, 1)
        header = ["column"] + [" / ".join(row[:n_key]) for row in cells]
        rows = [[labels[j]] + [row[j] for row in cells] for j in range(n_key, len(shown))]
        return {"header": header, "rows": rows, "classes": ["text"] + [""] * len(cells), "n_rows": len(rows),
                "n_columns": len(header), "transposed": True}
    classes = [" ".join(k for k, on in (("paper", c.startswith("paper")), ("text", i in text_columns)) if on)
               for i, c in enumerate(shown)]
    return {"header": labels, "rows": cells, "classes": classes, "n_rows": len(cells),
            "n_columns": len(labels), "transposed": False}


def _table_entry(path: Path, root: Path, index: int) -> dict[str, Any]:
    rel = str(path.relative_to(root))
    entry: dict[str, Any] = {"name": rel, "id": f"t{index}", "error": None, "simulated": False, "wide": False,
                             "transposed": False}
    try:
        table = pd.read_csv(path)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        entry["error"] = f"not readable as CSV ({exc})"
        return entry
    if "data" in table.columns:
        entry["simulated"] = bool(table["data"].astype(str).str.lower().eq("simulated").any())
    view = table_view(table)
    entry.update(view, wide=view["n_columns"] > WIDE_COLUMNS, fold=view["n_rows"] > FOLD_ROWS)
    return entry


def _figure_entry(path: Path, root: Path) -> dict[str, str]:
    return {"name": str(path.relative_to(root)), "src": "data:image/png;base64,"
            + base64.b64encode(path.read_bytes()).decode("ascii")}


# --------------------------------------------------------------------------- manifests


def _read_manifest(path: Path) -> tuple[dict, str]:
    text = path.read_text(encoding="utf-8", errors="replace")
    try:
        data = json.loads(text)
        return (data if isinstance(data, dict) else {}), json.dumps(data, indent=2, sort_keys=True)
    except json.JSONDecodeError:
        return {}, text


def _config_items(manifest: dict) -> dict[str, Any]:
    """The manifest's configuration flattened one level (study configs nested by name merged in)."""
    config = manifest.get("config") if isinstance(manifest.get("config"), dict) else {}
    flat: dict[str, Any] = {}
    for key, value in config.items():
        if isinstance(value, dict) and key in ("study_settings", "dap_settings", "fabric", "hand"):  # dap_: older
            flat.update({k: v for t in value.values() for k, v in t.items()} if key.endswith("_settings") else value)
        else:
            flat[key] = value
    return flat


def deviations(manifests: dict[str, dict]) -> list[str]:
    """Sentences saying where the recorded runs differ from the papers' protocols.

    Read from the manifests' configurations (the zero-shot study's ``study_settings`` tables, the
    fabric and hand study configs); a key absent from every manifest yields no sentence.
    """
    out: list[str] = []
    for name, manifest in manifests.items():
        c = _config_items(manifest)
        where = f"({name})"
        svm = c.get("svm_params")
        if isinstance(svm, dict):
            cv = svm.get("cv", "absent")
            if cv is not None and cv != "absent":
                out.append(f"Attribute SVMs tuned by {cv}-fold object-grouped cross-validation; the paper uses "
                           f"leave-one-object-out {where}.")
            grid = svm.get("grid")
            if grid not in (None, "paper"):
                out.append(f"SVM hyper-parameter grid {grid!r} instead of the paper's {where}.")
            reduced = {k: svm[k] for k in ("n_C", "n_gamma", "n_draws") if k in svm}
            if reduced:
                out.append(f"Reduced SVM search {reduced} {where}.")
        if "random_min_train_positives" in c:
            out.append(f"Random splits leave out attributes with fewer than {c['random_min_train_positives']} "
                       f"positive training objects (the paper states no rule for random splits) {where}.")
        if c.get("challenging_min_train_positives") not in (None, 3):
            out.append(f"Challenging splits require {c['challenging_min_train_positives']} positive training "
                       f"objects per attribute (paper: 3) {where}.")
        if c.get("undersampling") not in (None, "select"):
            out.append(f"Class-0 under-sampling {c['undersampling']!r} (paper: one random draw) {where}.")
        for key, paper in (("n_splits", 5), ("n_test", 10), ("sweep_max_subsets", 1000)):
            if key in c and c[key] != paper:
                out.append(f"{key} = {c[key]} (paper: {paper}) {where}.")
        if c.get("hand_data") == "simulated" or c.get("simulated") is True:
            out.append(f"Hand study on SIMULATED grasps: the paper's Shadow-hand recordings are not public, "
                       f"so its numbers are not comparable to Table 5 {where}.")
        if c.get("duplicate_groups"):
            out.append(f"Fabric attribute rows shared by groups {c['duplicate_groups']}: a test group sharing "
                       f"its row with a training group is not zero-shot {where}.")
        if c.get("dataset"):
            out.append(f"Dataset and features: {c['dataset']} {where}.")
        if isinstance(c.get("n_features"), dict):
            units = c.get("units") if isinstance(c.get("units"), dict) else {}
            described = "; ".join(f"{k}: {v} features per {units.get(k, 'sample')}" for k, v in c["n_features"].items())
            out.append(f"Features used: {described} {where}.")
        if c.get("lams") is not None and c.get("alphas") is not None:
            lams, alphas = (", ".join(map(str, c[k])) for k in ("lams", "alphas"))
            out.append(f"Embedding model: lambda in {{{lams}}}, alpha chosen from {{{alphas}}} by class-grouped "
                       f"cross-validation on the training groups {where}.")
        for key in ("grid_edges", "grid_edge_warnings"):
            if manifest.get(key):
                out.append(f"Selected hyper-parameters on a grid edge: {manifest[key]} {where}.")
    return list(dict.fromkeys(out))


# --------------------------------------------------------------------------- page


def _environment() -> jinja2.Environment:
    env = jinja2.Environment(
        loader=jinja2.PackageLoader("tzsl.reporting", "templates"),
        autoescape=True, undefined=jinja2.StrictUndefined, trim_blocks=True, lstrip_blocks=True,
    )
    # headers like n_test_objects may break after an underscore (zero-width space), not mid-word
    env.filters["breakable"] = lambda text: str(text).replace("_", "_\u200b")
    return env


def _is_simulated_section(section: Section, tables: list[dict], manifests: dict[str, dict]) -> bool:
    if any(t["simulated"] for t in tables):
        return True
    if not section.simulated:
        return False
    flags = [_config_items(m).get("simulated") for n, m in manifests.items() if "hand" in n]
    flags += [_config_items(m).get("hand_data") == "simulated" for m in manifests.values()
              if "hand_data" in _config_items(m)]
    return not flags or any(flag is True for flag in flags)


def _blocks(tables: list[dict], stems: list[str], figure_stems: list[str], png_by_stem: dict[str, Path],
            root: Path) -> list[dict]:
    """Tables with the figure of the same name beside them; other figures beside the first table."""
    blocks = [{"tables": [t], "figures": [_figure_entry(png_by_stem[s], root)] if s in figure_stems else []}
              for t, s in zip(tables, stems)]
    loose = [_figure_entry(png_by_stem[s], root) for s in figure_stems if s not in stems]
    if blocks:
        blocks[0]["figures"] += loose
    elif loose:
        blocks.append({"tables": [], "figures": loose})
    for block in blocks:
        block["stacked"] = any(t["wide"] for t in block["tables"])
    return blocks


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
        manifests[rel], manifest_text[rel] = _read_manifest(path)

    csv_by_stem = {p.stem: p for p in found["csv"]}
    png_by_stem = {p.stem: p for p in found["png"]}
    used: set[Path] = set()
    counter = iter(range(10**6))
    sections = []
    for section in SECTIONS:
        stems = [s for s in section.tables if s in csv_by_stem]
        tables = [_table_entry(csv_by_stem[s], root, next(counter)) for s in stems]
        figure_stems = [s for s in section.figures if s in png_by_stem]
        if not tables and not figure_stems:
            continue
        used.update(csv_by_stem[s] for s in stems)
        used.update(png_by_stem[s] for s in figure_stems)
        best = findings([csv_by_stem[s] for s in stems if s.endswith("method_comparison")])
        sections.append({"key": section.key, "title": section.title, "what": section.what, "findings": best,
                         "blocks": _blocks(tables, stems, figure_stems, png_by_stem, root),
                         "simulated": _is_simulated_section(section, tables, manifests)})
    other_csv = [p for p in found["csv"] if p not in used]
    other_png = [p for p in found["png"] if p not in used]
    if other_csv or other_png:
        tables = [_table_entry(p, root, next(counter)) for p in other_csv]
        sections.append({"key": "other", "title": "Other results", "what": "Tables and figures of the folder "
                         "that belong to no paper table.",
                         "blocks": _blocks(tables, [p.stem for p in other_csv], [p.stem for p in other_png],
                                           {p.stem: p for p in other_png}, root),
                         "simulated": any(t["simulated"] for t in tables)})

    provenance = []
    for rel, manifest in manifests.items():
        provenance.append({
            "name": rel, "created": manifest.get("created"), "command": manifest.get("command"),
            "packages": {k: v for k, v in (manifest.get("packages") or {}).items() if v},
            "data_files": manifest.get("data_files") or {}, "outputs": manifest.get("outputs") or {},
            "text": manifest_text[rel],
        })
    return _environment().get_template("report.html.j2").render(
        title=title or f"tzsl results: {root.resolve().name}",
        version=__version__,
        written=datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
        folder=str(root.resolve()),
        n_tables=len(found["csv"]), n_figures=len(found["png"]),
        sections=sections,
        interval_doc=INTERVAL_DOC,
        deviations=deviations(manifests),
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
    return atomic_write(target, lambda p: p.write_text(page, encoding="utf-8"))
