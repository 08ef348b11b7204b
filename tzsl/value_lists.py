"""The value lists that the experiment schema, the command line and the code all read, each written once.

This module imports nothing, so the schema (:mod:`tzsl.studies.config`) and the command line can read
it without importing the models. The order of :data:`FUSIONS` and :data:`PRIORS` is the order of the
DAP paper's Tables 1 and 2, which the study's tables keep.
"""

__all__ = ["FUSIONS", "JOBLIB_BACKENDS", "PRIORS", "SPLIT_KINDS", "SPLIT_SOURCES", "STUDY_BACKENDS"]

#: How DAP fuses the attribute posteriors of several sensors (DAP paper, Table 1: MAXDAP, AVGDAP).
FUSIONS: tuple[str, ...] = ("max", "avg")
#: The attribute prior ``p(a_m)`` of the DAP rule (DAP paper, Table 2): uniform 0.5, the test
#: classes' attribute frequencies, the training classes'.
PRIORS: tuple[str, ...] = ("uni", "test", "train")
#: Unseen-class splits drawn from a dataset: random object splits and the challenging (map) partitions.
SPLIT_KINDS: tuple[str, ...] = ("random", "challenging")
#: Where a study's splits come from: :data:`SPLIT_KINDS`, or a split file (``kinds = ["file"]``).
SPLIT_SOURCES: tuple[str, ...] = (*SPLIT_KINDS, "file")
#: The joblib backends the fit store and the attribute banks run on.
JOBLIB_BACKENDS: tuple[str, ...] = ("loky", "dask", "threading", "multiprocessing", "sequential")
#: The backends a study file (``[compute] backend``) and ``--backend`` offer.
STUDY_BACKENDS: tuple[str, ...] = ("loky", "dask")
