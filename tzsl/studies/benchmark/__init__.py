"""The cross-dataset benchmark (``tzsl benchmark``): every method on every dataset, compared across datasets.

:mod:`~tzsl.studies.benchmark.statistics` turns the long table of per-split scores into the
per-dataset table, the mean ranks, the Friedman and Iman-Davenport tests, Nemenyi's critical
difference and a random-effects meta-analysis of paired differences (Demšar 2006; MOABB);
:mod:`~tzsl.studies.benchmark.figures` draws the critical-difference diagram and the forest plot.
"""
