"""The opening of a generic study's report: its dataset's card, then what a lab wants to know first.

:func:`dataset_card_items` says what ``tzsl validate`` knows of the dataset the run read (classes,
attributes, trials, objects, sensors, features, identical rows, attributes too rare to learn),
counted by :func:`tzsl.datasets.dataset_card` against the run's own split settings. A plain folder
is read again only when every file of it the manifest recorded still has its recorded sha256;
otherwise the card says why it is not shown. A built-in dataset is described by its registry entry.

:func:`headline` says, per split kind, which method is most accurate, with its 95% interval,
against chance and the trivial baseline (always answering the most frequent test class), and
whether any method's interval clears chance; the settings the run relaxed follow
(:func:`tzsl.reporting.manifests.relaxations`). It reads the tables through :func:`chance_verdicts`,
which the command line's summary after a run reads too (:mod:`tzsl.reporting.terminal`).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd

from tzsl._io import file_sha256
from tzsl.reporting.best_method import KIND_COLUMN, best_rows, split_kinds
from tzsl.reporting.manifests import dict_at
from tzsl.reporting.sections import POOLED_ROWS

__all__ = ["ChanceVerdict", "chance_verdicts", "dataset_card_items", "headline", "trivial_baseline"]

#: Files of a plain dataset folder whose recorded checksums must still hold before the card is read from it.
PLAIN_FILES = ("classes.csv", "trials.csv", "trials.parquet", "dataset.toml")


def _setting(record: dict, section: str, key: str, default: Any) -> Any:
    """A run's setting ``section.key``, as relaxed when the run relaxed it."""
    for item in record.get("relaxations") or []:
        if isinstance(item, dict) and item.get("setting") == f"{section}.{key}" and "used" in item:
            return item["used"]
    settings = dict_at(record, "settings")
    return (settings.get(section) or {}).get(key, default)


def _plain_items(folder: Path, record: dict) -> list[tuple[str, str]]:
    from tzsl.datasets import dataset_card, read_plain_dataset  # noqa: PLC0415 (only a generic report reads one)

    data = read_plain_dataset(folder)
    trials = data.trials.drop_duplicates("trial_id") if "trial_id" in data.trials.columns else data.trials
    card = dataset_card(data.classes, trials["class"].astype(str).tolist(),
                        n_test=int(_setting(record, "splits", "n_test", 0)),
                        min_train_positives=int(_setting(record, "splits", "random_min_train_positives", 2)),
                        min_train_negatives=int(_setting(record, "splits", "min_train_negatives", 2)))
    low, median, high = card["trials_per_class"]
    features = (f"{len(data.feature_names)} feature columns per sensor" if data.feature_names is not None
                else f"signal files, channels {', '.join(data.channels or ())}")
    groups = "; ".join(" = ".join(g) for g in card["identical_rows"])
    return [
        ("folder", str(folder)),
        ("classes", f"{card['n_classes']} ({card['n_classes_with_trials']} with trials, "
                    f"{card['n_distinct_rows']} distinct attribute rows)"),
        ("attributes", f"{data.classes.shape[1]}; classes with each: "
                       + ", ".join(f"{a} {p}" for a, p in card["positives"].items())),
        ("trials", f"{len(trials)} (per class: min {low}, median {median:g}, max {high})"),
        ("objects", str(data.trials["object_name"].nunique())),
        ("sensors", f"{len(data.sensors)} ({', '.join(data.sensors)})"),
        ("features", features),
        ("identical rows", f"{groups} (no attribute model can tell these apart)" if groups else "none"),
        ("too rare to learn", f"{', '.join(card['too_rare']) or 'none'} (fewer than {card['min_train_positives']} "
                              f"positive or {card['min_train_negatives']} negative classes)"),
    ]


