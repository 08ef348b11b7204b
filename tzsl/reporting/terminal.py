"""What the command line prints of a study: its notes, then one screen with the answer first.

Without ``--verbose`` a study's own lines reach the terminal through :func:`notes_only`: its
``note:`` lines (each setting it relaxed, what a preset maps to), wrapped, and not its tables. ``tzsl
run`` then ends with :func:`run_summary`, fitted with what was printed before into :data:`MAX_LINES`
lines of at most :data:`WIDTH` characters (a path longer than that stays whole): the dataset in a
line, how many settings were relaxed, per split kind the most accurate methods and the reference
with their 95% intervals against chance, how many intervals clear chance, the paired difference of
the most accurate method to the reference, the method a robot would be given (the study's deploy
choice, :mod:`tzsl.reporting.deployment`), and where the CSVs and the report are. ``tzsl reproduce-tables`` and
``tzsl evidence`` print :func:`study_lines` after each study. Every number comes from the tables the
study wrote (the same data frames as its CSVs), through the report's own reading of them
(:func:`tzsl.reporting.summary.chance_verdicts`, :func:`tzsl.reporting.manifests.relaxations`);
nothing is computed again. ``--verbose`` prints the study's tables too; the files are the same.
"""

from __future__ import annotations

import textwrap
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import pandas as pd

from tzsl.reporting.deployment import deployment_lines
from tzsl.reporting.manifests import dict_at, relaxations
from tzsl.reporting.summary import ChanceVerdict, chance_verdicts, trivial_baseline

__all__ = ["MAX_LINES", "TOP_METHODS", "WIDTH", "notes_only", "run_summary", "study_lines"]

#: Most lines a run prints without ``--verbose`` (its first and last lines and the study's notes included).
MAX_LINES = 40
#: Widest line, in characters (a path longer than that is not broken).
WIDTH = 100
#: Methods listed per split kind, most accurate first (the reference is listed too).
TOP_METHODS = 3
#: Lines of the run's own that frame the summary: the engine's first line, ``wrote ...`` and a blank line.
FRAME_LINES = 3


def _wrap(text: str, first: str = "", rest: str = "    ") -> list[str]:
    """``text`` in lines of at most :data:`WIDTH` characters (words and paths kept whole), the first
    line starting with ``first``, the others with ``rest``."""
    return textwrap.wrap(text, WIDTH, initial_indent=first, subsequent_indent=rest,
                         break_long_words=False, break_on_hyphens=False) or [first]


def _interval(row: pd.Series, column: str = "accuracy", low: str = "ci95_low", high: str = "ci95_high",
              sign: str = "") -> str:
    text = f"{float(row[column]):{sign}.3f}"
    if not (pd.isna(row.get(low)) or pd.isna(row.get(high))):
        text += f" [{float(row[low]):{sign}.3f}, {float(row[high]):{sign}.3f}]"
    return text


def _dataset_line(record: Mapping[str, Any]) -> list[str]:
    """``dataset NAME: N trials, ...`` from the study's record (or its generic part's)."""
    nested = dict_at(dict(record), "zero_shot")
    size = record.get("dataset_size") or nested.get("dataset_size")
    name = record.get("dataset") or nested.get("dataset")
    if not size:
        return _wrap(f"dataset {name}") if name else []
    return _wrap(f"dataset {name}: {size['trials']} trials, {size['objects']} objects, {size['sensors']} "
                 f"sensor(s), {size['features_per_sensor']} features per sensor, {size['attributes']} attributes")


def _relaxed_line(record: Mapping[str, Any]) -> str:
    """How many settings the run relaxed (each said in a ``note: relaxed`` line as it was relaxed)."""
    said = relaxations({"run": dict(record)})
    if not said:
        return "relaxed: nothing (every setting as asked)"
    return f"relaxed: {len(said)} setting(s) to fit the dataset (the notes above; manifest.json 'relaxations')"


