"""Built-in experiment files (``tzsl run NAME``), shipped as package data."""
