"""What an attribute classifier's training shares, exact (RBF-SVM) or approximate (Nystroem).

Option names, the training error, the default preprocessor, class-balanced under-sampling of whole
objects, balanced sample weights, Platt scaling and the grid-edge record, used by
:class:`~tzsl.models.AttributeSVM`, :class:`~tzsl.models.ScalableAttributeClassifier` and
:class:`~tzsl.models.AttributeClassifierBank`.
"""

from __future__ import annotations

from numbers import Integral

import numpy as np
from scipy.special import expit, log_expit
from sklearn.base import BaseEstimator
from sklearn.model_selection import LeaveOneGroupOut

from tzsl.exceptions import ConfigError, SplitError
from tzsl.features import VariancePCA
from tzsl.models.detectors._grouped_folds import stratified_group_fold_masks

__all__ = [
    "AUTO_MAX_EXACT_TRIALS",
    "MIN_OBJECTS_PER_LABEL",
    "PLATT_WEIGHTING",
    "SCORING",
    "SOLVERS",
    "UNDERSAMPLING",
    "AttributeTrainingError",
    "GRIDS",
    "balanced_object_draws",
    "balanced_sample_weights",
    "binary_training_targets",
    "check_label_objects",
    "cv_criteria",
    "default_preprocessor",
    "fit_platt",
    "fit_platt_many",
    "gamma_grid",
    "grid_edges",
    "object_balanced_weights",
    "object_grouped_folds",
]

#: Fewest training objects with each value (present, absent) of an attribute an attribute bank learns: its
#: object-grouped CV folds need both values in more than one object.
MIN_OBJECTS_PER_LABEL = 2


def check_label_objects(A: np.ndarray, groups: np.ndarray, names) -> None:
    """Refuse an attribute present (or absent) in fewer than :data:`MIN_OBJECTS_PER_LABEL` training objects.

    Parameters
    ----------
    A : ndarray of shape (n_trials, n_attributes)
        0/1 attribute targets of the training trials.
    groups : ndarray of shape (n_trials,)
        The object of each trial.
    names : sequence of str
        The attributes, for the message.

    Raises
    ------
    AttributeTrainingError
        Naming the first such attribute, its value and its object count.
    """
    for j, name in enumerate(names):
        for label, mask in (("present", A[:, j] == 1), ("absent", A[:, j] == 0)):
            k = np.unique(groups[mask]).size
            if k < MIN_OBJECTS_PER_LABEL:
                raise AttributeTrainingError(f"attribute {name!r}: {label} in only {k} training object(s); need at "
                                             f"least {MIN_OBJECTS_PER_LABEL} (leave the attribute out of this split)")

UNDERSAMPLING = ("select", "bagging", "none")
SOLVERS = ("exact", "approximate", "auto")
AUTO_MAX_EXACT_TRIALS = 2000
SCORING = ("log_loss", "balanced_accuracy")
PLATT_WEIGHTING = ("balanced", "empirical")
#: ``grid`` options: the paper's log-spaced ``gamma`` grid, that grid with lower decades added, or
#: the extended grid widened at whichever end of the ``C`` or ``gamma`` grid the search chose.
GRIDS = ("paper", "extended", "adaptive")
#: Decades of ``gamma`` that ``grid="extended"`` adds below the low end of ``gamma_range``.
EXTENDED_GAMMA_DECADES = 2


def grid_edges(chosen: dict[str, tuple[np.ndarray, int]]) -> list[tuple[str, float, str]]:
    """``(name, value, "low" | "high")`` for each chosen grid index at an end of a grid of >= 2 points."""
    edges = []
    for name, (grid, i) in chosen.items():
        if grid.size >= 2 and i in (0, grid.size - 1):
            edges.append((name, float(grid[i]), "low" if i == 0 else "high"))
    return edges


