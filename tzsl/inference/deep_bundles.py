"""Deep-model bundles (kind ``"deep"``): the CNN + LSTM's weights as arrays, written and read here.

The file is a :mod:`tzsl.inference.bundle` bundle (magic line, JSON header with the tzsl version
and sha256 checksums, optional HMAC) whose payload is an ``.npz`` archive (read without pickle)
holding no torch object: the network's state dict as numpy arrays, the training classes and their
attribute table (:func:`tzsl.models.embedding.deep_model_arrays`). The header metadata holds the
parameters, the input shape and the training history. Frozen stages of a pretrained backbone are
not stored; the metadata records the sha256 of their weights file, which loading checks. Loading
needs the ``deep`` extra (torch); ``tzsl predict`` reads these bundles through
:func:`tzsl.inference.zero_shot_bundles.load_predictor`.
"""

from __future__ import annotations

from pathlib import Path

from tzsl.inference.bundle import load_bundle, save_bundle
from tzsl.inference.bundle_kinds import DEEP_KIND

__all__ = ["load_deep_bundle", "save_deep_bundle"]


def save_deep_bundle(model, path, *, force: bool = False) -> Path:
    """Save a fitted :class:`~tzsl.models.DeepAttributeEmbedding` as a bundle of kind ``"deep"``.

    Parameters
    ----------
    model : DeepAttributeEmbedding
        Fitted.
    path : str or path-like
        Destination (e.g. ``model.tzsl-deep``).
    force : bool, default=False
        Replace an existing file.

    Returns
    -------
    Path
    """
    from tzsl.models.embedding import deep_model_arrays  # noqa: PLC0415 - imports torch

    arrays, metadata = deep_model_arrays(model)
    return save_bundle(path, arrays, kind=DEEP_KIND, metadata=metadata, force=force)


def load_deep_bundle(path, *, weights_path=None, trust_pickle: bool = False):
    """Load a bundle written by :func:`save_deep_bundle`.

    Parameters
    ----------
    path : str or path-like
    weights_path : str or path-like or None
        Where the frozen backbone's weights file is on this machine, when the model was trained
        from a local file (VGG-16) at another path. Its sha256 must equal the recorded one.
    trust_pickle : bool, default=False
        Also load an old (format version 1) bundle, whose payload is a pickle that can run code
        when loaded: only for files whose author you trust. Current bundles hold an ``.npz``.

    Returns
    -------
    DeepAttributeEmbedding
        Fitted, ready for ``predict`` (``checkpoint_dir``, ``cache_dir`` and ``resume`` are reset).

    Raises
    ------
    ModelBundleError
        Not a bundle, corrupt or tampered with, saved by another tzsl version, not a deep model,
        or backbone weights that differ from the ones it was trained with.
    """
    from tzsl.models.embedding import deep_model_from_arrays  # noqa: PLC0415 - imports torch

    path = Path(path)
    arrays, metadata = load_bundle(path, expected_kind=DEEP_KIND, trust_pickle=trust_pickle)
    return deep_model_from_arrays(arrays, metadata, where=str(path), weights_path=weights_path)
