"""What a study run writes and records: the results folder (:mod:`~tzsl.studies.outputs.results_folder`:
atomic files, no silent overwrite, the manifest), the failures of single fits
(:mod:`~tzsl.studies.outputs.failures`), what every runner returns
(:mod:`~tzsl.studies.outputs.study_run`: :class:`~tzsl.studies.outputs.study_run.StudyRun`) and the study
cache that keeps and restores a finished study's outputs (:mod:`~tzsl.studies.outputs.study_cache`)."""
