"""The report's sections: which tables and figures each shows, under a heading named for what it shows.

Every section has a generic heading and text; the sections of the papers' tables also have the
paper's heading and text, used only in the report of a paper study
(:func:`tzsl.reporting.manifests.is_paper_record`). A text quotes counts (test objects per split,
splits, attributes) through placeholders filled from the section's own tables (:func:`fill`),
never from a constant: a placeholder the tables cannot fill takes its parenthesis with it.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import pandas as pd

__all__ = ["SECTIONS", "Section", "fill", "table_facts"]


@dataclass(frozen=True)
class Section:
    """One part of the report: the files that show it and what was run.

    Attributes
    ----------
    key : str
        Its anchor on the page.
    title, what : str
        Heading and text of any study (``{dataset}`` and the placeholders of :func:`table_facts`).
    tables, figures : tuple of str
        File stems (found anywhere in the folder) it shows, in order.
    simulated : bool
        Its tables come from simulated grasps unless a manifest says otherwise.
    paper_title, paper_what : str or None
        The paper's heading and text, in the report of a paper study (None: the generic ones).
    """

    key: str
    title: str
    what: str
    tables: tuple[str, ...] = ()
    figures: tuple[str, ...] = ()
    simulated: bool = False
    paper_title: str | None = None
    paper_what: str | None = None

    def heading(self, paper: bool) -> tuple[str, str]:
        """(title, text) for a paper study's report or any other."""
        if paper:
            return self.paper_title or self.title, self.paper_what or self.what
        return self.title, self.what


_FUSION = ("per-sensor attribute posteriors fused by their maximum or average. The control row rescores the same "
           "posteriors with the test attribute rows shuffled among the test classes: it must be at chance. "
           "Intervals: per-split rows resample test classes, the mean row resamples splits and test classes.")