def notes_only(echo: Callable[[str], None]) -> Callable[[str], None]:
    """An echo for a study's own lines that passes on its ``note:`` lines (what it relaxed, what it maps
    to, what it left out), each in lines of at most :data:`WIDTH` characters, and nothing else (tables,
    per-split lines: ``--verbose``'s)."""
    def say(message: str) -> None:
        if message.startswith("note:"):
            for line in _wrap(message):
                echo(line)
    return say


def _status(row: pd.Series) -> str:
    low, chance = row.get("ci95_low"), row.get("chance")
    if pd.isna(low) or pd.isna(chance):
        return "no interval"
    return "above chance" if float(low) > float(chance) else "interval includes chance"


def _verdict_lines(verdict: ChanceVerdict, label: str, baseline: str | None, more_in: str) -> list[str]:
    """One split kind: the most accurate methods and the reference against chance, the paired difference."""
    best, group, clear = verdict.best, verdict.group, verdict.clear
    dap_only = group["study"].astype(str).eq("").all()  # read from a fusion table: DAP, no comparison
    splits = f", {int(best['n_splits'])} splits" if not pd.isna(best.get("n_splits", float("nan"))) else ""
    what = "DAP only (no method comparison on them)" if dap_only else f"{len(group)} methods"
    lines = _wrap(f"{label}{verdict.kind} splits{splits}, {what}; accuracy [95% interval], "
                  f"chance {float(best['chance']):.3f}:")
    ranked = group.assign(_order=range(len(group))).sort_values(["accuracy", "_order"], ascending=[False, True])
    reference = str(best["reference"])
    shown = list(ranked.head(TOP_METHODS).index)
    shown += [i for i in group.index if str(group.at[i, "method"]) == reference and i not in shown][:1]
    width = max(len(str(group.at[i, "method"])) for i in shown)
    several_chances = group["chance"].nunique() > 1
    for i in shown:
        row = group.loc[i]
        tag = " (reference)" if str(row["method"]) == reference and not dap_only else ""
        chance = f", chance {float(row['chance']):.3f}" if several_chances else ""
        lines += _wrap(f"{str(row['method']):<{width}}  {_interval(row)}  {_status(row)}{chance}{tag}", "  ")
    if len(group) > len(shown):
        lines.append(f"  ... {len(group) - len(shown)} more in {more_in}")
    if clear.empty:
        lines += _wrap(f"no interval clears chance ({len(group)} compared): no evidence that any method "
                       "recognises unseen classes better than guessing", "  ")
    else:
        lines.append(f"  {len(clear)} of {len(group)} intervals clear chance")
    if baseline:
        lines += _wrap(baseline, "  ")
    if not dap_only and str(best["method"]) != reference and "difference" in best.index:
        verdict_word = "interval excludes 0" if best.get("beats_reference") else "interval includes 0"
        lines += _wrap(f"most accurate {best['method']} vs the reference {reference}: "
                       f"{_interval(best, 'difference', 'difference_ci95_low', 'difference_ci95_high', '+')} "
                       f"({verdict_word})", "  ")
    elif not dap_only and str(best["method"]) == reference:
        lines.append(f"  the reference {reference} is the most accurate")
    if str(best.get("purpose", "")) == "select":
        lines += _wrap("selection splits: confirm a choice on confirmation splits before reporting it", "  ")
    return lines


def _deployment_lines(record: Mapping[str, Any], root: Path) -> list[str]:
    """What a robot would be given (:func:`tzsl.reporting.deployment.deployment_lines`), wrapped: the study's
    deploy choice, or ``tzsl train-attributes``' default when it made none."""
    first, *rest = deployment_lines(record, root)
    return [*_wrap(first), *(line for text in rest for line in _wrap(text, "  "))]


def _where_lines(root: Path, written: Sequence[Path]) -> list[str]:
    suffixes = pd.Series([Path(p).suffix.lower() for p in written], dtype=object)
    csv, png = int((suffixes == ".csv").sum()), int((suffixes == ".png").sum())
    return [*_wrap(f"tables: {csv} CSV and {png} figures in {root} (--verbose prints the tables here)"),
            *_wrap(f"report: tzsl report {root} (writes report.html there)")]


