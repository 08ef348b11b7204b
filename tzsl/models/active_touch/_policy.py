"""Active touch, the policy half: sequential posterior, expected information gain, stopping rule.

Pure numpy functions on per-EP class log-scores ``(n_trials, n_eps, n_classes)`` and on a
confusion model ``(n_eps, n_attributes, 2, n_bins)``; the fitted model that produces them is
:class:`tzsl.models.active_touch._per_ep.PerEPAttributeModel` (whose docstring states the model and its
assumptions).
"""

from __future__ import annotations

import numpy as np
from scipy.special import logsumexp

from tzsl.exceptions import ConfigError
from tzsl.models._dap import break_ties, check_class_attributes
from tzsl.models.calibration import fit_temperature

__all__ = [
    "TEMPERINGS",
    "binned_confusion",
    "done_subset_index",
    "expected_information_gain",
    "fit_posterior_exponents",
    "outcome_log_likelihoods",
    "run_policy",
    "sequential_log_posterior",
    "stop_reasons",
]

_LOG2 = np.log(2.0)
#: How :func:`fit_posterior_exponents` shares exponents between sets of EPs done.
TEMPERINGS: tuple[str, ...] = ("subset", "count", "none")
_MAX_SUBSET_EPS = 12  # 2**12 exponents: beyond this, one exponent per set of EPs is not estimable
_EXPONENT_BOUNDS = (1e-3, 10.0)


def binned_confusion(posteriors, A, *, n_bins: int, smoothing: float) -> np.ndarray:
    """``p(bin | a_m = v)`` of held-out attribute posteriors, per action (EP or grasp type).

    Parameters
    ----------
    posteriors : array-like of shape (n_actions, n_samples, n_attributes)
        Held-out ``p(a_m = 1 | x)`` of each sample under each action; NaN where a sample has no
        posterior for that action (not observed with it, or the attribute could not be trained).
    A : array-like of shape (n_samples, n_attributes)
        True 0/1 attribute values of each sample's object.
    n_bins : int
        Equal-width bins on [0, 1].
    smoothing : float
        Pseudo-count added to every bin.

    Returns
    -------
    ndarray of shape (n_actions, n_attributes, 2, n_bins)
        Sums to 1 over bins.
    """
    P = np.asarray(posteriors, dtype=np.float64)
    A = np.asarray(A, dtype=int)
    counts = np.full((P.shape[0], P.shape[2], 2, n_bins), float(smoothing))
    e, t, j = np.nonzero(~np.isnan(P))
    bins = np.minimum((P[e, t, j] * n_bins).astype(int), n_bins - 1)
    np.add.at(counts, (e, j, A[t, j], bins), 1.0)
    return counts / counts.sum(axis=3, keepdims=True)


def done_subset_index(done) -> np.ndarray:
    """Index of each set of EPs done: the bit mask ``sum_e done[e] 2**e``.

    Parameters
    ----------
    done : array-like of shape (n_trials, n_eps) or (n_eps,), bool

    Returns
    -------
    int ndarray of shape (n_trials,) (or a 0-d array for a 1-d ``done``)
    """
    D = np.asarray(done, dtype=bool)
    return D.astype(np.int64) @ (np.int64(1) << np.arange(D.shape[-1], dtype=np.int64))


def sequential_log_posterior(ep_scores, done, exponents=None) -> np.ndarray:
    """Normalised log class posterior after the EPs in ``done`` (tempered naive Bayes across EPs).

    ``log p(z | D) = tau_D sum_{e in D} s_e(z) + c`` with ``tau_D = exponents[done_subset_index(D)]``;
    ``exponents=None`` (every ``tau_D = 1``) is the plain product of the EPs' evidence, exact only
    when the EPs' observations are conditionally independent given the class.

    Parameters
    ----------
    ep_scores : array-like of shape (n_trials, n_eps, n_classes)
        Per-EP class log-scores (:meth:`PerEPAttributeModel.ep_log_scores`).
    done : array-like of shape (n_trials, n_eps) or (n_eps,), bool
        EPs done so far; none done gives the uniform posterior.
    exponents : array-like of shape (2 ** n_eps,), optional
        Exponent of each set of EPs done (:func:`fit_posterior_exponents`).

    Returns
    -------
    ndarray of shape (n_trials, n_classes)
        ``log p(z | EPs done)``; ``logsumexp`` over classes is 0.
    """
    S = np.asarray(ep_scores, dtype=np.float64)
    D = np.broadcast_to(np.asarray(done, dtype=bool), S.shape[:2])
    total = np.where(D[:, :, None], S, 0.0).sum(axis=1)
    if exponents is not None:
        tau = np.asarray(exponents, dtype=np.float64)
        if tau.shape != (2 ** S.shape[1],):
            raise ConfigError(f"exponents must have shape ({2 ** S.shape[1]},) for {S.shape[1]} EPs, got {tau.shape}")
        total = total * tau[done_subset_index(D)][:, None]
    return total - logsumexp(total, axis=1, keepdims=True)


