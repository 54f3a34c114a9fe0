"""GOSPA and OSPA between a set of truths and a set of estimates, on the host (issue 35).

Functions of *sets*, not of the scenario: truths ``X`` = the present rows of ``truth
[..., M, 3]`` (``present [..., M]``), estimates ``Y`` = the existing rows of ``est
[..., K, 3]`` (``exists [..., K]``); ``M`` and ``K`` may differ, every leading axis
(trials, steps) is a batch. With ``d(x, y) = ‖x − y‖``, cutoff ``c > 0``, order
``1 <= p < ∞``, ``|X| = m``, ``|Y| = k``:

**GOSPA** (Rahmathullah, García-Fernández & Svensson 2017, ``α = 2``)::

    GOSPA^p = min_γ [ Σ_{(i,j)∈γ} d(x_i, y_j)^p + c^p/2 (m − |γ|) + c^p/2 (k − |γ|) ]

over partial assignments γ with ``d < c`` on every pair: the *localisation* part
``Σ_γ d^p``, the *missed* part ``c^p/2 (m − |γ|)`` and the *false* part ``c^p/2 (k −
|γ|)`` (each in m^p, summing to ``GOSPA^p``; with ``p = 1`` all in metres).

**OSPA** (Schuhmacher, Vo & Vo 2008), ``n = max(m, k)`` (0 when both sets are empty)::

    OSPA^p = 1/n [ min_π Σ_{i=1}^{min(m,k)} min(d, c)^p + c^p |m − k| ]
           = (GOSPA^p + c^p |m − k| / 2) / n.

Both minima are one assignment problem: the square cost matrix of size ``max(M, K)``
with ``min(d, c)^p`` between a present truth and an existing estimate, ``c^p/2``
between a real element and a padding one and 0 between two paddings; any optimal
permutation gives both metrics (a pair with ``d >= c`` costs what leaving both
unassigned costs, and counts as missed + false). It is solved exactly
(:func:`assign`): a permutation meeting every row's minimum is optimal (the sum of the
row minima bounds every permutation from below), which the identity (track j of
target j: the tracker's bank) almost always does; the other steps enumerate every
permutation (``max(M, K) <= ENUMERATE_MAX``, vectorised) or call scipy's
``linear_sum_assignment`` one step at a time. Checked against Stone Soup's
``GOSPAMetric`` and ``OSPAMetric`` (tests/test_gospa.py).
"""

from __future__ import annotations

import itertools
from typing import NamedTuple

import numpy as np

__all__ = ["ENUMERATE_MAX", "SetMetrics", "assign", "set_metrics"]

#: largest padded size solved by enumerating its permutations (6! = 720)
ENUMERATE_MAX = 6
_CHUNK = 1 << 22  # batch entries x permutations x rows held at once when enumerating


class SetMetrics(NamedTuple):
    """Per batch entry (leading axes of the inputs)."""

    gospa: np.ndarray  # [...] GOSPA [m]
    localisation: np.ndarray  # [...] Σ d^p over the assigned pairs [m^p]
    missed: np.ndarray  # [...] c^p/2 x truths unassigned [m^p]
    false: np.ndarray  # [...] c^p/2 x estimates unassigned [m^p]
    ospa: np.ndarray  # [...] OSPA [m]
    assignment: np.ndarray  # [..., M] int: the estimate of each truth (d < c), else -1


def _padded_cost(truth, present, est, exists, cutoff: float, order: float):
    """``(cost [B, n, n], dist [B, M, K])`` of the flattened batch (module docstring)."""
    b, m, k = truth.shape[0], truth.shape[1], est.shape[1]
    n = max(m, k)
    dist = np.linalg.norm(truth[:, :, None, :] - est[:, None, :, :], axis=-1)
    row = np.zeros((b, n), bool)
    col = np.zeros((b, n), bool)
    row[:, :m], col[:, :k] = present, exists
    half = 0.5 * cutoff**order
    cost = np.where(row[:, :, None] ^ col[:, None, :], half, 0.0)
    real = np.minimum(dist, cutoff) ** order
    cost[:, :m, :k] = np.where(present[:, :, None] & exists[:, None, :], real, cost[:, :m, :k])
    return cost, dist


