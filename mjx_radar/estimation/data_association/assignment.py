"""GNN over any number of tracks: the optimal joint assignment by the Hungarian method.

:func:`association.gnn_weights <mjx_radar.estimation.data_association.association.gnn_weights>`
finds the best joint event by enumerating ``(G + 1)^M`` events, which is out of reach for
a track table of K = 16 slots. The best event is a linear assignment problem: with the
log likelihood ratios ``log r[K, L]`` (:func:`association.log_ratios`; ``−inf`` outside a
gate, for invalid returns and empty slots) and a "missed" column of its own per track
(``log r = 0``, the PDA's convention of dividing each event by its miss term)::

    max_θ Σ_k log r_{k θ(k)},   θ(k) ∈ {returns} ∪ {miss_k}, no return taken twice

= the minimum-cost assignment of the K rows to the ``L + K`` columns of the cost
``C = [−log r | D]`` (``D_kk = 0``, ``D_kk' = BIG``; ``BIG`` also where ``log r = −inf``).
:func:`hungarian` solves it exactly (the shortest augmenting path form of the Hungarian
method, Kuhn 1955 / Jonker–Volgenant; ``O(K² (L + K))``): one row at a time (a
``fori_loop``), a Dijkstra-like inner ``while_loop`` over the columns. Fixed shapes,
pure JAX, ``vmap``-able (the while loops run until every batch member is done).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

__all__ = ["hungarian", "gnn_assignment", "BIG"]

#: cost of a forbidden pair (gated out, invalid, another track's miss column)
BIG = 1e6


def hungarian(cost):
    """The minimum-cost assignment of every row to a distinct column.

    Args:
        cost: ``[n, m]`` finite costs, ``n <= m``.

    Returns:
        ``[n]`` int32: the column of each row (``Σ_i cost[i, col_i]`` minimal).
    """
    n, m = cost.shape
    a = jnp.zeros((n + 1, m + 1), cost.dtype).at[1:, 1:].set(cost)  # 1-based, 0: sentinel
    inf = jnp.asarray(jnp.inf, cost.dtype)

    def grow(s):  # one step of the shortest augmenting path from the new row
        u, v, p, way, minv, used, j0 = s
        used = used.at[j0].set(True)
        i0 = p[j0]
        cur = a[i0] - u[i0] - v
        better = ~used & (cur < minv)
        minv = jnp.where(better, cur, minv)
        way = jnp.where(better, j0, way)
        free = jnp.where(used, inf, minv)
        j1 = jnp.argmin(free).astype(jnp.int32)
        delta = free[j1]
        u = u.at[p].add(jnp.where(used, delta, 0.0))  # the used columns' rows are distinct
        v = jnp.where(used, v - delta, v)
        minv = jnp.where(used, minv, minv - delta)
        return u, v, p, way, minv, used, j1

    def augment(s):
        p, way, j0 = s
        j1 = way[j0]
        return p.at[j0].set(p[j1]), way, j1

    def row(i, s):
        u, v, p, way = s
        p = p.at[0].set(i)
        start = (u, v, p, way, jnp.full(m + 1, inf), jnp.zeros(m + 1, bool), jnp.int32(0))
        u, v, p, way, _, _, j0 = jax.lax.while_loop(lambda t: t[2][t[6]] != 0, grow, start)
        p, _, _ = jax.lax.while_loop(lambda t: t[2] != 0, augment, (p, way, j0))
        return u, v, p, way

    zi = jnp.zeros(m + 1, jnp.int32)
    init = (jnp.zeros(n + 1, cost.dtype), jnp.zeros(m + 1, cost.dtype), zi, zi)
    _, _, p, _ = jax.lax.fori_loop(1, n + 1, row, init)
    rows = jnp.where(p[1:] > 0, p[1:] - 1, n)  # n: a free column (dropped)
    return jnp.zeros(n, jnp.int32).at[rows].set(jnp.arange(m, dtype=jnp.int32), mode="drop")


def gnn_assignment(logr):
    """The best joint event of K tracks and L returns (module docstring).

    Args:
        logr: ``[K, L]`` log likelihood ratios (``−inf``: the pair is not allowed).

    Returns:
        ``(β_0[K], β[K, L])`` hard weights in {0, 1}: each track's return or its miss;
        no return to two tracks.
    """
    k, ell = logr.shape
    ok = jnp.isfinite(logr)
    c = jnp.where(ok, -jnp.clip(jnp.where(ok, logr, 0.0), -BIG / 10, BIG / 10), BIG)
    miss = jnp.where(jnp.eye(k, dtype=bool), 0.0, BIG).astype(c.dtype)
    col = hungarian(jnp.concatenate([c, miss], axis=1))
    beta = jax.nn.one_hot(col, ell, dtype=logr.dtype)  # a miss column (>= L): all zero
    return 1.0 - jnp.sum(beta, axis=1), beta