def _fit_exponent(total: np.ndarray, y: np.ndarray, valid: np.ndarray) -> float:
    """The exponent ``tau = 1 / T`` of the temperature fitted on ``total`` among each trial's valid classes."""
    lo, hi = _EXPONENT_BOUNDS
    return 1.0 / fit_temperature([np.where(valid, total, -np.inf)], [y], log_bounds=(-np.log(hi), -np.log(lo)))


def fit_posterior_exponents(ep_scores, y, *, valid=None, tempering: str = "subset") -> np.ndarray:
    """Exponents of the tempered sequential posterior, fitted by maximum likelihood on labelled trials.

    For every set ``D`` of EPs done, ``tau_D`` minimises the mean negative log-likelihood of the
    true classes under ``softmax(tau_D sum_{e in D} s_e)``. EPs whose evidence is redundant (the
    same object felt by several EPs) get ``tau_D < 1``; calibrated, conditionally independent
    EPs get ``tau_D`` near 1. Fit on held-out trials of pseudo-unseen classes (the caller's job:
    :meth:`PerEPAttributeModel.fit` uses its object-grouped folds of the training objects).

    Parameters
    ----------
    ep_scores : array-like of shape (n_trials, n_eps, n_classes)
        Per-EP class log-scores of labelled held-out trials.
    y : array-like of shape (n_trials,), int
        True class (column of ``ep_scores``) of each trial.
    valid : array-like of shape (n_trials, n_classes), bool, optional
        Candidate classes of each trial (pools of different sizes padded to ``n_classes``);
        default every class.
    tempering : {"subset", "count", "none"}, default="subset"
        ``"subset"``: one exponent per set of EPs done (at most 12 EPs); ``"count"``: one per
        number of EPs done; ``"none"``: every exponent 1 (the untempered product).

    Returns
    -------
    ndarray of shape (2 ** n_eps,)
        ``exponents[done_subset_index(D)] = tau_D``; entry 0 (nothing done) is 1.
    """
    S = np.asarray(ep_scores, dtype=np.float64)
    if S.ndim != 3:
        raise ConfigError(f"ep_scores must have shape (n_trials, n_eps, n_classes), got {S.shape}")
    n, E, Z = S.shape
    y = np.asarray(y, dtype=int)
    valid = np.ones((n, Z), dtype=bool) if valid is None else np.asarray(valid, dtype=bool)
    if tempering not in TEMPERINGS:
        raise ConfigError(f"tempering must be one of {TEMPERINGS}, got {tempering!r}")
    if y.shape != (n,) or valid.shape != (n, Z) or (n and not valid[np.arange(n), y].all()):
        raise ConfigError(f"y must hold one valid class per trial ({n}) and valid have shape {(n, Z)}")
    if tempering == "subset" and E > _MAX_SUBSET_EPS:
        raise ConfigError(f"tempering 'subset' fits 2**n_eps exponents; with {E} EPs use tempering 'count'")
    out = np.ones(2 ** E)
    if tempering == "none" or n == 0:
        return out
    masks = np.arange(1, 2 ** E)
    members = ((masks[:, None] >> np.arange(E)) & 1).astype(bool)  # (n_subsets, E)
    totals = np.einsum("de,nez->dnz", members.astype(float), S)  # (n_subsets, n, Z)
    if tempering == "subset":
        for d, mask in enumerate(masks):
            out[mask] = _fit_exponent(totals[d], y, valid)
        return out
    sizes = members.sum(axis=1)
    for k in np.unique(sizes):
        rows = np.flatnonzero(sizes == k)
        out[masks[rows]] = _fit_exponent(totals[rows].reshape(-1, Z), np.tile(y, rows.size),
                                         np.tile(valid, (rows.size, 1)))
    return out


