"""Model bundles of the deep model: :func:`save_deep_bundle`, :func:`load_deep_bundle` (kind ``"deep"``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from sklearn.utils.validation import check_is_fitted

from tzsl.exceptions import ModelBundleError, TzslError
from tzsl.models._deep import DeepAttributeEmbedding
from tzsl.models._deep_input import require_torch

__all__ = ["BUNDLE_KIND", "load_deep_bundle", "save_deep_bundle"]

#: ``kind`` of deep-model bundles in :mod:`tzsl.bundle`.
BUNDLE_KIND = "deep"


def _jsonable(value):
    if isinstance(value, Path):
        return str(value)
    if isinstance(value, np.generic):
        return value.item()
    return value


def save_deep_bundle(model, path, *, force: bool = False) -> Path:
    """Save a fitted :class:`DeepAttributeEmbedding` as a tzsl model bundle (kind ``"deep"``).

    The file is a :mod:`tzsl.bundle` bundle (magic line, JSON header with the tzsl version and
    sha256 checksums, optional HMAC). Its payload is an ``.npz`` archive (read without pickle) holding
    no torch object: the network's state dict as numpy arrays, the training classes and their attribute table. The header metadata
    holds the parameters, the input shape and the training history. Frozen stages of a pretrained
    backbone are not stored; the metadata records the sha256 of their weights file, which
    :func:`load_deep_bundle` checks.

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
    from tzsl.bundle import save_bundle  # noqa: PLC0415

    torch = require_torch()
    check_is_fitted(model)
    payload = {
        "state_dict": {k: v.detach().cpu().numpy() for k, v in model._stored_state(model.net_).items()},
        "classes": np.asarray(model.classes_),
        "class_attributes": np.asarray(model.class_attributes_, dtype=np.float64),
    }
    metadata = {
        "model": type(model).__name__,
        "torch_version": str(torch.__version__),
        "params": {k: _jsonable(v) for k, v in model.get_params().items()},
        "sequence_shape": list(model.sequence_shape_),
        "n_attributes": int(model.n_attributes_),
        "backbone_sha256": model.backbone_sha256_,
        "loss_curve": [float(v) for v in model.loss_curve_],
        "epoch_times": [float(v) for v in model.epoch_times_],
        "n_epochs": int(model.n_epochs_),
    }
    return save_bundle(path, payload, kind=BUNDLE_KIND, metadata=metadata, force=force)


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
    from tzsl.bundle import load_bundle  # noqa: PLC0415

    torch = require_torch()
    path = Path(path)
    payload, meta = load_bundle(path, expected_kind=BUNDLE_KIND, trust_pickle=trust_pickle)
    try:
        params = dict(meta["params"])
        params.update(checkpoint_dir=None, cache_dir=None, resume=False)
        if weights_path is not None:
            params["weights_path"] = str(weights_path)
        model = DeepAttributeEmbedding(**params)
        model._check_params()
        shape = tuple(int(s) for s in meta["sequence_shape"])
        n_attributes = int(meta["n_attributes"])
        stored_sha = meta["backbone_sha256"]
        state = {k: torch.as_tensor(np.asarray(v)) for k, v in payload["state_dict"].items()}
        classes = np.asarray(payload["classes"])
        S = np.asarray(payload["class_attributes"], dtype=np.float64)
    except (KeyError, TypeError, ValueError, TzslError) as exc:
        raise ModelBundleError(f"{path}: not a valid deep-model bundle ({type(exc).__name__}: {exc})") from None
    probe = model._build_net(n_attributes, shape[-1], load_weights=False)
    if model._frozen_prefixes(probe):
        try:
            net = model._build_net(n_attributes, shape[-1], load_weights=True)
        except TzslError as exc:
            raise ModelBundleError(f"{path}: cannot load the backbone weights the model needs: {exc}") from None
        if net.backbone.weights_sha256 != stored_sha:
            raise ModelBundleError(
                f"{path}: the backbone weights file differs from the one the model was trained with "
                f"(sha256 {net.backbone.weights_sha256} vs {stored_sha})"
            )
    else:
        net = probe
        net.backbone.weights_sha256 = stored_sha
    model._load_stored_state(net, state, str(path))
    net.eval()
    for p in net.parameters():
        p.requires_grad_(False)
    model.net_ = net.to(model.device)
    model.classes_ = classes
    model.class_attributes_ = S
    model.n_attributes_ = n_attributes
    model.sequence_shape_ = shape
    model.loss_curve_ = [float(v) for v in meta.get("loss_curve", [])]
    model.epoch_times_ = [float(v) for v in meta.get("epoch_times", [])]
    model.feature_time_ = 0.0
    model.n_epochs_ = int(meta.get("n_epochs", 0))
    model.backbone_sha256_ = stored_sha
    return model

