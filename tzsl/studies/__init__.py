"""Studies: the engine (:mod:`~tzsl.studies.engine`) and the studies ``reproduce-tables`` and ``evidence`` run
(:mod:`~tzsl.studies.reproduce`) at the top; in subpackages the experiment-file schema and the study registry
(``config``), what a run writes and records (``outputs``), the method comparison every study shares
(``comparison``), the papers' numbers (``papers``), the generic zero-shot study and the papers' presets
(``zero_shot``, ``fabric``, ``hand``, ``active_touch``), each with its tables and figures, and the built-in
experiment files (``builtin``)."""