def cv_criteria(oof: np.ndarray, yb: np.ndarray, w_cal: np.ndarray, scoring: str) -> tuple[np.ndarray, np.ndarray]:
    """Grouped-CV criterion and Platt sigmoid of every configuration of an attribute SVM search, all at once.

    Parameters
    ----------
    oof : ndarray of shape (..., n_train)
        Out-of-fold SVM scores (unitless) of each configuration.
    yb : bool ndarray of shape (n_train,)
    w_cal : ndarray of shape (n_train,)
        Platt sample weights.
    scoring : {"log_loss", "balanced_accuracy"}

    Returns
    -------
    crit : ndarray of shape (..., 2)
        (criterion, tie-break), lower is better: class-weighted log-loss of the Platt posteriors
        (nats) and 0, or minus the balanced accuracy of the score's sign and the log-loss.
    platt : ndarray of shape (..., 2)
        Each configuration's ``(a, b)`` (:func:`fit_platt_many`).
    """
    flat = oof.reshape(-1, oof.shape[-1])
    a, b = fit_platt_many(flat, yb, w_cal)
    z = a[:, None] * flat + b[:, None]
    ll = -(w_cal * np.where(yb, log_expit(z), log_expit(-z))).sum(axis=1) / w_cal.sum()
    if scoring == "log_loss":
        crit = np.stack([ll, np.zeros_like(ll)], axis=1)
    else:
        pred = flat > 0
        bacc = 0.5 * (pred[:, yb].mean(axis=1) + (~pred[:, ~yb]).mean(axis=1))
        crit = np.stack([-bacc, ll], axis=1)
    shape = oof.shape[:-1] + (2,)
    return crit.reshape(shape), np.stack([a, b], axis=1).reshape(shape)


def gamma_grid(gamma_range, n_gamma: int, grid: str) -> np.ndarray:
    """The ``gamma`` values an RBF attribute classifier tunes over, ascending.

    Parameters
    ----------
    gamma_range : (float, float)
        Ends of the paper's log-spaced grid (``(0.01, 1.0)``: DAP paper section 4.4).
    n_gamma : int
        Points of that grid.
    grid : {"paper", "extended", "adaptive"}
        ``"paper"``: ``np.geomspace(*gamma_range, n_gamma)``. ``"extended"`` (and ``"adaptive"``,
        which starts from it and widens it during the search): the same points
        plus ``gamma_range[0] * 10**-k`` for ``k = 1 .. EXTENDED_GAMMA_DECADES`` (0.001 and
        0.0001 for the paper's range): on PHAC-2 most grouped-CV choices sit on the paper's low
        edge 0.01, and with about 25 z-scored PCA components (squared distances of order 50)
        ``gamma = 1e-4`` is close to a linear kernel, so the extended grid spans linear to local.

    Returns
    -------
    ndarray of shape (n_gamma,) or (n_gamma + EXTENDED_GAMMA_DECADES,)
        In units of squared preprocessed features^-1.
    """
    paper = np.geomspace(float(gamma_range[0]), float(gamma_range[1]), int(n_gamma))
    if grid == "paper":
        return paper
    low = float(gamma_range[0]) * 10.0 ** -np.arange(EXTENDED_GAMMA_DECADES, 0, -1)
    return np.concatenate([low, paper])


class AttributeTrainingError(SplitError, ValueError):
    """An attribute cannot be learned from the training objects of a split.

    A :class:`tzsl.exceptions.SplitError` (and a ``ValueError``, as scikit-learn expects of
    estimators given unusable targets).
    """