def _comparison_file(tables: Mapping[str, pd.DataFrame], written: Sequence[Path]) -> str:
    """The name of the run's method comparison CSV (with the run's prefix), for ``... more in``."""
    stems = [s for s in tables if s.endswith("method_comparison")]
    for path in written:
        if stems and Path(path).name.endswith(f"{stems[0]}.csv"):
            return Path(path).name
    return "the comparison CSV"


def _compact(verdict: ChanceVerdict, label: str = "", first: str = "") -> list[str]:
    """One split kind in a line or two: the most accurate method against chance, how many clear it."""
    best = verdict.best
    return _wrap(f"{label}{verdict.kind} splits: most accurate {best['method']} {_interval(best)}, chance "
                 f"{float(best['chance']):.3f}; {len(verdict.clear)} of {len(verdict.group)} intervals clear "
                 "chance", first, first + "    ")


def _verdict_blocks(tables: Mapping[str, pd.DataFrame], more_in: str) -> list[tuple[list[str], list[str]]]:
    """Per split kind (and study): its full block and its compact line(s)."""
    verdicts = chance_verdicts(dict(tables), every_kind=True)
    studies = {str(v.best["study"]) for v in verdicts if str(v.best["study"])}
    fusion = tables.get("table1_fusion")
    baseline = trivial_baseline(fusion) if fusion is not None and "chance" in fusion.columns else None
    blocks = []
    for verdict in verdicts:
        study = str(verdict.best["study"])
        label = f"{study}, " if len(studies) > 1 and study else ""
        said = baseline if verdict.kind in ("random", "file") else None
        blocks.append((_verdict_lines(verdict, label, said, more_in), _compact(verdict, label)))
        if said:
            baseline = None  # said once
    return blocks


def run_summary(tables: Mapping[str, pd.DataFrame], record: Mapping[str, Any], root: Path,
                written: Sequence[Path], printed: int = 0) -> list[str]:
    """The lines ``tzsl run`` prints after a study without ``--verbose``: with the ``printed`` lines
    before them and :data:`FRAME_LINES` after, at most :data:`MAX_LINES` (while the study's notes
    leave room for the first split kind), each at most :data:`WIDTH` characters but for long paths.

    Parameters
    ----------
    tables : dict
        The study's tables by file stem (``StudyRun.tables``: what its CSVs hold).
    record : dict
        The study's record (``StudyRun.record``: dataset, relaxations).
    root : Path
        The results folder.
    written : list of Path
        The files the run wrote.
    printed : int
        Lines the run printed before (its first line, the study's notes).

    Returns
    -------
    list of str
        The dataset, what was relaxed, per split kind the most accurate methods and the reference
        with their intervals against chance (a split kind that does not fit in full in a line or
        two, then ``... N more``), the method to deploy and its model, where the CSVs and the report are.
    """
    head = [*_dataset_line(record), _relaxed_line(record)]  # the study's notes were said as it ran
    blocks = _verdict_blocks(tables, _comparison_file(tables, written))
    tail = _deployment_lines(record, root) + _where_lines(root, written)
    budget = MAX_LINES - FRAME_LINES - printed - len(head) - len(tail)
    middle: list[str] = [] if blocks else _wrap(f"tables: {', '.join(sorted(tables))}")[:2]
    for n, (full, compact) in enumerate(blocks):
        room = budget - len(middle) - (1 if n + 1 < len(blocks) else 0)  # keep a line for "... N more"
        if len(full) <= room:
            middle += full
        elif len(compact) <= room or n == 0:  # the first split kind is always said
            middle += compact
        else:
            middle.append(f"... {len(blocks) - n} more split kinds or studies: the report, or --verbose")
            break
    return [*head, *middle, *tail]


def study_lines(tables: Mapping[str, pd.DataFrame]) -> list[str]:
    """A few lines after each study of ``reproduce-tables`` / ``evidence`` without ``--verbose``: per
    comparison group, the most accurate method against chance and how many intervals clear it."""
    lines = [line for verdict in chance_verdicts(dict(tables)) for line in _compact(
             verdict, f"{verdict.best['study']}, " if str(verdict.best["study"]) else "", "  ")]
    return lines or [f"  {len(tables)} tables"]
