"""Classify new grasps with a saved model bundle, grasp by grasp, with multi-grasp fusion.

This is the engine of ``tzsl predict`` and of :class:`tzsl.inference.Recogniser`. Every model is
predicted the same way, whatever the method: a bundle (:mod:`tzsl.inference.zero_shot_bundles`) holds a
fitted model whose ``attribute_scores(X)`` gives attribute scores, a fitted decision rule
(:class:`tzsl.models.DecisionRule`), the attribute names and a feature schema. The input files
are read into the model's input by that schema (:mod:`tzsl.inference.predict_inputs`), the
candidate classes arrive as a *class table* (their attribute rows; the grasped object's own row
is never needed), and the rule ranks them. With several grasps the decision is fused:

* **SC-MDAP** (default, ``mode="sc"``): classify grasp by grasp, in the order given, and stop at
  the first class decided ``k`` times (DAP paper section 5.7.3). If no class reaches ``k`` the
  result says it has *not* decided (and names the most frequent class).
* **DF-MDAP** (``mode="df"``): average the grasps' attribute scores into one "super grasp"
  (eqs. 11-12; per sensor, before the rule fuses sensors) and classify it; the running decision
  after each grasp is reported too.

Class table (``classes.csv``): first column the class name (any header), then one 0/1 column per
attribute, named exactly as the model's attributes (a missing or unknown attribute is an error).
Lines starting with ``#`` are comments, and columns named ``split`` or ``subset`` are descriptive
and not used - so the shipped Table 4 file (``tzsl/datasets/hand_table4.csv``) works as is. A
plain dataset folder stands for its ``classes.csv`` (then attributes the model does not know are
ignored); ``candidates`` picks some of its rows.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from io import StringIO
from pathlib import Path

import numpy as np
import pandas as pd

from tzsl._scoring import duplicate_attribute_groups
from tzsl.exceptions import DataFileError
from tzsl.inference.zero_shot_bundles import Predictor

__all__ = [
    "Prediction",
    "format_prediction",
    "prediction_report",
    "read_class_table",
    "top_ties",
]

_DESCRIPTIVE = ("split", "subset")


# ---------------------------------------------------------------------------- class table
def read_class_table(path: str | Path, attribute_names: Sequence[str], *,
                     candidates: Sequence[str] | None = None, left_out: Sequence[str] = ()) -> pd.DataFrame:
    """Read candidate classes and check their attributes against the model's.

    Parameters
    ----------
    path : str or Path
        CSV file: class name in the first column, then 0/1 attribute columns (format in the
        module docstring); or a dataset folder, standing for its ``classes.csv`` (whose
        attributes the model does not know, e.g. dropped for a split, are then ignored).
    attribute_names : sequence of str
        The model's attributes, in the model's order.
    candidates : sequence of str, optional
        Keep only these classes, in this order (e.g. the unseen ones of a dataset's table).
    left_out : sequence of str
        Attributes the model left out (too rare to learn: the bundle's ``left_out_attributes``,
        :func:`tzsl.inference.bundle_kinds.left_out_attributes`): their columns are ignored, in a
        file too, and a note says so once.

    Returns
    -------
    DataFrame of shape (n_classes, n_attributes), int 0/1
        Indexed by class name, columns in ``attribute_names`` order. ``attrs["notes"]``: what to tell
        the user (attributes ignored because the model left them out; classes whose rows over the
        model's attributes are identical, which no ranking can tell apart), one line each.

    Raises
    ------
    DataFileError
        Missing file, missing or unknown attribute columns, non-0/1 entries, duplicate or empty
        class names (naming the file, the class and the attribute).
    """
    path = Path(path)
    extra_ok = path.is_dir()
    if extra_ok:
        path = path / "classes.csv"
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise DataFileError(path, "class table not found") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise DataFileError(path, f"cannot read the class table ({exc})") from None
    body = "\n".join(line for line in text.splitlines() if line.strip() and not line.lstrip().startswith("#"))
    try:
        table = pd.read_csv(StringIO(body), dtype=str, keep_default_na=False)
    except (pd.errors.ParserError, pd.errors.EmptyDataError) as exc:
        raise DataFileError(path, f"cannot parse the class table: {exc}") from None
    if table.shape[1] < 2 or table.empty:
        raise DataFileError(path, "a class table needs a class-name column, attribute columns and at least one row")
    name_col = table.columns[0]
    names = table[name_col].str.strip()
    if (names == "").any():
        raise DataFileError(path, f"empty class name on row(s) {list(np.flatnonzero(names == '') + 2)}")
    if names.duplicated().any():
        raise DataFileError(path, f"duplicate class name(s) {sorted(set(names[names.duplicated()]))}")
    wanted = [str(a) for a in attribute_names]
    ignored = [c for c in table.columns[1:] if c in set(left_out) - set(wanted)]
    given = [c for c in table.columns[1:] if c not in _DESCRIPTIVE and c not in ignored]
    missing = [a for a in wanted if a not in given]
    unknown = [a for a in given if a not in wanted]
    if missing or (unknown and not extra_ok):
        parts = []
        if missing:
            parts.append(f"missing attribute column(s) {missing}")
        if unknown:
            parts.append(f"unknown attribute column(s) {unknown}")
        dropped = f" (it left out {list(left_out)})" if len(left_out) else ""
        raise DataFileError(path, "; ".join(parts) + f"; the model's attributes are {wanted}{dropped}")
    values = table[wanted].apply(lambda c: c.str.strip())
    bad = ~values.isin(["0", "1"])
    if bad.any().any():
        r, c = np.argwhere(bad.to_numpy())[0]
        raise DataFileError(
            path, f"class {names.iloc[r]!r}, attribute {wanted[c]!r}: value {values.iat[r, c]!r} is not 0 or 1"
        )
    table = pd.DataFrame(values.to_numpy(dtype=int), index=pd.Index(names, name="class"), columns=wanted)
    if candidates is not None:
        absent = [c for c in candidates if c not in table.index]
        if absent or not candidates:
            raise DataFileError(path, f"candidate class(es) {absent} not in the table; it has {list(table.index)}")
        table = table.loc[list(candidates)]
    table.attrs["notes"] = _class_table_notes(path, table, ignored)
    return table


def _class_table_notes(path: Path, table: pd.DataFrame, ignored: list[str]) -> list[str]:
    """The notes of :func:`read_class_table` (``ignored``: its columns the model left out)."""
    notes = []
    if ignored:
        notes.append(f"{path}: attribute(s) {ignored} ignored: the model left them out (its bundle's "
                     f"left_out_attributes say why); classes are ranked on its {table.shape[1]} attributes")
    groups = duplicate_attribute_groups(table.to_numpy())
    if groups:
        same = "; ".join(" = ".join(str(table.index[i]) for i in g) for g in groups)
        notes.append(f"{path}: classes {same} have identical rows over the model's {table.shape[1]} attributes: "
                     "no ranking can tell them apart (they tie)")
    return notes


# ---------------------------------------------------------------------------- prediction
@dataclass
class Prediction:
    """Result of :meth:`tzsl.inference.Recogniser.add` (and ``tzsl predict``): grasps and their fused decision.

    Attributes
    ----------
    classes : list of str, length c
    grasp_ids, sources, info : list of str, length n
    grasp_posteriors : ndarray of shape (n, c)
        ``p(z | x)`` of every grasp alone, over the candidate classes (calibrated when the bundle
        holds a calibrator: :meth:`tzsl.inference.zero_shot_bundles.Predictor.posteriors`).
    decisions : ndarray of int, shape (n,)
        Per-grasp top class (index into ``classes``).
    mode : {"sc", "df"}
    k : int
        SC-MDAP's number of equal classifications.
    decided : bool
        SC-MDAP: some class reached ``k``; DF-MDAP: always True.
    n_used : int
        Grasps used for the decision.
    final : int
        Decided class (SC-MDAP undecided: the most frequent class, ties to the earliest).
    final_posteriors : ndarray of shape (c,) or None
        DF-MDAP: ``p(z | super grasp)``.
    running : ndarray of int, shape (n,) or None
        DF-MDAP: decision after the first 1, 2, ..., n grasps.
    notes : list of str
    """

    classes: list[str]
    grasp_ids: list[str]
    sources: list[str]
    info: list[str]
    grasp_posteriors: np.ndarray
    decisions: np.ndarray
    mode: str
    k: int
    decided: bool
    n_used: int
    final: int
    final_posteriors: np.ndarray | None = None
    running: np.ndarray | None = None
    notes: list[str] = field(default_factory=list)


def top_ties(p: np.ndarray) -> np.ndarray:
    """Indices of the classes whose posterior equals the top one (up to rounding), shape (t,)."""
    return np.flatnonzero(np.isclose(p, p.max(), rtol=1e-9, atol=1e-12))


def _ranking(p: np.ndarray, classes: list[str], top: int) -> list[str]:
    order = np.argsort(-p, kind="stable")[: top if top > 0 else None]
    width = max(len(c) for c in classes)
    lines = [f"  {r + 1:>3}. {classes[i]:<{width}}  {p[i]:.3f}" for r, i in enumerate(order)]
    tied = top_ties(p)
    if tied.size > 1:
        lines.append(f"       tie at the top: {', '.join(classes[i] for i in tied)} have equal posteriors "
                     "(the evidence cannot tell them apart; the listed first is an arbitrary pick)")
    return lines


def format_prediction(pred: Prediction, top: int = 5) -> str:
    """Human-readable report: each grasp's ranked classes, then the multi-grasp decision."""
    lines = [f"note: {n}" for n in pred.notes]
    n = len(pred.grasp_ids)
    for i in range(n):
        lines.append(f"grasp {i + 1}/{n}: {pred.grasp_ids[i]} ({pred.sources[i]}; {pred.info[i]})")
        lines += _ranking(pred.grasp_posteriors[i], pred.classes, top)
    name = lambda j: repr(pred.classes[int(j)])  # noqa: E731
    if pred.mode == "sc":
        seq = ", ".join(pred.classes[int(d)] for d in pred.decisions)
        lines.append(f"per-grasp decisions: {seq}")
        if pred.decided:
            lines.append(f"SC-MDAP (k={pred.k}): decided {name(pred.final)} after grasp {pred.n_used} of {n} "
                         f"({pred.k} equal classification{'s' if pred.k > 1 else ''})")
        else:
            count = int((pred.decisions == pred.final).sum())
            lines.append(f"SC-MDAP (k={pred.k}): NOT decided after {n} grasp{'s' if n > 1 else ''}: no class reached "
                         f"{pred.k} equal classifications (most frequent so far: {name(pred.final)}, {count} of {n})")
    else:
        assert pred.running is not None and pred.final_posteriors is not None  # DF-MDAP sets both
        seq = ", ".join(pred.classes[int(d)] for d in pred.running)
        lines.append(f"DF-MDAP decision after each grasp: {seq}")
        lines.append(f"DF-MDAP: decided {name(pred.final)} from all {n} grasp{'s' if n > 1 else ''} (eqs. 11-12):")
        lines += _ranking(pred.final_posteriors, pred.classes, top)
    return "\n".join(lines)


def prediction_report(pred: Prediction, predictor: Predictor, top: int = 5) -> dict:
    """The prediction as one JSON-serialisable object (``tzsl predict --json``).

    Returns
    -------
    dict
        ``model`` (method, kind), ``calibration``
        (:meth:`~tzsl.inference.zero_shot_bundles.Predictor.calibration_report`: whether the
        posteriors are calibrated, the temperature and how it was fitted), ``grasps`` (per
        grasp: id, source, the ``top`` classes with their posterior (0 = all), the decision),
        ``fusion`` (mode, k, decided, decision, grasps used, and DF-MDAP's final ranking), ``notes``.
    """
    def ranking(p: np.ndarray) -> list[dict]:
        order = np.argsort(-p, kind="stable")[: top if top > 0 else None]
        return [{"class": pred.classes[i], "probability": float(p[i])} for i in order]

    grasps = [{"grasp": pred.grasp_ids[i], "source": pred.sources[i], "ranking": ranking(pred.grasp_posteriors[i]),
               "decision": pred.classes[int(pred.decisions[i])]} for i in range(len(pred.grasp_ids))]
    fusion = {"mode": pred.mode, "k": pred.k, "decided": pred.decided, "decision": pred.classes[pred.final],
              "grasps_used": pred.n_used}
    if pred.final_posteriors is not None:
        fusion["ranking"] = ranking(pred.final_posteriors)
    return {"model": {"method": predictor.metadata.get("method", predictor.kind), "kind": predictor.kind},
            "calibration": predictor.calibration_report(), "grasps": grasps, "fusion": fusion,
            "notes": list(pred.notes)}
