"""Inference for robots: model bundles, ``tzsl predict`` inputs, the next-EP suggestion and :class:`Recogniser`.

:class:`Recogniser` loads a bundle once and ranks grasps as they arrive (the Python side of
``tzsl predict``). Importing this package imports neither scikit-learn nor torch: a bundle
imports what its model needs when it is loaded.
"""

from tzsl.inference.recogniser import Recogniser

__all__ = ["Recogniser"]
