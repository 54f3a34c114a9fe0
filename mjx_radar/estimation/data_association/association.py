"""Joint data association of M targets and one scan: exact JPDA, JPDA* and GNN (issue 35).

One radar's scan holds L unlabelled measurements (a fixed buffer with a ``valid`` mask:
the detected returns and the false alarms). Target t's predicted measurement has the
innovation covariance ``S_t``; a measurement j inside its gate (``d_tj² < γ``) has the
likelihood ratio against clutter (Bar-Shalom, Willett & Tian, *Tracking and Data
Fusion*, 2011, §6.6; Fortmann, Bar-Shalom & Scheffe 1983)::

    r_tj = P_D,t N(ν_tj; 0, S_t) / (λ (1 − P_D,t P_G)) = exp(−d_tj²/2) / b_t,
    b_t  = λ √det(2π S_t) (1 − P_D,t P_G) / P_D,t          (the PDA's b, pda.py)

and 0 outside the gate. A joint event θ gives each target one measurement or none,
no measurement to two targets; with Poisson clutter its posterior probability is

    P(θ | Z) ∝ Π_{t detected in θ} r_{t θ(t)}

(each target's factors divided by its own ``1 − P_D,t P_G``, which every event shares).
The JPDA marginals are ``β_tj = Σ_{θ: θ(t) = j} P(θ)`` and ``β_t0 = Σ_{θ: t missed} P(θ)``.

Exact marginals by enumeration (static shapes): each target keeps its ``G`` best gated
candidates (largest ``r_tj``; fewer gated ones pad with ``r = 0``), and the
``(G + 1)^M`` slot combinations (:func:`event_table`) are scored at once, events using a
measurement twice getting probability 0. What is truncated: events in which a target
takes a measurement outside its ``G`` best; their mass is dropped (the kept events are
renormalised). Nothing is dropped when every target has at most G gated measurements.

GNN (global nearest neighbour): the single most probable event (the optimal assignment
with miss costs ``−log r``) as hard weights. With ``G ≥ M`` it is the optimum over all
measurements: a target assigned outside its M best would find one of them free (the
other M − 1 targets use at most M − 1) and a better event.

JPDA* (Blom & Bloem, "Probabilistic data association avoiding track coalescence", IEEE
TAC 45(2), 2000): of the events that are permutations of one another (the same
detected targets and the same measurements, in another order) only the most probable is
kept before normalising. Siblings are scored over all L measurements (not only the
candidates), with the M! target permutations that map detected targets to detected ones.

The loopy-BP approximation is :mod:`mjx_radar.estimation.data_association.lbp`.
"""

from __future__ import annotations

import functools
import itertools

import jax
import jax.numpy as jnp
import numpy as np

__all__ = [  # noqa: RUF022
    "log_ratios",
    "event_table",
    "candidates",
    "event_log_weights",
    "grid_log_weights",
    "exact_marginals",
    "gnn_weights",
    "star_mask",
    "n_events",
    "permutations",
    "scatter",
]


def log_ratios(d2, valid, b, seen, gate):
    """``log r[M, L]`` (−inf outside a gate, for empty slots and unseen targets).

    Args:
        d2: ``[M, L]`` squared Mahalanobis distances; valid: ``[L]`` bool.
        b: ``[M]`` the PDA's ``b_t`` (> 0); seen: ``[M]`` bool ``P_D,t > 0``; gate: γ.
    """
    inside = valid[None, :] & seen[:, None] & (d2 < gate)
    return jnp.where(inside, -0.5 * jnp.where(inside, d2, 0.0) - jnp.log(b)[:, None], -jnp.inf)


def n_events(m: int, g: int) -> int:
    """``(g + 1)^m`` joint slot combinations of the enumeration."""
    return (g + 1) ** m


@functools.cache
def event_table(m: int, g: int) -> np.ndarray:
    """``[E, M]`` int32 slots of every joint event, ``E = (G + 1)^M``; slot 0 is "missed",
    slot s ≥ 1 the target's s-th best candidate. Row 0 is the all-missed event."""
    return np.asarray(list(itertools.product(range(g + 1), repeat=m)), np.int32).reshape(-1, m)


@functools.cache
def permutations(m: int) -> np.ndarray:
    """``[M!, M]`` int32: every permutation of M targets (the identity first)."""
    return np.asarray(list(itertools.permutations(range(m))), np.int32).reshape(-1, m)


def candidates(logr, g: int):
    """Each target's ``g`` best measurements: ``(idx[M, G] int32, logr[M, G])``."""
    top, idx = jax.lax.top_k(logr, g)
    return idx.astype(jnp.int32), top


def _assigned(events, idx):
    """``[E, M]`` measurement of each target in each event (−1: missed)."""
    m = idx.shape[0]
    slot = jnp.asarray(events)
    meas = idx[jnp.arange(m)[None, :], jnp.maximum(slot - 1, 0)]
    return jnp.where(slot > 0, meas, -1)


def _on_axis(values, t: int, m: int):
    """``values [S]`` laid along axis t of an ``[S] * M`` grid."""
    return values.reshape([values.shape[0] if s == t else 1 for s in range(m)])


