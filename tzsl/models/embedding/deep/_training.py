"""Training of the deep model: epochs, checkpoints, and the number of epochs chosen on training classes.

:class:`DeepTrainingMixin` holds the training half of
:class:`~tzsl.models.DeepAttributeEmbedding` (the estimator, its parameters and inference are in
:mod:`tzsl.models.embedding.deep._model`).

Early stopping (``early_stopping=True``) is a nested, class-grouped selection of the number of
epochs on the training classes only - the zero-shot situation in miniature, as the classical
embedding's weight decay is tuned (:func:`tzsl.evaluation.select_embedding_alpha`):

1. the distinct training attribute rows are split into ``min(5, n_rows // 2)`` folds by
   :func:`class_grouped_folds` (at least 2 rows held out per fold);
2. for each fold the network (same initial weights as the final fit) trains up to ``epochs``
   epochs on the other rows' sequences; after every epoch the held-out sequences are recognised
   among the held-out rows only (nearest attribute vector) and the held-out log-likelihood
   ``log softmax(-||f - a||^2)`` of the true row is recorded;
3. the epoch count with the best mean held-out accuracy wins (ties: the better mean
   log-likelihood, then the fewer epochs), and the final network trains that many epochs on every
   training sequence.

Pixel and CNN-feature standardisation statistics are computed once on all training sequences
(no labels used) and shared by the fold fits. Test sequences are never seen.
"""

from __future__ import annotations

import hashlib
import os
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from tzsl._io import atomic_write
from tzsl._progress import progress_bar
from tzsl.exceptions import ConfigError
from tzsl.models._zsl_input import class_grouped_folds
from tzsl.models.embedding.deep._input import FEATURE_CHUNK, deep_nets, pixel_stats, require_torch, sha256_arrays

__all__ = ["DeepTrainingMixin", "best_epoch"]

_CHECKPOINT = "checkpoint.pt"


def best_epoch(accuracy: np.ndarray, loglik: np.ndarray) -> int:
    """Epoch count (1-based) with the best mean held-out accuracy; ties: better log-likelihood, then fewer.

    ``accuracy``, ``loglik``: shape (n_folds, n_epochs).
    """
    acc, ll = np.asarray(accuracy).mean(axis=0), np.asarray(loglik).mean(axis=0)
    epochs = np.arange(acc.size)
    order = np.lexsort((epochs, -ll, -acc))  # last key first: accuracy, then log-likelihood, then fewer
    return int(order[0]) + 1


