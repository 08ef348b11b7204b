"""tzsl: tactile zero-shot learning.

Recognise objects a robot has never touched from their attribute description, by learning
attribute detectors from touch data of other objects (DAP, ESZSL, learned embeddings).

Layers (lower never imports higher): ``tzsl.datasets`` (readers, registry, plain format:
files -> arrays + trial table), ``tzsl.features`` (scikit-learn transformers), ``tzsl.models``
(scikit-learn estimators and the method registry), ``tzsl.evaluation`` (splits, metrics,
intervals, baselines), ``tzsl.studies`` (the engine, the experiment-file schema, the generic
zero-shot study and the papers' presets with their tables and figures), ``tzsl.reporting`` (HTML
report, generated README blocks), ``tzsl.inference`` (model bundles, ``predict``, next-EP
suggestion), ``tzsl.benchmarks`` and ``tzsl.cli`` (the ``tzsl`` command).

``tzsl.run(FILE_OR_NAME, **overrides)`` runs a study (an experiment file or a built-in study
such as ``"phac2-dap"``) and returns its main table as a DataFrame; see
:func:`tzsl.studies.engine.run`.
"""

from tzsl.exceptions import TzslError

__version__ = "0.1.0"

__all__ = ["TzslError", "__version__", "run"]


def __getattr__(name: str):
    """``tzsl.run``: imported on first use, so ``import tzsl`` stays light."""
    if name == "run":
        from tzsl.studies.engine import run  # noqa: PLC0415

        return run
    raise AttributeError(f"module 'tzsl' has no attribute {name!r}")
