"""The method comparison every study writes: registry methods fitted and scored the same way in every study
(:mod:`~tzsl.studies.comparison.method_runs`) and the calibration of their class posteriors with the
reliability diagrams (:mod:`~tzsl.studies.comparison.calibration`)."""