class DeepTrainingMixin:
    """Training of :class:`~tzsl.models.DeepAttributeEmbedding` (see the module docstring) and its
    frozen CNN features (computed once per fit, cached in memory and on disk)."""

    if TYPE_CHECKING:  # what the estimator provides: its parameters and network helpers (declared, never set here)
        backbone: str
        epochs: int
        batch_size: int
        early_stopping: bool
        checkpoint_dir: str | os.PathLike[str] | None
        cache_dir: str | os.PathLike[str] | None
        resume: bool
        verbose: bool
        device: str

        def _build_net(self, n_attributes: int, n_channels: int, *, load_weights: bool = True) -> Any: ...
        def _n_trainable(self, net: Any) -> int: ...
        def _train_mode(self, net: Any) -> None: ...
        def _make_optimizer(self, net: Any) -> Any: ...
        def _stored_state(self, net: Any) -> dict: ...
        def _load_stored_state(self, net: Any, state: dict, what: str, error: type[Exception] = ...) -> None: ...

    def _fit_torch(self, torch, X, y_u, S_u, weights, seed, fingerprint) -> None:
        net = self._build_net(S_u.shape[1], X.shape[-1]).to(self.device)
        mean, std = pixel_stats(X)
        net.pixel_mean.copy_(torch.as_tensor(mean, dtype=torch.float32).reshape(1, -1, 1, 1))
        net.pixel_std.copy_(torch.as_tensor(std, dtype=torch.float32).reshape(1, -1, 1, 1))
        start = time.perf_counter()
        feats = self._frozen_features(net, X, disk=True)  # initial features: their statistics, and the cache
        self.feature_time_ = time.perf_counter() - start
        f_std = feats.reshape(-1, feats.shape[-1]).std(dim=0)
        net.feature_mean.copy_(feats.reshape(-1, feats.shape[-1]).mean(dim=0))
        net.feature_std.copy_(torch.where(f_std > 1e-6, f_std, torch.ones_like(f_std)))
        if self._n_trainable(net) > 0:
            self.__dict__.pop("_feature_cache", None)  # features change while training
            feats = None

        epochs = int(self.epochs)
        self.validation_accuracy_ = self.validation_loglik_ = None
        if self.early_stopping:
            initial = {k: v.clone() for k, v in net.state_dict().items()}
            acc, ll = self._validation_curves(torch, net, X, feats, y_u, S_u, weights, seed, initial)
            net.load_state_dict(initial)
            self.validation_accuracy_, self.validation_loglik_ = acc, ll
            epochs = best_epoch(acc, ll)
        self.best_epoch_ = epochs

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

        rows = torch.arange(X.shape[0])
        bar = progress_bar(range(first_epoch, epochs), show=self.verbose, desc="epochs", unit="epoch",
                           initial=first_epoch, total=epochs)
        for epoch in bar:
            t0 = time.perf_counter()
            self.loss_curve_.append(self._epoch(torch, net, opt, gen, X, feats, rows, y_t, L, weights))
            self.epoch_times_.append(time.perf_counter() - t0)
            bar.set_postfix(loss=f"{self.loss_curve_[-1]:.4f}")
            if ckpt is not None:
                self._save_checkpoint(torch, ckpt, net, opt, gen, fingerprint, epoch + 1)
        bar.close()
        net.eval()
        for p in net.parameters():
            p.requires_grad_(False)
        self.net_ = net
        self.n_epochs_ = max(first_epoch, epochs)
        self.backbone_sha256_ = net.backbone.weights_sha256

    def _epoch(self, torch, net, opt, gen, X, feats, rows, y_t, L, weights) -> float:
        """One pass over the sequences ``rows`` (tensor of indices) in a random order; mean loss."""
        w_c, w_r = weights
        nets = deep_nets()
        self._train_mode(net)
        order = rows[torch.randperm(rows.shape[0], generator=gen)]
        bs, total = int(self.batch_size), 0.0
        for lo in range(0, order.shape[0], bs):
            idx = order[lo : lo + bs]
            F = self._embed(torch, net, X, feats, idx)
            loss = nets.f15_loss(F, L, y_t[idx].to(self.device), w_c, w_r)
            opt.zero_grad()
            loss.backward()
            opt.step()
            total += float(loss.detach()) * idx.shape[0]
        return total / order.shape[0]

    def _embed(self, torch, net, X, feats, idx):
        """Attribute estimates ``f`` (len(idx), m) of the sequences ``idx`` (frozen features or frames)."""
        if feats is not None:
            return net.embed(feats[idx].to(self.device))
        seq = torch.from_numpy(np.ascontiguousarray(X[idx.numpy()], dtype=np.float32))
        return net(seq.to(self.device))

    def _validation_curves(self, torch, net, X, feats, y_u, S_u, weights, seed, initial):
        """Held-out accuracy and log-likelihood (n_folds, epochs) of every class-grouped fold."""
        folds = class_grouped_folds(y_u, 5, "early stopping of DeepAttributeEmbedding")
        acc = np.zeros((len(folds), int(self.epochs)))
        ll = np.zeros_like(acc)
        for f, (tr, va) in enumerate(folds):
            net.load_state_dict(initial)
            tr_rows, y_tr = np.unique(y_u[tr], return_inverse=True)
            va_rows, y_va = np.unique(y_u[va], return_inverse=True)
            y_fold = np.full(len(y_u), -1)
            y_fold[tr] = y_tr.ravel()
            L = torch.as_tensor(S_u[tr_rows], dtype=torch.float32, device=self.device)
            S_va = torch.as_tensor(S_u[va_rows], dtype=torch.float32, device=self.device)
            y_va_t = torch.as_tensor(y_va.ravel(), dtype=torch.long)
            self._train_mode(net)
            opt = self._make_optimizer(net)
            gen = torch.Generator().manual_seed(seed + 2 + f)
            rows_tr, rows_va = torch.as_tensor(tr), torch.as_tensor(va)
            y_t = torch.as_tensor(y_fold, dtype=torch.long)
            for e in range(int(self.epochs)):
                self._epoch(torch, net, opt, gen, X, feats, rows_tr, y_t, L, weights)
                net.eval()
                with torch.no_grad():
                    F = torch.cat([self._embed(torch, net, X, feats, rows_va[lo : lo + FEATURE_CHUNK])
                                   for lo in range(0, rows_va.shape[0], FEATURE_CHUNK)]).cpu()
                    scores = -((F[:, None, :] - S_va.cpu()[None]) ** 2).sum(dim=2)
                    acc[f, e] = float((scores.argmax(dim=1) == y_va_t).float().mean())
                    logp = torch.log_softmax(scores, dim=1)
                    ll[f, e] = float(logp[torch.arange(len(y_va_t)), y_va_t].mean())
        return acc, ll

    # ------------------------------------------------------------------ frozen features
    def _feature_key(self, net, X: np.ndarray) -> str:
        parts = [
            sha256_arrays(X),
            self.backbone,
            str(net.backbone.weights_sha256),
            str(net.image_size),
            sha256_arrays(net.pixel_mean.cpu().numpy(), net.pixel_std.cpu().numpy()),
        ]
        if self.backbone == "small-cnn":  # random weights: key them too
            parts.append(sha256_arrays(*[t.cpu().numpy() for t in net.backbone.state_dict().values()]))
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
            except Exception:  # noqa: BLE001  # torch.load raises many kinds; a damaged cache file is recomputed
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
        n, t = X.shape[:2]
        out = torch.empty(n, t, net.backbone.out_features)
        net.eval()
        starts = range(0, n, FEATURE_CHUNK)
        with torch.no_grad():
            for lo in progress_bar(starts, show=self.verbose, desc="CNN features", unit="chunk", leave=False):
                chunk = torch.from_numpy(np.ascontiguousarray(X[lo : lo + FEATURE_CHUNK], dtype=np.float32))
                b = chunk.shape[0]
                feats = net.frame_features(chunk.reshape(b * t, *chunk.shape[2:]).to(self.device))
                out[lo : lo + b] = feats.reshape(b, t, -1).cpu()
        return out

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
        except Exception as exc:  # noqa: BLE001  # torch.load raises many kinds; each is reported with the file
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
