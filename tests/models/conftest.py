"""Fixtures shared by the attribute-model tests: a zero-shot problem whose answer is known."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest


@dataclass(frozen=True)
class ZeroShotProblem:
    """Trials of ``n_classes`` classes whose 0/1 attribute rows are linearly encoded in X.

    ``X = S[y] @ M + noise`` with a random mixing matrix ``M`` (n_attributes, n_features). The first
    ``n_train`` classes train; the rest are the unseen test classes. ``n_train`` exceeds the number
    of attributes so the training rows span attribute space and unseen rows are identifiable.
    """

    X: np.ndarray  # (n_trials, n_features)
    y: np.ndarray  # (n_trials,) class index
    S: np.ndarray  # (n_classes, n_attributes) distinct 0/1 rows
    n_train: int

    @property
    def train(self) -> np.ndarray:
        return self.y < self.n_train

    @property
    def X_train(self) -> np.ndarray:
        return self.X[self.train]

    @property
    def A_train(self) -> np.ndarray:
        """Attribute row of each training trial's class, (n_train_trials, n_attributes)."""
        return self.S[self.y[self.train]]

    @property
    def X_test(self) -> np.ndarray:
        return self.X[~self.train]

    @property
    def S_test(self) -> np.ndarray:
        """Attribute rows of the unseen classes, (n_test_classes, n_attributes)."""
        return self.S[self.n_train :]

    @property
    def y_test(self) -> np.ndarray:
        """Row of ``S_test`` each test trial belongs to."""
        return self.y[~self.train] - self.n_train

    @property
    def chance(self) -> float:
        return 1.0 / (self.S.shape[0] - self.n_train)


def make_zero_shot_problem(
    *, seed=0, n_classes=24, n_train=16, n_attributes=10, n_features=30, per_class=20, noise=1.0
) -> ZeroShotProblem:
    rng = np.random.default_rng(seed)
    while True:
        S = rng.integers(0, 2, (n_classes, n_attributes)).astype(float)
        if len(np.unique(S, axis=0)) == n_classes:
            break
    mixing = rng.normal(size=(n_attributes, n_features))
    y = np.repeat(np.arange(n_classes), per_class)
    X = S[y] @ mixing + noise * rng.normal(size=(y.size, n_features))
    return ZeroShotProblem(X=X, y=y, S=S, n_train=n_train)


@pytest.fixture
def zero_shot_problem():
    """Factory: ``zero_shot_problem(seed=...)`` -> :class:`ZeroShotProblem` (24 classes, 16 train)."""
    return make_zero_shot_problem
