"""Numbers printed in the two papers, typed by hand, so every table shows them beside ours.

Sources
-------
DAP paper: ``../shared/papers/haptic_zsl_dap.txt`` (Abderrahmane et al., haptic zero-shot
learning with DAP), Tables 1, 2, 3 and 5 and the text of sections 4.4 and 5.8.
Fabric paper: ``../shared/papers/fabric_zsl_gelsight.txt``, Table 1.
"""

from __future__ import annotations

#: DAP paper Table 1: ZSL accuracy, independent attribute classifiers, uni-prior. split -> (MAXDAP, AVGDAP)
DAP_TABLE1: dict[str, tuple[float, float]] = {
    "1": (0.48, 0.48),
    "2": (0.38, 0.36),
    "3": (0.38, 0.38),
    "4": (0.35, 0.35),
    "5": (0.35, 0.36),
    "average": (0.39, 0.39),
}

#: DAP paper Table 2: AVGDAP accuracy by attribute prior. split -> (uni, test, train)
DAP_TABLE2: dict[str, tuple[float, float, float]] = {
    "1": (0.48, 0.24, 0.36),
    "2": (0.38, 0.33, 0.28),
    "3": (0.38, 0.39, 0.32),
    "4": (0.35, 0.39, 0.38),
    "5": (0.35, 0.33, 0.29),
    "average": (0.39, 0.34, 0.33),
}

#: DAP paper Table 3: challenging splits. split -> (number of objects, random accuracy, AVGDAP)
DAP_TABLE3: dict[str, tuple[int | None, float | None, float]] = {
    "1": (11, 0.09, 0.18),
    "2": (7, 0.14, 0.21),
    "3": (7, 0.14, 0.30),
    "4": (10, 0.10, 0.22),
    "5": (11, 0.09, 0.27),
    "average": (None, None, 0.24),
}

#: DAP paper section 4.4: average accuracy of the multi-label (joint) attribute classifier vs independent.
DAP_MULTILABEL_ACCURACY: float = 0.31
DAP_INDEPENDENT_ACCURACY: float = 0.39

#: DAP paper section 4.4 / Fig. 2: mean attribute classification accuracy over splits and BioTacs.
DAP_MEAN_ATTRIBUTE_ACCURACY: float = 0.78
#: Per-attribute accuracies quoted in the text of section 4.4 (the figure's other bars are not printed).
DAP_ATTRIBUTE_ACCURACY_QUOTED: dict[str, float] = {"solid": 0.92, "smooth": 0.64, "textured": 0.64}