def grid_log_weights(terms, clash_of):
    """Every joint event's log weight ``[S^M]`` in :func:`event_table`'s order.

    The event table is the C-ordered grid of the M targets' S slots, so an event's log
    weight is the outer sum of the targets' ``terms [M, S]`` over that grid, ``−inf`` where
    two targets clash: ``clash_of(t, u) -> [S, S]`` bool for each target pair ``t < u``,
    broadcast along the pair's two axes and united over the ``M (M − 1) / 2`` pairs.
    Broadcasts only: no per-event gathers.
    """
    m, n = terms.shape
    total = _on_axis(terms[0], 0, m)
    for t in range(1, m):  # ((r_0 + r_1) + r_2) + ...: the order of a sum over the targets
        total = total + _on_axis(terms[t], t, m)
    clash = jnp.zeros((n,) * m, bool)
    for t, u in zip(*np.triu_indices(m, k=1), strict=True):  # static pairs
        shape = [n if s in (t, u) else 1 for s in range(m)]
        clash = clash | clash_of(int(t), int(u)).reshape(shape)
    return jnp.where(clash, -jnp.inf, total).reshape(-1)


def event_log_weights(logr_c, idx, events):
    """``(log P(θ) unnormalised [E], meas[E, M])``: −inf for events using a measurement
    twice or a padded (ungated) candidate.

    ``events`` must be :func:`event_table` ``(M, G)`` (static): the weights are
    :func:`grid_log_weights` of the targets' ``[G + 1]`` slot log ratios (slot 0, the
    miss: 0), two targets clashing where their candidates are one measurement.
    """
    m, g = idx.shape
    if not np.array_equal(events, event_table(m, g)):
        raise ValueError(f"event_log_weights: events must be event_table({m}, {g})")
    pad = jnp.concatenate([jnp.zeros((m, 1), logr_c.dtype), logr_c], axis=1)  # slot 0: miss

    def clash_of(t, u):  # [G+1, G+1]: slot 0, the miss, shares nothing
        return jnp.pad(idx[t][:, None] == idx[u][None, :], ((1, 0), (1, 0)))

    return grid_log_weights(pad, clash_of), _assigned(events, idx)


def star_mask(logw, meas, logr):
    """JPDA*: ``[E]`` bool, the events that are the most probable of their permutations.

    Args:
        logw: ``[E]`` event log weights; meas: ``[E, M]`` (−1 missed); logr: ``[M, L]``.
    """
    m = meas.shape[1]
    perms = jnp.asarray(permutations(m))  # [P, M]
    sib = meas[:, perms]  # [E, P, M]: target t takes the measurement of target perms[p, t]
    same_set = jnp.all((sib >= 0) == (meas[:, None, :] >= 0), axis=-1)  # [E, P]
    rows = jnp.arange(m)[None, None, :]
    terms = jnp.where(sib >= 0, logr[rows, jnp.maximum(sib, 0)], 0.0)
    sib_w = jnp.where(same_set, jnp.sum(terms, axis=-1), -jnp.inf)
    return logw >= jnp.max(sib_w, axis=1)


def scatter(beta_c, idx, n_meas):
    """Candidate weights ``[M, G]`` onto the scan's ``[M, L]`` (padded candidates carry 0)."""
    m = idx.shape[0]
    out = jnp.zeros((m, n_meas), beta_c.dtype)
    return out.at[jnp.arange(m)[:, None], idx].add(beta_c)


def exact_marginals(logr, g: int, star: bool = False):
    """JPDA marginals by enumeration over each target's ``g`` best candidates.

    Args:
        logr: ``[M, L]`` log likelihood ratios (:func:`log_ratios`).
        g: candidates per target (static, ``1 ≤ g ≤ L``).
        star: JPDA* (keep the most probable of each permutation class).

    Returns:
        ``(β_0[M], β[M, L])``, ``β_0 + Σ_j β_j = 1`` per target.
    """
    m, n_meas = logr.shape
    events = event_table(m, g)
    idx, top = candidates(logr, g)
    logw, meas = event_log_weights(top, idx, events)
    if star:
        logw = jnp.where(star_mask(logw, meas, logr), logw, -jnp.inf)
    p = jax.nn.softmax(logw)  # the all-missed event is always finite
    onehot = jnp.asarray(np.eye(g + 1)[events], p.dtype)  # [E, M, G + 1]
    beta = jnp.einsum("e,etg->tg", p, onehot)
    return beta[:, 0], scatter(beta[:, 1:], idx, n_meas)


def gnn_weights(logr, g: int):
    """GNN: the most probable joint event as hard weights ``(β_0[M], β[M, L])`` in {0, 1}."""
    m, n_meas = logr.shape
    events = event_table(m, g)
    idx, top = candidates(logr, g)
    logw, _ = event_log_weights(top, idx, events)
    best = jnp.asarray(events)[jnp.argmax(logw)]  # [M]
    onehot = jax.nn.one_hot(best, g + 1, dtype=logr.dtype)
    return onehot[:, 0], scatter(onehot[:, 1:], idx, n_meas)
