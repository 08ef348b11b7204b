"""Inference for robots: model bundles, ``tzsl predict`` inputs and the next-EP suggestion."""
