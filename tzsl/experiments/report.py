"""``tzsl report RESULTS_DIR``: one self-contained HTML page of a results folder.

Every CSV table of the folder (and its sub-folders) is rendered with
:meth:`pandas.DataFrame.to_html`, the paper's numbers (columns named ``paper_*``) shaded so
they stand out beside ours; every PNG figure is embedded as a base64 ``data:`` URI; every
``*manifest*.json`` is shown in a collapsible block. A header gives the tzsl version, the
date and the folder. The page needs no other file and no network (no scripts, no external
style sheets), so it can be mailed or archived as it is. It is written atomically.
"""

from __future__ import annotations

import base64
import html
import json
import os
from collections.abc import Sequence
from datetime import datetime, timezone
from pathlib import Path

import pandas as pd

from tzsl._io import atomic_write
from tzsl.exceptions import ConfigError, DataFileError

__all__ = ["REPORT_FILE", "collect_results", "render_report", "write_report"]

#: Default report file name inside the results folder.
REPORT_FILE = "report.html"

#: Tables long enough to be folded away by default (rows).
FOLD_ROWS = 40

#: Known tables first, in this order, with a caption; the rest follow alphabetically.
CAPTIONS: dict[str, str] = {
    "table1_fusion": "DAP paper Table 1: MAXDAP vs AVGDAP (uni-prior), random splits",
    "table2_priors": "DAP paper Table 2: AVGDAP by attribute prior, random splits",
    "table3_challenging": "DAP paper Table 3: challenging splits (AVGDAP, uni-prior)",
    "multilabel": "Independent vs multi-label attribute classifiers (AVGDAP, uni-prior)",
    "phac2_methods": "DAP vs ESZSL vs embedding model on the same random splits (trial accuracy)",
    "gzsl": "Generalised zero-shot: seen / unseen per-class mean accuracy and harmonic mean",
    "attribute_accuracy": "Per-attribute test accuracy (mean over random splits and sensors)",
    "attribute_sweep": "Accuracy vs number of attributes (DAP paper section 4.7)",
    "fabric_table1": "Fabric paper Table 1 analogue (accuracy per lambda and ESZSL)",
    "hand_table5": "DAP paper Table 5 analogue (hand study)",
}

_CSS = """
body { font-family: system-ui, -apple-system, "Segoe UI", Roboto, sans-serif; margin: 0 auto;
       max-width: 1200px; padding: 1em 2em; color: #222; line-height: 1.4; }
header { border-bottom: 2px solid #345; margin-bottom: 1em; }
h1 { margin-bottom: 0.2em; } h2 { margin-top: 2em; border-bottom: 1px solid #ccc; }
.meta { color: #555; font-size: 0.9em; }
nav ul { columns: 3; font-size: 0.9em; }
table.dataframe { border-collapse: collapse; font-size: 0.85em; margin: 0.5em 0; }
table.dataframe th, table.dataframe td { border: 1px solid #ccc; padding: 2px 6px; text-align: right; }
table.dataframe thead th { background: #eef2f6; }
table.dataframe tbody tr:nth-child(even) { background: #fafafa; }
.scroll { overflow-x: auto; }
.legend .paper { background: #fff1c9; padding: 0 4px; }
figure { margin: 1em 0; } figure img { max-width: 100%; border: 1px solid #ddd; }
figcaption { font-size: 0.9em; color: #555; }
pre { background: #f6f6f6; padding: 0.8em; overflow-x: auto; font-size: 0.8em; }
details > summary { cursor: pointer; color: #245; }
"""