def _enumerate(cost: np.ndarray) -> np.ndarray:
    """Optimal permutations ``[B, n]`` by evaluating all ``n!`` of them."""
    n = cost.shape[-1]
    perms = np.asarray(list(itertools.permutations(range(n))), np.intp)  # [P, n]
    out = np.empty(cost.shape[:2], np.intp)
    step = max(1, _CHUNK // (len(perms) * n))
    rows = np.arange(n)
    for s in range(0, cost.shape[0], step):
        c = cost[s : s + step]
        total = c[:, rows[None, :], perms].sum(-1)  # [b, P]
        out[s : s + step] = perms[np.argmin(total, axis=1)]
    return out


def assign(cost: np.ndarray) -> np.ndarray:
    """Minimum-cost permutations of square cost matrices, exactly.

    Args:
        cost: ``[B, n, n]`` costs.

    Returns:
        ``[B, n]`` int: the column of each row in an optimal permutation.
    """
    b, n = cost.shape[0], cost.shape[-1]
    perm = np.broadcast_to(np.arange(n), (b, n)).copy()
    diag = np.take_along_axis(cost, perm[:, :, None], axis=2)[..., 0]
    todo = np.flatnonzero(np.any(diag > cost.min(axis=2), axis=1))  # identity not optimal
    if todo.size and n <= ENUMERATE_MAX:
        perm[todo] = _enumerate(cost[todo])
    elif todo.size:  # imported only here: scipy.optimize takes ~0.5 s to import
        from scipy.optimize import linear_sum_assignment

        for i in todo:
            perm[i] = linear_sum_assignment(cost[i])[1]
    return perm


def _flat(truth, present, est, exists, cutoff: float, order: float) -> SetMetrics:
    """:func:`set_metrics` of a flat batch: ``[B, M, 3]``, ``[B, M]``, ``[B, K, 3]``, ``[B, K]``."""
    m0 = truth.shape[1]
    if m0 == 0:  # no truth slot: one that is never present
        truth, present = np.zeros((truth.shape[0], 1, 3)), np.zeros((truth.shape[0], 1), bool)
    if est.shape[1] == 0:  # no estimate slot: one that never exists
        est, exists = np.zeros((est.shape[0], 1, 3)), np.zeros((est.shape[0], 1), bool)
    m, k = truth.shape[1], est.shape[1]
    cost, dist = _padded_cost(truth, present, est, exists, cutoff, order)
    perm = assign(cost)[:, :m]
    col = np.minimum(perm, k - 1)
    d = np.take_along_axis(dist, col[:, :, None], axis=2)[..., 0]
    ok = present & (perm < k) & (d < cutoff) & np.take_along_axis(exists, col, axis=1)
    half = 0.5 * cutoff**order
    n_pairs = ok.sum(-1)
    n_truth, n_est = present.sum(-1), exists.sum(-1)
    loc = np.where(ok, d**order, 0.0).sum(-1)
    missed, false = half * (n_truth - n_pairs), half * (n_est - n_pairs)
    total = loc + missed + false
    big = np.maximum(n_truth, n_est)
    ospa_p = (total + half * np.abs(n_truth - n_est)) / np.maximum(big, 1)
    return SetMetrics(
        total ** (1.0 / order),
        loc,
        missed,
        false,
        np.where(big > 0, ospa_p, 0.0) ** (1.0 / order),
        np.where(ok, perm, -1)[:, :m0],
    )


def set_metrics(truth, present, est, exists, cutoff: float, order: float = 1.0) -> SetMetrics:
    """GOSPA (with its parts), OSPA and the optimal assignment of batches of sets.

    Args:
        truth: ``[..., M, 3]`` true positions [m]; present: ``[..., M]`` bool.
        est: ``[..., K, 3]`` estimated positions [m]; exists: ``[..., K]`` bool.
        cutoff: ``c > 0`` [m].
        order: ``1 <= p < ∞``.

    Returns:
        :class:`SetMetrics` (float64), every field with the inputs' leading axes.

    Raises:
        ValueError: a cutoff or order out of range, or inconsistent shapes.
    """
    if not (np.isfinite(cutoff) and cutoff > 0):
        raise ValueError(f"cutoff = {cutoff!r}: must be a finite number > 0")
    if not (np.isfinite(order) and order >= 1):
        raise ValueError(f"order = {order!r}: must be a finite number >= 1")
    truth, est = np.asarray(truth), np.asarray(est)
    present, exists = np.asarray(present, bool), np.asarray(exists, bool)
    lead = truth.shape[:-2]
    if present.shape != truth.shape[:-1] or exists.shape != est.shape[:-1]:
        raise ValueError("masks must have the shapes of the sets without their last axis")
    if est.shape[:-2] != lead or truth.shape[-1] != est.shape[-1]:
        raise ValueError(f"truth {truth.shape} and estimates {est.shape} do not match")
    m, k = truth.shape[-2], est.shape[-2]
    b = int(np.prod(lead))
    truth, est = truth.reshape(b, m, truth.shape[-1]), est.reshape(b, k, est.shape[-1])
    present, exists = present.reshape(b, m), exists.reshape(b, k)
    n = max(m, k, 1)
    step = max(1, _CHUNK // (n * n))  # batch entries per chunk: a few 10 MB of costs
    parts = []
    for s in range(0, max(truth.shape[0], 1), step):
        x, y = (np.asarray(a[s : s + step], np.float64) for a in (truth, est))
        parts.append(_flat(x, present[s : s + step], y, exists[s : s + step], cutoff, order))
    out = SetMetrics(*(np.concatenate(x) for x in zip(*parts, strict=True)))
    return SetMetrics(*(x.reshape(lead + x.shape[1:]) for x in out))