def _changed(folder: Path, data_files: dict[str, str]) -> str | None:
    """Why ``folder`` no longer holds what the run read (None when its recorded files are unchanged)."""
    recorded = {Path(p): digest for p, digest in data_files.items()
                if Path(p).parent == folder and Path(p).name in PLAIN_FILES}
    for path, digest in sorted(recorded.items()):
        if not path.is_file():
            return f"{path} is gone"
        if file_sha256(path) != digest:
            return f"{path} has changed since the run (its sha256 differs from the manifest's)"
    return None if recorded else "the manifest records none of its files"


def dataset_card_items(record: dict, data_files: dict[str, str]) -> tuple[list[tuple[str, str]], str | None]:
    """The card of the dataset a generic study ``record`` ran on, as (label, text) pairs, and a note.

    Parameters
    ----------
    record : dict
        The study's manifest record (its ``settings.dataset`` names the dataset).
    data_files : dict
        The manifest's ``data_files`` (path -> sha256).

    Returns
    -------
    items : list of (str, str)
        Empty when the card cannot be read faithfully; ``note`` then says why.
    note : str or None
    """
    dataset = (record.get("settings") or {}).get("dataset") or {}
    if dataset.get("builtin"):
        from tzsl.datasets import get_dataset  # noqa: PLC0415

        entry = get_dataset(dataset["builtin"])
        return [("built-in dataset", entry.name), ("holds", entry.description), ("source", entry.source),
                ("data", "SIMULATED" if entry.simulated else "recorded")], None
    if dataset.get("features"):
        return [("feature table", str(dataset["features"]))], (
            "a feature table carries no class table of its own: run `tzsl validate` on a plain folder for a card")
    folders = sorted({Path(p).parent for p in data_files if Path(p).name == "classes.csv"})
    if len(folders) != 1:
        return [], f"the manifest records {len(folders)} class tables, so the card cannot name the dataset folder"
    why = _changed(folders[0], data_files)
    if why is not None:
        return [], f"card not shown: {why}"
    return _plain_items(folders[0], record), None


def _interval(row: pd.Series, low: str = "ci95_low", high: str = "ci95_high") -> str:
    text = f"{row['accuracy']:.3f}"
    if not (pd.isna(row.get(low)) or pd.isna(row.get(high))):
        text += f" (95% interval {row[low]:.3f}\u2013{row[high]:.3f})"
    return text


def _fusion_rows(table: pd.DataFrame, kind: str = "random") -> pd.DataFrame:
    """The mean row of a sensor-fusion table (``table1_fusion``, ``table3_challenging``) as comparison
    rows (MAXDAP, AVGDAP) on splits of ``kind``."""
    mean = table[table.iloc[:, 0].astype(str) == "mean"]
    rows = []
    for column, name in (("maxdap", "MAXDAP"), ("avgdap", "AVGDAP")):
        if column in table.columns and len(mean):
            row = mean.iloc[0]
            rows.append({"study": "", "method": name, "accuracy": row[column], "reference": "AVGDAP",
                         "ci95_low": row.get(f"{column}_ci95_low"), "ci95_high": row.get(f"{column}_ci95_high"),
                         "chance": row.get("chance"), KIND_COLUMN: kind})
    return pd.DataFrame(rows)


def trivial_baseline(fusion: pd.DataFrame | None) -> str:
    """The trivial baseline in words, from the fusion table's mean row (written with its ``majority``
    column only when test classes have unequal trial counts, :mod:`tzsl.evaluation`)."""
    if fusion is None or "chance" not in fusion.columns:
        return "the trivial baseline is not in these results"
    mean = fusion[fusion.iloc[:, 0].astype(str) == "mean"]
    if "majority" in fusion.columns and len(mean) and not pd.isna(mean.iloc[0]["majority"]):
        return f"trivial baseline (always the most frequent test class) {mean.iloc[0]['majority']:.3f}"
    return "trivial baseline (always the most frequent test class) equal to chance: every test class has as many trials"


