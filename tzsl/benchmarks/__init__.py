"""Benchmarks shipped with the command line: ``tzsl bench`` and ``make bench`` / ``make bench-scale``."""
