"""Early stopping of the CNN + LSTM: epochs chosen by class-grouped validation on training classes only."""

from __future__ import annotations

import numpy as np
import pytest

from tzsl.models import DeepAttributeEmbedding, ZSLInputError
from tzsl.models.embedding.deep._training import best_epoch
from tzsl.models.protocol import class_grouped_folds

# 6 classes with distinct attribute rows: folds of 2 held-out rows
A6 = np.array([[1, 0, 1, 0], [0, 1, 1, 0], [1, 1, 0, 1], [0, 0, 1, 1], [1, 0, 0, 1], [0, 1, 0, 0]], dtype=float)


@pytest.fixture
def torch():
    torch = pytest.importorskip("torch", reason="PyTorch is not installed (pip install 'tzsl[deep]')")
    before = torch.get_num_threads()
    torch.set_num_threads(1)
    yield torch
    torch.set_num_threads(before)


def sequences(n_per_class=4, size=12, n_frames=3, seed=0):
    """Tiny frame sequences whose class shows in brightness and stripe frequency."""
    rng = np.random.default_rng(seed)
    y = np.repeat(np.arange(len(A6)), n_per_class)
    xx = np.arange(size)[None, None, None, :]
    k = y[:, None, None, None]
    X = 100 + 20 * k + 40 * np.sin(xx * (k + 1) * 0.4) + rng.normal(0, 5, (len(y), n_frames, size, size))
    return np.clip(X, 0, 255).astype(np.uint8), y


def tiny(**kw):
    params = dict(backbone="small-cnn", finetune=0, hidden_size=6, epochs=5, batch_size=8, lr=3e-2,
                  random_state=0, n_threads=1)
    return DeepAttributeEmbedding(**{**params, **kw})


def test_best_epoch_prefers_accuracy_then_likelihood_then_fewer_epochs():
    acc = np.array([[0.5, 0.75, 0.75, 0.5], [0.5, 0.75, 0.75, 0.25]])
    assert best_epoch(acc, np.array([[-1.0, -0.9, -0.8, 0], [-1.0, -0.9, -0.8, 0]])) == 3  # tie on acc: loglik
    assert best_epoch(acc, np.full((2, 4), -1.0)) == 2  # full tie: fewer epochs
    assert best_epoch(np.array([[0.0, 0.0, 1.0]]), np.zeros((1, 3))) == 3


def test_class_grouped_folds_hold_out_whole_classes():
    groups = np.repeat(np.arange(6), 3)
    folds = class_grouped_folds(groups, 5, "test")
    assert len(folds) == 3
    held = [set(groups[va]) for _, va in folds]
    assert all(len(h) == 2 for h in held) and set().union(*held) == set(range(6))
    for tr, va in folds:
        assert not set(groups[tr]) & set(groups[va])
    with pytest.raises(ZSLInputError, match="at least 4 training classes"):
        class_grouped_folds(np.repeat(np.arange(3), 2), 5, "test")


def test_early_stopping_trains_the_chosen_epochs_on_all_training_classes(torch):
    X, y = sequences()
    train = y < 5  # class 5 never reaches fit: it plays the unseen class
    model = tiny(early_stopping=True).fit(X[train], y[train], A6[:5])
    assert model.validation_accuracy_.shape == (2, 5) == model.validation_loglik_.shape  # 5 rows: 2 folds
    assert ((model.validation_accuracy_ >= 0) & (model.validation_accuracy_ <= 1)).all()
    chosen = best_epoch(model.validation_accuracy_, model.validation_loglik_)
    assert model.best_epoch_ == chosen == model.n_epochs_ == len(model.loss_curve_)
    # the final network is a plain fit of that many epochs (same seed): selection leaves no trace
    plain = tiny(epochs=chosen).fit(X[train], y[train], A6[:5])
    np.testing.assert_allclose(model.transform(X[~train]), plain.transform(X[~train]), rtol=1e-5, atol=1e-6)
    assert plain.best_epoch_ == chosen and plain.validation_accuracy_ is None


def test_early_stopping_needs_four_training_rows(torch):
    X, y = sequences()
    keep = y < 3
    with pytest.raises(ZSLInputError, match="at least 4 training classes"):
        tiny(early_stopping=True).fit(X[keep], y[keep], A6[:3])
