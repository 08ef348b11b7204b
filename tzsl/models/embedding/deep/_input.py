"""Input checks and torch helpers of the deep model (:mod:`tzsl.models.embedding.deep._model`); torch is lazy."""

from __future__ import annotations

import contextlib
import hashlib
import importlib

import numpy as np

from tzsl.exceptions import TzslError
from tzsl.models._zsl_input import ZSLInputError

_INSTALL_HINT = 'install the deep extra: pip install "tzsl[deep]"'
# Sequences per chunk when extracting frozen features (bounds memory to chunk x T frames).
FEATURE_CHUNK = 16


def require_torch():
    """Import and return torch, or raise a TzslError saying how to install it."""
    try:
        return importlib.import_module("torch")
    except ImportError:
        raise TzslError(f"the deep model needs PyTorch, which is not installed; {_INSTALL_HINT}") from None


def deep_nets():
    """The torch-based module :mod:`tzsl.models.embedding.deep._backbones` (imports torch)."""
    require_torch()
    from tzsl.models.embedding.deep import _backbones  # noqa: PLC0415 - lazy: torch is optional

    return _backbones


def sha256_arrays(*arrays) -> str:
    digest = hashlib.sha256()
    for a in arrays:
        a = np.ascontiguousarray(a)
        digest.update(f"{a.dtype.str}{a.shape}".encode())
        digest.update(a.data if a.dtype != object else repr(a.tolist()).encode())
    return digest.hexdigest()


def validate_frames(X, name: str, expected: tuple | None = None) -> np.ndarray:
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
def torch_threads(torch, n_threads):
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


def pixel_stats(X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
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

