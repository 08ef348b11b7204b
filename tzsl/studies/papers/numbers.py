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

#: Fabric paper Table 1: zero-shot accuracy of the CNN+LSTM embedding for each lambda of the loss
#: ``C + lambda R`` and of ESZSL, on the GelSight press videos (train classes 2, 3, 4, 5, 7 of the
#: paper, i.e. 0-indexed groups 1, 2, 3, 4, 6; tzsl fabric config 1). The paper prints percent;
#: stored here as fractions. row (Flat / Fold / Rand / Average) -> column ("0", "0.1", "1", "10",
#: "inf", "ESZSL") -> accuracy. The paper's caption reads "inf" as the classification term C only;
#: tzsl's ``EmbeddingZSL(lam="inf")`` is the regression term R only (see tzsl.models.embedding._embedding).
FABRIC_TABLE1: dict[str, dict[str, float]] = {
    "Flat": {"0": 0.6357, "0.1": 0.6701, "1": 0.6014, "10": 0.6529, "inf": 0.6460, "ESZSL": 0.5738},
    "Fold": {"0": 0.8941, "0.1": 0.8613, "1": 0.8722, "10": 0.8412, "inf": 0.8320, "ESZSL": 0.7603},
    "Rand": {"0": 0.7340, "0.1": 0.8230, "1": 0.7930, "10": 0.7460, "inf": 0.7340, "ESZSL": 0.7123},
    "Average": {"0": 0.7545, "0.1": 0.7848, "1": 0.7555, "10": 0.7467, "inf": 0.7373, "ESZSL": 0.6821},
}

#: DAP paper Table 5 (section 5.8.2): single-grasp accuracy on the test objects of the Shadow-hand
#: experiment, by object subset. method -> {subset: accuracy}; subsets as in ``hand_table4.csv``.
DAP_HAND_TABLE5: dict[str, dict[str, float]] = {
    "maxdap": {"homogeneous": 0.7778, "heterogeneous_shape": 0.4483, "heterogeneous_material": 0.20, "all": 0.5229},
    "avgdap": {"homogeneous": 0.7778, "heterogeneous_shape": 0.50, "heterogeneous_material": 0.3333, "all": 0.5688},
    "ldap": {"homogeneous": 0.75, "heterogeneous_shape": 0.5517, "heterogeneous_material": 0.40, "all": 0.5963},
}

#: Section 5.8.3: best single-grasp accuracy (LDAP, all test objects).
DAP_HAND_SINGLE_GRASP_BEST: float = 0.5963
#: Section 5.8.3 / Fig. 12: settings of the multi-grasp confusion matrices (DF-MDAP T, SC-MDAP k).
DAP_HAND_CONFUSION_T: int = 5
DAP_HAND_CONFUSION_K: int = 4
#: Section 5.8.3: "the best accuracies were obtained between k = 2 and k = 4" (SC-MDAP).
DAP_HAND_SC_BEST_K_RANGE: tuple[int, int] = (2, 4)
#: Fig. 12 caption / section 6: SC-MDAP (k = 4) "achieved perfect recognition of 8 out of 10 new objects".
DAP_HAND_SC_OBJECTS_PERFECT: tuple[int, int] = (8, 10)
#: Section 5.8.1: mean attribute classification accuracy on the test grasps, and the one attribute quoted.
DAP_HAND_MEAN_ATTRIBUTE_ACCURACY: float = 0.89
DAP_HAND_ATTRIBUTE_ACCURACY_QUOTED: dict[str, float] = {"plastic": 0.45}
#: Section 5.5: test objects were grasped "up to 15 times" (the longest grasp sequence).
DAP_HAND_MAX_TEST_GRASPS: int = 15

#: The DAP paper's PHAC-2 protocol (section 4.1-4.2): the built-in datasets that are its data (the
#: Penn features and the raw release), 10 test objects per random split, attributes kept when
#: present in >= 3 objects. Its numbers are shown only beside runs on this dataset and protocol.
DAP_PAPER_DATASETS: tuple[str, ...] = ("phac2-penn", "phac2-h5")
DAP_N_TEST: int = 10
DAP_MIN_OBJECTS: int = 3