def outcome_log_likelihoods(confusion, class_attributes, n_samples: int = 256, random_state=0) -> np.ndarray:
    """Monte-Carlo outcomes of every EP for every class, and their log-likelihood under every class.

    For EP ``e``, sample ``s`` and true class ``z`` an outcome (one bin per attribute) is drawn
    from ``confusion[e, m, a^z_m]`` (the same uniforms for all classes and EPs); the result is
    ``L[e, s, z, z'] = sum_m log confusion[e, m, a^z'_m, bin]``.

    Parameters
    ----------
    confusion : array-like of shape (n_eps, n_attributes, 2, n_bins)
    class_attributes : array-like of shape (n_classes, n_attributes)
    n_samples : int
    random_state : int, Generator or None

    Returns
    -------
    ndarray of shape (n_eps, n_samples, n_classes, n_classes)
        Natural-log likelihoods (this array does not depend on the current belief).
    """
    C = np.asarray(confusion, dtype=np.float64)
    K = check_class_attributes(class_attributes, C.shape[1]).astype(int)
    if n_samples < 1:
        raise ConfigError(f"n_samples must be >= 1, got {n_samples}")
    rng = np.random.default_rng(random_state)
    u = rng.random((n_samples, C.shape[1]))  # (S, m)
    cdf = np.cumsum(C, axis=3)  # (E, m, 2, B)
    cdf_z = cdf[:, np.arange(C.shape[1])[None, :], K]  # (E, Z, m, B)
    bins = (u[None, :, None, :, None] > cdf_z[:, None]).sum(axis=4)  # (E, S, Z, m)
    bins = np.minimum(bins, C.shape[3] - 1)
    logC = np.log(C)  # (E, m, 2, B)
    e_idx = np.arange(C.shape[0])[:, None, None, None, None]
    m_idx = np.arange(C.shape[1])[None, None, None, None, :]
    # (E, S, Z, Z', m): log p(bin of (s, z) | a_m = K[z', m])
    terms = logC[e_idx, m_idx, K[None, None, None, :, :], bins[:, :, :, None, :]]
    return terms.sum(axis=4)


def expected_information_gain(log_belief, outcome_ll) -> np.ndarray:
    """Expected reduction of class entropy (bits) of each EP, for each current belief.

    Parameters
    ----------
    log_belief : array-like of shape (n_trials, n_classes)
        Current normalised log posterior.
    outcome_ll : array-like of shape (n_eps, n_samples, n_classes, n_classes)
        From :func:`outcome_log_likelihoods`.

    Returns
    -------
    ndarray of shape (n_trials, n_eps)
        ``H(pi) - E_{z ~ pi} mean_s H(pi'(. | o_{s,z}))`` in bits; exactly 0 for an EP whose
        outcome likelihoods do not depend on the class.
    """
    lb = np.asarray(log_belief, dtype=np.float64)
    L = np.asarray(outcome_ll, dtype=np.float64)
    pi = np.exp(lb)
    H0 = -(pi * lb).sum(axis=1) / _LOG2
    out = np.empty((lb.shape[0], L.shape[0]))
    for e in range(L.shape[0]):  # (n, S, Z, Z') per EP keeps memory at n * S * Z^2
        post = lb[:, None, None, :] + L[e][None]
        post -= post.max(axis=3, keepdims=True)  # log-sum-exp in place, each exp computed once
        weights = np.exp(post)
        norm = weights.sum(axis=3, keepdims=True)
        post -= np.log(norm)
        weights /= norm
        H = -(weights * post).sum(axis=3) / _LOG2  # (n, S, Z)
        out[:, e] = H0 - (H.mean(axis=1) * pi).sum(axis=1)
    return out


def stop_reasons(log_belief, n_done, seconds_used, next_seconds, *, threshold: float = 0.9,
                 max_eps: int | None = None, max_seconds: float | None = None) -> np.ndarray:
    """Why each trial stops now (``""`` = continue).

    Parameters
    ----------
    log_belief : array-like of shape (n_trials, n_classes)
    n_done : array-like of shape (n_trials,)
        EPs done.
    seconds_used : array-like of shape (n_trials,)
    next_seconds : array-like of shape (n_trials,)
        Duration of the cheapest EP left (``inf`` when none is left).
    threshold : float
        Stop when the top class posterior is >= this.
    max_eps : int or None
    max_seconds : float or None
        Stop when the cheapest EP left would end after this many seconds.

    Returns
    -------
    ndarray of shape (n_trials,), dtype object
        ``"threshold"``, ``"max_eps"``, ``"max_seconds"``, ``"no_ep_left"`` or ``""``.
    """
    top = np.exp(np.asarray(log_belief, dtype=np.float64).max(axis=1))
    n_done, used, nxt = (np.asarray(a, dtype=float) for a in (n_done, seconds_used, next_seconds))
    reason = np.full(top.shape, "", dtype=object)
    conds = [
        ("no_ep_left", ~np.isfinite(nxt)),
        ("max_seconds", (used + nxt > max_seconds) if max_seconds is not None else np.zeros(top.shape, bool)),
        ("max_eps", (n_done >= max_eps) if max_eps is not None else np.zeros(top.shape, bool)),
        ("threshold", top >= threshold),
    ]
    for name, c in conds:  # the last true condition wins: the threshold is the most informative reason
        reason[c] = name
    return reason