def collect_results(folder: str | os.PathLike, exclude: Sequence[Path] = ()) -> dict[str, list[Path]]:
    """The CSV tables, PNG figures and manifests of a results folder (recursive, hidden skipped).

    Returns
    -------
    dict with keys ``"csv"``, ``"png"``, ``"manifest"``: lists of paths, tables in report order
    (known tables first, see :data:`CAPTIONS`), the rest sorted by relative path.
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
    order = {name: i for i, name in enumerate(CAPTIONS)}
    found["csv"].sort(key=lambda p: (order.get(p.stem, len(order)), str(p.relative_to(root))))
    return found


def _anchor(kind: str, i: int) -> str:
    return f"{kind}-{i}"


def _formatters(table: pd.DataFrame) -> dict:
    """Float columns holding only whole numbers (counts read back as float) print without decimals."""
    out = {}
    for column in table.columns:
        values = table[column]
        if pd.api.types.is_float_dtype(values):
            finite = values.dropna()
            if len(finite) and (finite == finite.round()).all() and finite.abs().max() < 1e15:
                out[column] = lambda v: "-" if pd.isna(v) else f"{v:.0f}"
    return out


def _table_html(path: Path, root: Path, table_id: str) -> str:
    try:
        table = pd.read_csv(path)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        return f"<p>{html.escape(str(path.relative_to(root)))}: not readable as CSV ({html.escape(str(exc))})</p>"
    paper = [i + 1 for i, c in enumerate(table.columns) if str(c).startswith("paper")]
    style = ""
    if paper:
        cells = ", ".join(f"#{table_id} td:nth-child({i}), #{table_id} th:nth-child({i})" for i in paper)
        style = f"<style>{cells} {{ background: #fff1c9; }}</style>\n"
    body = table.to_html(index=False, table_id=table_id, na_rep="-", border=0, formatters=_formatters(table),
                         float_format=lambda v: f"{v:.3f}", escape=True)
    block = f'{style}<div class="scroll">{body}</div>'
    if len(table) > FOLD_ROWS:
        block = f"<details><summary>{len(table)} rows x {table.shape[1]} columns (show)</summary>{block}</details>"
    return block


def _figure_html(path: Path, root: Path) -> str:
    data = base64.b64encode(path.read_bytes()).decode("ascii")
    name = html.escape(str(path.relative_to(root)))
    return (f'<figure><img src="data:image/png;base64,{data}" alt="{name}">'
            f"<figcaption>{name}</figcaption></figure>")


def _manifest_html(path: Path, root: Path) -> str:
    text = path.read_text(encoding="utf-8", errors="replace")
    try:
        text = json.dumps(json.loads(text), indent=2, sort_keys=True)
    except json.JSONDecodeError:
        pass
    name = html.escape(str(path.relative_to(root)))
    return f"<details><summary>{name}</summary><pre>{html.escape(text)}</pre></details>"


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
    now = datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    title = title or f"tzsl results: {root.resolve().name}"
    parts = [
        "<!DOCTYPE html>", '<html lang="en">', "<head>", '<meta charset="utf-8">',
        '<meta name="viewport" content="width=device-width, initial-scale=1">',
        f"<title>{html.escape(title)}</title>", f"<style>{_CSS}</style>", "</head>", "<body>",
        "<header>", f"<h1>{html.escape(title)}</h1>",
        f'<p class="meta">tzsl {html.escape(__version__)} &middot; report written {now} &middot; folder '
        f"<code>{html.escape(str(root.resolve()))}</code> &middot; {len(found['csv'])} tables, "
        f"{len(found['png'])} figures, {len(found['manifest'])} manifest(s)</p>",
        '<p class="meta legend">Shaded columns <span class="paper">paper_*</span> hold the published '
        "numbers beside ours; accuracies are fractions in [0, 1].</p>",
        "</header>",
    ]
    toc = []
    for i, path in enumerate(found["csv"]):
        toc.append(f'<li><a href="#{_anchor("table", i)}">{html.escape(str(path.relative_to(root)))}</a></li>')
    for i, path in enumerate(found["png"]):
        toc.append(f'<li><a href="#{_anchor("figure", i)}">{html.escape(str(path.relative_to(root)))}</a></li>')
    parts += ["<nav><h2>Contents</h2><ul>", *toc, "</ul></nav>"]
    if found["csv"]:
        parts.append("<h2>Tables</h2>")
    for i, path in enumerate(found["csv"]):
        rel = html.escape(str(path.relative_to(root)))
        caption = CAPTIONS.get(path.stem)
        parts.append(f'<section id="{_anchor("table", i)}"><h3>{rel}</h3>')
        if caption:
            parts.append(f"<p>{html.escape(caption)}</p>")
        parts += [_table_html(path, root, f"t{i}"), "</section>"]
    if found["png"]:
        parts.append("<h2>Figures</h2>")
    for i, path in enumerate(found["png"]):
        parts.append(f'<section id="{_anchor("figure", i)}">{_figure_html(path, root)}</section>')
    if found["manifest"]:
        parts.append("<h2>Manifests</h2><p>Configuration, seeds, data checksums and package versions "
                     "of each run.</p>")
        parts += [_manifest_html(path, root) for path in found["manifest"]]
    parts += ["</body>", "</html>", ""]
    return "\n".join(parts)


def write_report(folder: str | os.PathLike, out: str | os.PathLike | None = None, force: bool = False) -> Path:
    """Write the report of ``folder`` to ``out`` (default ``folder/report.html``) atomically.

    Raises
    ------
    ConfigError
        ``out`` exists and ``force`` is false.
    """
    target = Path(out) if out is not None else Path(folder) / REPORT_FILE
    if target.exists() and not force:
        raise ConfigError(f"{target} already exists; use --force to overwrite it or choose another --out")
    page = render_report(folder, exclude=[target])
    return atomic_write(target, lambda p: p.write_text(page, encoding="utf-8"))
