"""Studies: compose data, features, models and evaluation; write tables, figures, manifest."""
