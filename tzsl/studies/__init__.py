"""Studies: the engine, the experiment-file schema, the generic zero-shot study and the papers' presets,
each with its tables and figures."""