#: Report order (the papers' where they have one).
SECTIONS: tuple[Section, ...] = (
    Section("benchmark", "The benchmark: every method on every dataset, compared across datasets",
            "tzsl benchmark: each dataset's standard splits, per-class mean accuracy with its 95% interval over the "
            "splits, chance and the gain over it (datasets); each method's mean rank across datasets (ranks) with "
            "the Friedman test and Nemenyi's critical difference (friedman; diagram: methods joined by a bar do not "
            "differ significantly, Demsar 2006); every pair of methods' paired difference on shared splits, pooled "
            "across datasets by a random-effects meta-analysis (meta_analysis; forest plot against the generic "
            "default). Each dataset's own study follows in the sections below.",
            tables=("datasets", "ranks", "friedman", "meta_analysis", "defaults"),
            figures=("critical_difference", "meta_analysis")),
    Section("fusion", "Sensor fusion on random unseen-class splits: MAXDAP and AVGDAP",
            "DAP on random splits of {dataset} ({n_splits} random splits of {n_test_objects} unseen classes each), "
            "uniform attribute prior; " + _FUSION,
            tables=("table1_fusion",),
            paper_title="DAP paper, Table 1: sensor fusion (MAXDAP vs AVGDAP)",
            paper_what="DAP on PHAC-2 random object splits ({n_test_objects} test objects each), uniform attribute "
                       "prior; " + _FUSION),
    Section("priors", "Attribute priors: uniform, training-set and test-set",
            "AVGDAP on the same random splits with a uniform, training-set or test-set attribute prior.",
            tables=("table2_priors",), paper_title="DAP paper, Table 2: attribute priors"),
    Section("challenging", "Challenging splits: unseen classes from one region of the feature map",
            "{n_splits} splits from a 2-D PCA map of the classes' mean features, each testing on the classes of "
            "one region of the map ({n_objects} unseen classes per split); MAXDAP and AVGDAP.",
            tables=("table3_challenging", "object_map"), figures=("object_map",),
            paper_title="DAP paper, Table 3 and Fig. 3: challenging splits",
            paper_what="{n_splits} splits from a 2-D PCA map of the objects' haptic features, each testing on one "
                       "region of the map ({n_objects} test objects per split); MAXDAP and AVGDAP; partition "
                       "numbering is arbitrary, so only the means compare with the paper (which reports AVGDAP only)."),
    Section("attributes", "Attribute accuracy: how well each attribute is recognised on unseen classes",
            "Test accuracy of every attribute classifier over the random splits and sensors; balanced "
            "accuracy is the headline, beside the per-attribute majority baseline.",
            tables=("attribute_accuracy", "attribute_accuracy_per_split"), figures=("attribute_accuracy",),
            paper_title="DAP paper, Fig. 4: attribute accuracy"),
    Section("sweep", "Accuracy against the number of attributes",
            "AVGDAP with random subsets of j attributes ({n_attributes} attributes), on the random splits.",
            tables=("attribute_sweep",), figures=("attribute_sweep",),
            paper_title="DAP paper, section 4.7: accuracy vs number of attributes"),
    Section("multilabel", "Independent or joint (multi-label) attribute classifiers",
            "AVGDAP, uniform prior, with attribute classifiers fitted one by one or jointly.",
            tables=("multilabel",),
            paper_title="DAP paper, section 4.4: independent vs multi-label attribute classifiers"),
    Section("methods", "Every method on the same splits",
            "Every compared method on the study's own splits and test trials: accuracy with its 95% interval, "
            "chance, seconds per fit, and the paired difference to the reference method (named in the table). "
            "Methods a study cannot run are listed with the reason.",
            tables=("method_comparison", "phac2_method_comparison", "phac2_methods", "fabric_method_comparison",
                    "hand_method_comparison"),
            paper_title="Every method x study, on the same splits",
            paper_what="Every registered method on each study's own splits and test trials: accuracy with its 95% "
                       "interval [the paper's number where it has one], chance, seconds per fit, and the paired "
                       "difference to the paper's method of the study (PHAC-2: DAP-AVG, uniform prior; fabric: the "
                       "embedding at lambda 0.1; hand: LDAP, on SIMULATED grasps). Methods a study cannot run are "
                       "listed with the reason."),
    Section("calibration", "Calibration: do the class posteriors mean what they say?",
            "Each method's class posterior on the test classes against what happened: ECE (trials sorted by top-class "
            "probability into equal-size bins; the trial-weighted mean gap between mean probability and share right) "
            "and the multi-class Brier score, with 95% intervals resampling splits and test classes (method comparison "
            "columns ece, brier; *_uncalibrated: the method's own posterior; ece_if_calibrated: the ECE a perfectly "
            "calibrated posterior shows on as many trials). The calibrator is one temperature per method and split, "
            "fitted on pseudo-unseen classes of the training classes: rankings and accuracy are unchanged. Reliability "
            "diagram, one panel per method: accuracy against mean top-class probability per bin; below the diagonal "
            "is over-confident.",
            tables=("reliability", "phac2_reliability", "fabric_reliability", "hand_reliability"),
            figures=("reliability", "phac2_reliability", "fabric_reliability", "hand_reliability")),
    Section("gzsl", "Generalised zero-shot recognition: seen and unseen classes together",
            "Seen and unseen classes compete; seen-class test trials are held-out trials of training "
            "classes. Per-class mean accuracy on seen and unseen classes and their harmonic mean.",
            tables=("gzsl",)),
    Section("active-touch", "Active touch: choosing the next exploratory procedure",
            "Per-EP attribute models and a sequential zero-shot posterior updated after each EP; the active "
            "policy picks the EP with the largest expected class-entropy reduction (confusion from grouped CV on "
            "training objects), against every fixed EP order (first:<ep> = the best order starting "
            "with that EP on training objects), the recording order and a random order. "
            "best_fixed_test_optimistic is chosen on the test trials (an upper bound, not a method). The "
            "stopping table gives accuracy when the top posterior reaches a threshold, the paired difference to "
            "running every EP, and the EPs and seconds saved. The posterior is tempered (exponents fitted on "
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
    Section("fabric-table1", "Fabric groups: the embedding model per lambda and ESZSL",
            "Fabric groups as classes, depth-image features; the embedding model for each lambda and ESZSL.",
            tables=("fabric_table1", "fabric_partitions", "fabric_runs"), figures=("fabric_lambda",),
            paper_title="Fabric paper, Table 1: accuracy per lambda and ESZSL",
            paper_what="Fabric groups as classes, depth-image features; the embedding model for each lambda and ESZSL. "
                       "In the a8 attribute matrix groups 3, 4 and 5 share one row, so the paper's split "
                       "(protocol 'paper') is not zero-shot for test group 5; it is kept as a reproduction row. "
                       "The headline is the 'zero-shot-drop' variant (group 5 dropped from the test set, training "
                       "unchanged) and its per-class mean accuracy (the _pcma columns). fabric_partitions: ESZSL on "
                       "every valid partition of the groups into >= 4 test groups and the rest (a12 attributes; a8 has "
                       "none), mean over partitions (interval resampling partitions and test groups) beside chance and "
                       "the majority baseline."),
    Section("fabric-deep", "Deep attribute embedding on GelSight frames",
            "The end-to-end network on GelSight frames.",
            tables=("fabric_deep_table", "fabric_deep_runs"), paper_title="Fabric paper: deep attribute embedding"),
    Section("hand-table5", "Hand: one grasp and multi-grasp fusion",
            "LDAP and multi-grasp fusion on grasps of a dexterous hand.",
            tables=("hand_table5", "hand_multigrasp_T", "hand_multigrasp_k", "hand_confusion",
                    "hand_attribute_accuracy", "hand_attribute_distance"),
            figures=("hand_multigrasp_T", "hand_multigrasp_k", "hand_confusion", "hand_attribute_accuracy",
                     "hand_attribute_distance"),
            simulated=True, paper_title="DAP paper, Table 5 and section 5.8: hand study"),
)

#: Count columns whose per-split values :func:`table_facts` reads (placeholder = column name).
COUNT_COLUMNS = ("n_test_objects", "n_objects", "n_attributes")

#: First-column labels of rows that pool or summarise splits (not a split).
POOLED_ROWS = ("mean", "std", "sd", "average", "control")


def _span(values: pd.Series) -> str | None:
    """``"5"`` or ``"3-5"`` for whole numbers (None when there is none)."""
    numbers = pd.to_numeric(values, errors="coerce").dropna()
    if numbers.empty or not (numbers == numbers.round()).all():
        return None
    low, high = int(numbers.min()), int(numbers.max())
    return str(low) if low == high else f"{low}\u2013{high}"


def table_facts(tables: list[pd.DataFrame]) -> dict[str, str]:
    """Counts a section's text quotes, read from its tables (first table that has each).

    ``n_splits``: the rows of the first table with a ``split`` column that are one split each
    (not mean, std or control rows); ``n_test_objects``, ``n_objects``, ``n_attributes``: the
    value (or its range) of that column over such rows.
    """
    facts: dict[str, str] = {}
    for table in tables:
        if "split" not in table.columns:
            continue
        per_split = table[~table["split"].astype(str).str.lower().isin(POOLED_ROWS)]
        if "n_splits" not in facts and len(per_split):
            facts["n_splits"] = str(per_split["split"].nunique())
        for column in COUNT_COLUMNS:
            span = _span(per_split[column]) if column in per_split.columns else None
            if span is not None:
                facts.setdefault(column, span)
    return facts


_PLACEHOLDER = re.compile(r"\{(\w+)\}")


def fill(text: str, facts: dict[str, str]) -> str:
    """``text`` with its ``{placeholders}`` from ``facts``; a parenthesis (or a leading count) whose
    placeholder ``facts`` lacks is left out, so no sentence quotes a number the results do not hold."""
    def missing(part: str) -> bool:
        return any(name not in facts for name in _PLACEHOLDER.findall(part))

    text = re.sub(r" ?\([^()]*\)", lambda m: "" if missing(m.group(0)) else m.group(0), text)
    text = re.sub(r"^\{(\w+)\} (\w)", lambda m: m.group(0) if m.group(1) in facts else m.group(2).upper(), text)
    return _PLACEHOLDER.sub(lambda m: facts.get(m.group(1), m.group(0)), text)
