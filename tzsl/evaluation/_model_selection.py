"""Model selection on training classes only: the embedding model's weight decay by class-grouped CV.

Zero-shot hyper-parameters must be chosen without the test classes. :func:`select_embedding_alpha`
holds out whole training classes (classes sharing an attribute row together) and scores how well
the held-out samples are recognised among the held-out classes' attribute rows - the zero-shot
situation in miniature, as :class:`tzsl.models.ESZSLCV` tunes ESZSL.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence

import numpy as np
from sklearn.exceptions import ConvergenceWarning

from tzsl.exceptions import ConfigError
from tzsl.fit_store import fit_cached
from tzsl.models import build_method
from tzsl.models.protocol import (
    DEFAULT_SCORING,
    attribute_rows,
    best_within_tolerance,
    class_grouped_folds,
    heldout_scores,
)

__all__ = ["DEFAULT_ALPHAS", "select_embedding_alpha"]

#: Weight-decay grid of the embedding model, strongest first (ties go to the strongest).
DEFAULT_ALPHAS: tuple[float, ...] = (1.0, 0.1, 0.01, 0.001)


def select_embedding_alpha(
    X: np.ndarray,
    y: np.ndarray,
    class_attributes: np.ndarray,
    *,
    lam,
    alphas: Sequence[float] = DEFAULT_ALPHAS,
    random_state=None,
    max_iter: int = 500,
    scoring: str = DEFAULT_SCORING,
) -> tuple[float, np.ndarray | None]:
    """Weight decay of :class:`EmbeddingZSL` by class-grouped CV on training classes only.

    Classes with identical attribute rows are one CV group. :func:`tzsl.models.protocol.class_grouped_folds`
    makes ``min(5, n_groups // 2)`` folds holding out whole groups (at least 2 per fold, at
    least 2 trained on; a merged group never alone); each fold
    trains ``EmbeddingZSL(lam, alpha, early_stopping=False)`` on the rest and scores how well it
    recognises the held-out samples among the held-out groups' attribute rows (the zero-shot
    situation) by ``scoring`` (:func:`tzsl.models.protocol.heldout_scores` on the class scores; by
    default accuracy). The alpha with the
    best mean score wins; scores within :data:`tzsl.models.protocol.TIE_TOLERANCE` of the best are
    tied and the largest tied alpha (the strongest weight decay) is chosen.

    Parameters
    ----------
    X : ndarray of shape (n_samples, d)
        Training samples.
    y : ndarray of shape (n_samples,)
        Training labels.
    class_attributes : ndarray of shape (n_classes, m)
        One row per class of ``np.unique(y)``.
    lam : float or "inf"
        The loss weight of the model being tuned.
    alphas : sequence of float
        Candidate weight decays; a single value is returned without CV.
    random_state : int or None
        Seed of the fold models.
    max_iter : int
        L-BFGS iterations of each fit.
    scoring : {"accuracy", "balanced_accuracy", "neg_log_loss"}
        The held-out criterion (higher is better).

    Returns
    -------
    alpha : float
    scores : ndarray of shape (n_alphas, n_folds) or None
        Held-out criterion of each alpha in each fold (None without CV).

    Raises
    ------
    ConfigError
        Empty grid or non-positive alpha.
    ZSLInputError
        Fewer than 4 distinct training attribute rows.
    """
    alphas = [float(a) for a in alphas]
    if not alphas or any(not np.isfinite(a) or a < 0 for a in alphas):
        raise ConfigError(f"alphas must be a non-empty sequence of numbers >= 0; got {alphas}")
    if len(alphas) == 1:
        return alphas[0], None
    y = np.asarray(y)
    S = np.asarray(class_attributes, dtype=np.float64)
    classes = np.unique(y)
    S_u, merged = np.unique(S, axis=0, return_inverse=True)
    merged = merged.ravel()
    grp = merged[np.searchsorted(classes, y)]
    folds = class_grouped_folds(grp, 5, "class-grouped selection of alpha (pass a single alpha to skip it)")
    scores = np.empty((len(alphas), len(folds)))
    for f, (tr, va) in enumerate(folds):
        tr_classes = np.unique(y[tr])
        va_groups, y_va = np.unique(grp[va], return_inverse=True)
        S_tr = S[np.searchsorted(classes, tr_classes)]
        for a, alpha in enumerate(alphas):
            with warnings.catch_warnings():
                # a fold fit stopped at max_iter is still scored (weakly regularised fits on
                # 2 classes can take long); the final fit records its convergence
                warnings.simplefilter("ignore", ConvergenceWarning)
                model = fit_cached(build_method(  # a selection fit needs no calibrated posterior
                    "embedding", lam=lam, alpha=alpha, early_stopping=False, max_iter=max_iter,
                    random_state=random_state, calibration="none",
                ), X[tr], attribute_rows(y[tr], S_tr), y[tr])
            scores[a, f] = heldout_scores(model.decision_function(X[va], S_u[va_groups]), y_va.ravel(), scoring)
    best = best_within_tolerance(scores.mean(axis=1), (np.asarray(alphas),))[0]
    return alphas[best], scores