def binary_training_targets(y: np.ndarray, groups, label: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Classes, "present" mask and object groups of one attribute's training trials, checked.

    Parameters
    ----------
    y : ndarray of shape (n_trials,)
        Two class labels; the larger (``np.unique`` order) is "present".
    groups : array-like of shape (n_trials,) or None
        Object of each trial; ``None``: every trial is its own object.
    label : str
        Names the attribute in messages.

    Returns
    -------
    classes : ndarray of shape (2,)
    yb : ndarray of bool, shape (n_trials,)
    groups : ndarray of shape (n_trials,)

    Raises
    ------
    AttributeTrainingError
        Not exactly two classes, or a class held by fewer than 2 objects (it cannot be
        cross-validated over objects).
    ConfigError
        ``groups`` of the wrong shape.
    """
    classes = np.unique(y)
    if classes.size != 2:
        raise AttributeTrainingError(
            f"{label}: training labels hold {classes.size} class(es); need exactly 2 "
            "(absent and present). Only binary classification is supported."
        )
    yb = y == classes[1]
    n = yb.size
    groups = np.arange(n) if groups is None else np.asarray(groups)
    if groups.shape != (n,):
        raise ConfigError(f"groups must have shape ({n},), got {groups.shape}")
    for cls, mask in ((classes[1], yb), (classes[0], ~yb)):
        n_obj = np.unique(groups[mask]).size
        if n_obj < 2:
            value = cls.item() if isinstance(cls, np.generic) else cls  # 1, not np.int64(1)
            raise AttributeTrainingError(
                f"{label}: only {n_obj} training object(s) with label {value!r}; "
                "need at least 2 (one class present in a single object cannot be cross-validated)"
            )
    return classes, yb, groups


def default_preprocessor() -> BaseEstimator:
    """Z-score then PCA keeping 95% of the variance, capped at 25 components (DAP paper §4.3).

    Returns
    -------
    tzsl.features.VariancePCA
        ``VariancePCA(variance=0.95, max_components=25)``, unfitted.
    """
    return VariancePCA(variance=0.95, max_components=25)


#: Newton iterations of :func:`fit_platt_many` (it converges in well under 20 on SVM scores).
PLATT_MAX_ITER = 100
#: A problem stops when its Newton step is below this (in the conditioned parameters) or its
#: Newton decrement below 1e-15 of its loss (nothing left to gain at double precision).
PLATT_STEP_TOL = 1e-10


def _platt_loss(theta: np.ndarray, u: np.ndarray, t: np.ndarray, w: np.ndarray,
                t_neg: np.ndarray | None = None) -> np.ndarray:
    """Weighted cross-entropy of ``expit(theta[:, 0] * u + theta[:, 1])`` to targets ``t``; shape (k,).

    ``t_neg``: ``1.0 - t`` when the caller has it already (the same numbers)."""
    z = theta[:, :1] * u + theta[:, 1:]
    return -(w * (t * log_expit(z) + ((1.0 - t) if t_neg is None else t_neg) * log_expit(-z))).sum(axis=1)


def fit_platt_many(
    scores: np.ndarray, y: np.ndarray, sample_weight: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Fit Platt's sigmoid ``p(y = 1 | s) = expit(a * s + b)`` to many score vectors at once.

    Uses Platt's (1999) smoothed targets ``(N+ + 1) / (N+ + 2)`` and ``1 / (N- + 2)``, which keep
    the fit finite on separable scores, and Newton's method with backtracking (Lin, Lin and Weng
    2007) on all rows together: one array operation per iteration for every problem. The slope
    is constrained to ``a >= 0``: the loss is strictly convex, so where the unconstrained
    optimum has ``a < 0`` the constrained one is ``a = 0`` with ``b`` the logit of the weighted
    mean target (closed form). Rows with constant scores get ``a = 0`` and that ``b``.

    Parameters
    ----------
    scores : ndarray of shape (k, n)
        Classifier scores (SVM decision values, unitless) of ``k`` problems on the same trials.
    y : ndarray of shape (n,)
        0/1 labels.
    sample_weight : ndarray of shape (n,), optional
        Non-negative weights.

    Returns
    -------
    a, b : ndarray of shape (k,)
        Slope and intercept of each row's logit.
    """
    s = np.atleast_2d(np.asarray(scores, dtype=float))
    y = np.asarray(y).astype(bool)
    w = np.ones(s.shape[1]) if sample_weight is None else np.asarray(sample_weight, dtype=float)
    n_pos, n_neg = int(y.sum()), int((~y).sum())
    t = np.where(y, (n_pos + 1.0) / (n_pos + 2.0), 1.0 / (n_neg + 2.0))
    scale = s.std(axis=1)
    flat = ~(scale > 0)
    scale[flat] = 1.0
    u = (s - s.mean(axis=1, keepdims=True)) / scale[:, None]  # conditioning only; undone below
    w_pos, w_neg = w[y].sum(), w[~y].sum()
    theta = np.zeros((s.shape[0], 2))
    theta[:, 1] = np.log((w_pos + 1.0) / (w_neg + 1.0))
    t_neg = 1.0 - t
    loss = _platt_loss(theta, u, t, w, t_neg)
    active = ~flat
    for _ in range(PLATT_MAX_ITER):
        act = np.flatnonzero(active)
        if act.size == 0:
            break
        # every row still active (the first iterations): the arrays themselves, not copies of them
        ua, th = (u, theta.copy()) if act.size == u.shape[0] else (u[act], theta[act])
        p = expit(th[:, :1] * ua + th[:, 1:])
        r, h = w * (p - t), w * p * (1.0 - p)
        hu = h * ua  # h * ua * ua is (h * ua) * ua: computed once for both sums
        g = np.stack([(r * ua).sum(axis=1), r.sum(axis=1)], axis=1)  # (k_active, 2)
        h_aa, h_ab, h_bb = (hu * ua).sum(axis=1) + 1e-12, hu.sum(axis=1), h.sum(axis=1) + 1e-12
        det = h_aa * h_bb - h_ab**2
        step = -np.stack([h_bb * g[:, 0] - h_ab * g[:, 1], h_aa * g[:, 1] - h_ab * g[:, 0]], axis=1) / det[:, None]
        decrement = -(g * step).sum(axis=1)  # Newton decrement squared: the loss still to gain, x2
        moving = (np.abs(step).max(axis=1) > PLATT_STEP_TOL) & (decrement > 1e-15 * np.maximum(loss[act], 1.0))
        active[act[~moving]] = False
        if not moving.all():
            act, ua, th, g, step = act[moving], ua[moving], th[moving], g[moving], step[moving]
        length = np.ones(act.size)
        left = np.arange(act.size)
        while left.size:  # backtracking (Armijo): halve each step until the loss falls enough
            every = left.size == act.size  # (the first pass): the arrays themselves, not copies
            trial = th[left] + length[left, None] * step[left]
            new = _platt_loss(trial, ua if every else ua[left], t, w, t_neg)
            ok = new <= loss[act[left]] + 1e-4 * length[left] * (g[left] * step[left]).sum(axis=1)
            theta[act[left[ok]]], loss[act[left[ok]]] = trial[ok], new[ok]
            length[left[~ok]] /= 2.0
            stuck = left[~ok][length[left[~ok]] < 1e-10]  # no descent left at this precision: converged
            active[act[stuck]] = False
            left = left[~ok][length[left[~ok]] >= 1e-10]
    a = theta[:, 0] / scale
    b = theta[:, 1] - a * s.mean(axis=1)
    # a >= 0: the map must increase with the score. Without it, leave-one-object-out scores of
    # near-constant models (large gamma) are perfectly *anti*-correlated with the label (holding
    # out a positive object shifts the intercept down), and a negative slope would "win" the CV.
    bound = (a < 0) | flat
    a[bound] = 0.0
    mean_t = float((w * t).sum() / w.sum())
    b[bound] = np.log(mean_t / (1.0 - mean_t))
    return a, b


def fit_platt(
    scores: np.ndarray, y: np.ndarray, sample_weight: np.ndarray | None = None
) -> tuple[float, float]:
    """Fit Platt's sigmoid ``p(y = 1 | s) = expit(a * s + b)`` to one score vector.

    :func:`fit_platt_many` with one row (smoothed targets, ``a >= 0``).

    Parameters
    ----------
    scores : ndarray of shape (n,)
        Classifier scores (SVM decision values, unitless).
    y : ndarray of shape (n,)
        0/1 labels.
    sample_weight : ndarray of shape (n,), optional
        Non-negative weights.

    Returns
    -------
    a, b : float
        Slope and intercept of the logit.
    """
    a, b = fit_platt_many(np.asarray(scores, dtype=float)[None], y, sample_weight)
    return float(a[0]), float(b[0])


def balanced_sample_weights(y: np.ndarray) -> np.ndarray:
    y = y.astype(bool)
    w = np.empty(y.shape, dtype=float)
    w[y] = 0.5 / max(int(y.sum()), 1)
    w[~y] = 0.5 / max(int((~y).sum()), 1)
    return w * y.size


def object_balanced_weights(yb: np.ndarray, groups: np.ndarray) -> np.ndarray:
    """Trial weights under which every object counts equally within its class and the classes equally.

    Parameters
    ----------
    yb : ndarray of bool, shape (n_trials,)
        Attribute present in each trial's object.
    groups : ndarray of shape (n_trials,)
        Object of each trial.

    Returns
    -------
    ndarray of shape (n_trials,)
        ``n / (2 * n_objects_of_class * n_trials_of_object)``: sums to ``n / 2`` per class (as
        :func:`balanced_sample_weights`, which it equals when every object has as many trials).
    """
    yb = np.asarray(yb).astype(bool)
    _, g = np.unique(np.asarray(groups), return_inverse=True)
    g = g.ravel()
    trials_of = np.bincount(g)[g].astype(float)
    w = np.empty(yb.size, dtype=float)
    for cls in (True, False):
        mask = yb == cls
        n_objects = max(np.unique(g[mask]).size, 1)
        w[mask] = yb.size / (2.0 * n_objects * trials_of[mask])
    return w


def object_grouped_folds(cv, yb: np.ndarray, groups: np.ndarray, seed: int) -> list[np.ndarray]:
    """Object-grouped cross-validation folds of an attribute classifier's training trials.

    Parameters
    ----------
    cv : None, int or splitter
        ``None``: leave-one-object-out. int: ``StratifiedGroupKFold(min(cv, n), shuffle=True)``'s folds
        (:func:`~tzsl.models.detectors._grouped_folds.stratified_group_fold_masks`) with ``n`` the number of
        objects of the rarer class (so every fold keeps both classes).
        A splitter: its ``split(X, y, groups)``.
    yb : ndarray of bool, shape (n_trials,)
    groups : ndarray of shape (n_trials,)
        Object of each trial.
    seed : int
        Seeds the shuffled ``StratifiedGroupKFold``.

    Returns
    -------
    list of ndarray of bool, shape (n_trials,)
        Each fold's held-out trials.

    Raises
    ------
    ConfigError
        The test folds do not partition the trials.
    """
    if isinstance(cv, Integral):  # StratifiedGroupKFold's folds, without its per-group Python loop
        n_min = min(np.unique(groups[yb]).size, np.unique(groups[~yb]).size)
        masks = stratified_group_fold_masks(yb, groups, min(int(cv), n_min), seed)
    else:
        masks = []
        for _, test in (LeaveOneGroupOut() if cv is None else cv).split(np.zeros((yb.size, 1)), yb, groups):
            m = np.zeros(yb.size, dtype=bool)
            m[test] = True
            masks.append(m)
    counts = np.sum(masks, axis=0) if masks else np.zeros(yb.size)
    if not np.all(counts == 1):
        raise ConfigError("cv: the test folds must partition the training trials (each trial exactly once)")
    return masks


def balanced_object_draws(yb: np.ndarray, groups: np.ndarray, n_draws: int,
                          rng: np.random.RandomState) -> tuple[list[np.ndarray], np.ndarray]:
    """Class-balanced under-sampling draws that drop whole objects of the majority class.

    Parameters
    ----------
    yb : ndarray of bool, shape (n_trials,)
    groups : ndarray of shape (n_trials,)
        Object of each trial.
    n_draws : int
        Random draws; 0 means no under-sampling (one draw keeping every trial).
    rng : numpy.random.RandomState

    Returns
    -------
    draws : list of ndarray of bool, shape (n_trials,)
        Kept trials of each distinct draw (duplicates merged).
    weights : ndarray of shape (n_distinct_draws,)
        Fraction of the ``n_draws`` draws equal to each distinct draw.
    """
    n = yb.size
    if n_draws == 0:
        return [np.ones(n, dtype=bool)], np.ones(1)
    minority = yb.sum() * 2 <= n  # True: positives are the minority
    major = yb != minority
    # groups holding only majority trials can be dropped whole
    g_all, g_inv = np.unique(groups, return_inverse=True)
    has_minor = np.bincount(g_inv, weights=(~major).astype(float), minlength=g_all.size) > 0
    droppable = np.flatnonzero(~has_minor)
    size = np.bincount(g_inv, minlength=g_all.size)
    n_minor = int((~major).sum())
    # majority trials inside mixed groups are always kept
    major_per_group = np.bincount(g_inv, weights=major.astype(float), minlength=g_all.size)
    kept_major_fixed = int(major_per_group[has_minor].sum())
    need = n_minor - kept_major_fixed
    # keep majority trials of at least two objects where there are two: with one, object-grouped CV has a
    # single fold (few objects of many trials each, e.g. the fabric groups' depth images)
    k_min = max(0, 2 - int(np.count_nonzero(has_minor & (major_per_group > 0))))
    draws = []
    for _ in range(n_draws):
        order = droppable[rng.permutation(droppable.size)]
        csum = np.cumsum(size[order])
        k = int(np.searchsorted(csum, need)) + 1 if need > 0 else 0
        k = min(max(k, k_min), order.size)
        keep_group = has_minor.copy()
        keep_group[order[:k]] = True
        draws.append(keep_group[g_inv])
    # distinct draws in the row order of np.unique(axis=0) (bool bytes sort like the rows), without
    # its structured dtype of one field per trial (seconds at a million trials)
    keys = [d.tobytes() for d in draws]
    distinct = sorted(set(keys))
    position = {key: i for i, key in enumerate(distinct)}
    weights = np.bincount([position[key] for key in keys], minlength=len(distinct)).astype(float)
    uniq = [np.frombuffer(key, dtype=bool).copy() for key in distinct]
    return uniq, weights / weights.sum()
