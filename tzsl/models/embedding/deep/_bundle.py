"""The deep model as arrays and back: what its bundle (:mod:`tzsl.inference.deep_bundles`) stores.

:func:`deep_model_arrays` gives a fitted :class:`DeepAttributeEmbedding`'s weights (no torch
object: the network's state dict as numpy arrays), training classes and attribute table, and the
metadata that rebuilds it; :func:`deep_model_from_arrays` rebuilds the fitted model from them.
Frozen stages of a pretrained backbone are not stored; the metadata records the sha256 of their
weights file, which :func:`deep_model_from_arrays` checks.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from sklearn.utils.validation import check_is_fitted

from tzsl.exceptions import ModelBundleError, TzslError
from tzsl.models.embedding.deep._input import require_torch
from tzsl.models.embedding.deep._model import DeepAttributeEmbedding

__all__ = ["deep_model_arrays", "deep_model_from_arrays"]


def _jsonable(value):
    if isinstance(value, Path):
        return str(value)
    if isinstance(value, np.generic):
        return value.item()
    return value


def deep_model_arrays(model: DeepAttributeEmbedding) -> tuple[dict, dict]:
    """The arrays and metadata of a fitted deep model (the payload and metadata of its bundle).

    Returns
    -------
    arrays : dict
        ``state_dict`` (name -> ndarray, the stored stages), ``classes`` (n_classes,),
        ``class_attributes`` (n_classes, n_attributes) float64.
    metadata : dict
        JSON-serialisable: ``model``, ``torch_version``, ``params``, ``sequence_shape``,
        ``n_attributes``, ``backbone_sha256``, ``loss_curve``, ``epoch_times``, ``n_epochs``.
    """
    torch = require_torch()
    check_is_fitted(model)
    arrays = {
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
    return arrays, metadata


def deep_model_from_arrays(arrays: dict, meta: dict, *, where: str, weights_path=None) -> DeepAttributeEmbedding:
    """Rebuild the fitted model of :func:`deep_model_arrays`'s output.

    Parameters
    ----------
    arrays, meta : dict
        As :func:`deep_model_arrays` returns them (read back from a bundle).
    where : str
        The bundle, for messages.
    weights_path : str or path-like or None
        Where the frozen backbone's weights file is on this machine, when the model was trained
        from a local file (VGG-16) at another path. Its sha256 must equal the recorded one.

    Returns
    -------
    DeepAttributeEmbedding
        Fitted, ready for ``predict`` (``checkpoint_dir``, ``cache_dir`` and ``resume`` are reset).

    Raises
    ------
    ModelBundleError
        Arrays or metadata that are not a deep model's, or backbone weights that differ from the
        ones it was trained with.
    """
    torch = require_torch()
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
        state = {k: torch.as_tensor(np.asarray(v)) for k, v in arrays["state_dict"].items()}
        classes = np.asarray(arrays["classes"])
        S = np.asarray(arrays["class_attributes"], dtype=np.float64)
    except (KeyError, TypeError, ValueError, TzslError) as exc:
        raise ModelBundleError(f"{where}: not a valid deep-model bundle ({type(exc).__name__}: {exc})") from None
    probe = model._build_net(n_attributes, shape[-1], load_weights=False)
    if model._frozen_prefixes(probe):
        try:
            net = model._build_net(n_attributes, shape[-1], load_weights=True)
        except TzslError as exc:
            raise ModelBundleError(f"{where}: cannot load the backbone weights the model needs: {exc}") from None
        if net.backbone.weights_sha256 != stored_sha:
            raise ModelBundleError(
                f"{where}: the backbone weights file differs from the one the model was trained with "
                f"(sha256 {net.backbone.weights_sha256} vs {stored_sha})"
            )
    else:
        net = probe
        net.backbone.weights_sha256 = stored_sha
    model._load_stored_state(net, state, where)
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