def run_policy(ep_scores, outcome_ll, ep_seconds, *, policy="active", threshold: float = 1.01,
               max_eps: int | None = None, max_seconds: float | None = None, exponents=None,
               random_state=0) -> dict:
    """Run a choice rule on many trials at once, one EP per step.

    Parameters
    ----------
    ep_scores : array-like of shape (n_trials, n_eps, n_classes)
        Per-EP DAP log-scores of the test trials.
    outcome_ll : array-like of shape (n_eps, n_samples, n_classes, n_classes) or None
        Needed by the active rules.
    ep_seconds : array-like of shape (n_eps,)
    policy : {"active", "active_per_second"} or sequence of int
        Greedy expected information gain (per second), or a fixed order of EP indices.
    threshold, max_eps, max_seconds
        Stopping rule (:func:`stop_reasons`); the default threshold above 1 never stops early.
    exponents : array-like of shape (2 ** n_eps,), optional
        Tempered posterior (:func:`sequential_log_posterior`); ``None``: the untempered product.
    random_state : int or None
        Seeds the tie-breaking of predictions.

    Returns
    -------
    dict with
        ``order`` (n_trials, n_eps) int: EP done at each step (-1 after stopping);
        ``predictions`` (n_trials, n_eps + 1) int: argmax class before any EP and after each step
        (frozen after stopping); ``top_probability`` (n_trials, n_eps + 1): top class posterior at
        the same moments; ``gain`` (n_trials, n_eps): expected gain (bits) of the chosen
        EP (NaN for fixed orders / after stopping); ``n_eps_used`` (n_trials,) int;
        ``seconds_used`` (n_trials,); ``stop_reason`` (n_trials,) object; ``final`` (n_trials,) int.
    """
    S = np.asarray(ep_scores, dtype=np.float64)
    n, E, Z = S.shape
    sec = np.asarray(ep_seconds, dtype=float)
    rng = np.random.default_rng(random_state)
    done = np.zeros((n, E), dtype=bool)
    active = np.ones(n, dtype=bool)
    used = np.zeros(n)
    order = np.full((n, E), -1)
    gain = np.full((n, E), np.nan)
    reason = np.full(n, "", dtype=object)
    preds = np.empty((n, E + 1), dtype=int)
    top = np.empty((n, E + 1))
    lb = sequential_log_posterior(S, done, exponents)
    preds[:, 0] = break_ties(lb, rng)
    top[:, 0] = np.exp(lb.max(axis=1))
    if isinstance(policy, str) and policy not in ("active", "active_per_second"):
        raise ConfigError(f"policy must be 'active', 'active_per_second' or an EP order, got {policy!r}")
    if isinstance(policy, str) and outcome_ll is None:
        raise ConfigError("the active policy needs outcome_ll (the confusion model's outcome likelihoods)")
    fixed = None if isinstance(policy, str) else np.asarray(policy, dtype=int)
    for step in range(E):
        left_sec = np.where(done, np.inf, sec[None, :]).min(axis=1)
        r = stop_reasons(lb, done.sum(axis=1), used, left_sec, threshold=threshold, max_eps=max_eps,
                         max_seconds=max_seconds)
        newly = active & (r != "")
        reason[newly] = r[newly]
        active &= r == ""
        if not active.any():
            preds[:, step + 1:] = preds[:, step][:, None]
            top[:, step + 1:] = top[:, step][:, None]
            break
        if fixed is not None:
            choice = np.full(n, fixed[step])
        else:
            g = expected_information_gain(lb[active], outcome_ll)
            score = g / sec[None, :] if policy == "active_per_second" else g
            score = np.where(done[active], -np.inf, score)
            if max_seconds is not None:
                score = np.where(used[active, None] + sec[None, :] > max_seconds, -np.inf, score)
            choice = np.zeros(n, dtype=int)
            choice[active] = score.argmax(axis=1)
            gain[active, step] = g[np.arange(g.shape[0]), choice[active]]
        rows = np.flatnonzero(active)
        done[rows, choice[rows]] = True
        order[rows, step] = choice[rows]
        used[rows] += sec[choice[rows]]
        lb = np.where(active[:, None], sequential_log_posterior(S, done, exponents), lb)
        preds[:, step + 1] = np.where(active, break_ties(lb, rng), preds[:, step])
        top[:, step + 1] = np.exp(lb.max(axis=1))
    r = np.where(done.all(axis=1) & active, "no_ep_left", "")
    reason[(reason == "") & (r != "")] = "no_ep_left"
    return {"order": order, "predictions": preds, "top_probability": top, "gain": gain, "n_eps_used": done.sum(axis=1),
            "seconds_used": used, "stop_reason": reason, "final": preds[:, -1]}