@dataclass(frozen=True)
class ChanceVerdict:
    """The methods of one comparison group (study, split kind) against chance.

    Attributes
    ----------
    best : Series
        The group's most accurate row (:func:`tzsl.reporting.best_method.best_rows`: ties in table
        order), with its ``kind`` and ``beats_reference``.
    group : DataFrame
        Every row of the group that ran, in table order.
    clear : DataFrame
        The rows of ``group`` whose 95% interval lies above chance (``ci95_low > chance``).
    """

    best: pd.Series
    group: pd.DataFrame
    clear: pd.DataFrame

    @property
    def kind(self) -> str:
        return str(self.best[KIND_COLUMN])


def chance_verdicts(tables: dict[str, pd.DataFrame], every_kind: bool = False) -> list[ChanceVerdict]:
    """Per comparison group, the most accurate method and the methods whose interval clears chance.

    Parameters
    ----------
    tables : dict
        File stem -> table of a run: the method comparisons (stems ending ``method_comparison``)
        when there are any, else the sensor-fusion table ``table1_fusion`` (its mean row).
    every_kind : bool
        Also a split kind no comparison covers, from its DAP-only table (``table1_fusion`` for random
        splits, ``table3_challenging`` for challenging ones): MAXDAP and AVGDAP.

    Returns
    -------
    list of ChanceVerdict
        Empty when the tables hold neither comparisons nor a fusion table.
    """
    fusion = tables.get("table1_fusion")
    compared = [t for stem, t in tables.items() if stem.endswith("method_comparison")
                and {"method", "accuracy", "chance", "study", "reference"} <= set(t.columns)]
    if not compared and fusion is not None:
        compared = [_fusion_rows(fusion)]
    out = [verdict for table in compared for verdict in _verdicts_of(table)]
    if every_kind:
        covered = {v.kind for v in out}
        for stem, kind in (("table1_fusion", "random"), ("table3_challenging", "challenging")):
            if kind not in covered and stem in tables:
                out += _verdicts_of(_fusion_rows(tables[stem], kind))
    return out


def _verdicts_of(table: pd.DataFrame) -> list[ChanceVerdict]:
    """The verdicts of one comparison table, a group per (study, split kind, purpose) best row."""
    if not {"method", "accuracy"} <= set(table.columns):
        return []
    ran = table[table["accuracy"].notna() & ~table["method"].astype(str).isin(POOLED_ROWS)]
    if ran.empty:
        return []
    kinds = split_kinds(ran)
    out = []
    for _, best in best_rows(ran).iterrows():
        group = ran[(ran["study"] == best["study"]) & (kinds == best[KIND_COLUMN])]
        clear = group[group["ci95_low"].astype(float) > group["chance"].astype(float)] \
            if "ci95_low" in group.columns else group.iloc[:0]
        out.append(ChanceVerdict(best, group, clear))
    return out


def headline(tables: dict[str, pd.DataFrame]) -> list[str]:
    """Sentences on the best method of each split kind against chance and the trivial baseline.

    Parameters
    ----------
    tables : dict
        File stem -> table of the folder: the method comparisons (stems ending ``method_comparison``)
        when there are any, else the sensor-fusion table ``table1_fusion`` (its mean row).

    Returns
    -------
    list of str
        Empty when the folder has neither.
    """
    baseline = trivial_baseline(tables.get("table1_fusion"))
    out = []
    for verdict in chance_verdicts(tables):
        best, group, clear = verdict.best, verdict.group, verdict.clear
        text = (f"On {verdict.kind} splits the most accurate method is {best['method']}: accuracy {_interval(best)}, "
                f"against chance {best['chance']:.3f} and the {baseline}. ")
        if clear.empty:
            text += (f"No method's interval clears chance ({len(group)} compared): these results do not show "
                     "any method recognising unseen classes better than guessing.")
        else:
            text += (f"{len(clear)} of {len(group)} methods have an interval above chance"
                     + (f" ({', '.join(map(str, clear['method']))})." if len(clear) <= 6 else "."))
        out.append(text)
    return out
