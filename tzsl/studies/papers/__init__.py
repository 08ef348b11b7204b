"""The papers' own numbers (:mod:`~tzsl.studies.papers.numbers`, typed from the papers) and when a run shows
them: how a zero-shot run labels its tables and whether it follows the paper's protocol
(:mod:`~tzsl.studies.papers.run_labels`)."""
