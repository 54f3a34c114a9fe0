"""Line of sight over terrain: does a straight segment pass below the height field? (pure JAX)

A segment ``p(t) = a + t e``, ``t ∈ [0, 1]``, ``e = b - a``, is blocked by the
terrain iff its clearance ``d(t) = a_z + t e_z - h(a_xy + t e_xy)`` is negative
somewhere (``h`` the bilinear height of :mod:`mjx_radar.world.terrain`; touching,
``d = 0``, does not block). The test is exact, without marching: between two
consecutive crossings of grid lines the segment stays in one cell, where ``h`` along
the segment is a quadratic in t (bilinear in two linear functions), so ``d`` is a
quadratic too and its minimum over ``[0, 1]`` is attained at

* an end point (t = 0, 1),
* a crossing of a grid line ``x = x_j`` (``t = (x_j - a_x) / e_x``) or ``y = y_i``,
* or the vertex of the quadratic of the cell that a crossing's piece runs in:
  with local coordinates ``U = U0 + t ê_x``, ``V = V0 + t ê_y`` (grid units) and
  ``h = H00 + A U + B V + τ U V`` (``A = H01 - H00``, ``B = H10 - H00``,
  ``τ = H11 - H10 - H01 + H00``), ``d'(t*) = 0`` gives
  ``t* = (e_z - A ê_x - B ê_y - τ (ê_x V0 + ê_y U0)) / (2 τ ê_x ê_y)``.

Every candidate is evaluated with the true lookup, so a candidate that falls
outside its piece still gives a true clearance (never below the minimum), and the
minimum over the ``2 (nx + ny) + 3`` candidates equals the minimum over the segment
(up to the float32 rounding of t at a crossing). No sorting, fixed shapes: jittable
and vmappable; the candidates are visited line by line (``fori_loop``), so memory does
not grow with the grid.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from mjx_radar.world.terrain import TerrainGrid, height

_TINY = 1e-12
_NUDGE = 1e-4  # grid units past a crossing to pick the cell the next piece runs in


def _vertex_after(grid: TerrainGrid, sa, es, ez, t_start):
    """``[...]`` t of the vertex of d's quadratic in the cell just after ``t_start``."""
    ny, nx = grid.heights.shape
    step = _NUDGE / jnp.maximum(jnp.max(jnp.abs(es), -1), _TINY)
    s = sa + (t_start + step)[..., None] * es  # [..., 2] grid units
    s = jnp.clip(s, 0.0, jnp.array([nx - 1, ny - 1], s.dtype))
    j = jnp.clip(jnp.floor(s[..., 0]), 0, nx - 2).astype(jnp.int32)
    i = jnp.clip(jnp.floor(s[..., 1]), 0, ny - 2).astype(jnp.int32)
    h = grid.heights.astype(sa.dtype)
    h00, h01, h10, h11 = h[i, j], h[i, j + 1], h[i + 1, j], h[i + 1, j + 1]
    a_, b_, tau = h01 - h00, h10 - h00, h11 - h10 - h01 + h00
    ex, ey = es[..., 0], es[..., 1]
    u0, v0 = sa[..., 0] - j, sa[..., 1] - i
    den = 2.0 * tau * ex * ey
    flat = jnp.abs(den) < _TINY
    num = ez - a_ * ex - b_ * ey - tau * (ex * v0 + ey * u0)
    return jnp.clip(jnp.where(flat, 0.0, num / jnp.where(flat, 1.0, den)), 0.0, 1.0)


def min_clearance(grid: TerrainGrid, a, b):
    """``[...]`` the smallest height of segments ``a -> b`` (``[..., 3]``) above the terrain [m].

    A ``fori_loop`` over the ``nx + ny`` grid lines keeps a running minimum (memory of a
    few arrays of the segments' shape, not of every candidate at once).
    """
    a, b = jnp.broadcast_arrays(jnp.asarray(a), jnp.asarray(b))
    e = b - a
    dtype = a.dtype
    sp = grid.spacing.astype(dtype)
    sa = (a[..., :2] - grid.origin.astype(dtype)) / sp  # grid units
    es = e[..., :2] / sp
    ny, nx = grid.heights.shape

    def clearance(t):  # t [...]: d at t and at the vertex of the piece starting there
        p = a + t[..., None] * e
        tv = _vertex_after(grid, sa, es, e[..., 2], t)
        pv = a + tv[..., None] * e
        return jnp.minimum(
            p[..., 2] - height(grid, p[..., :2]), pv[..., 2] - height(grid, pv[..., :2])
        )

    zero = jnp.zeros(a.shape[:-1], dtype)
    d = jnp.minimum(clearance(zero), clearance(zero + 1.0))

    def line(k, d):  # grid line k: x = x_k (k < nx), else y = y_(k - nx)
        on_x = k < nx
        den = jnp.where(on_x, es[..., 0], es[..., 1])
        start = jnp.where(on_x, sa[..., 0], sa[..., 1])
        flat = jnp.abs(den) < _TINY
        pos = jnp.where(on_x, k, k - nx).astype(dtype)
        t = jnp.where(flat, 0.0, (pos - start) / jnp.where(flat, 1.0, den))
        return jnp.minimum(d, clearance(jnp.clip(t, 0.0, 1.0)))

    return jax.lax.fori_loop(0, nx + ny, line, d)


def segment_blocked(grid: TerrainGrid, a, b):
    """``[...]`` True where the segment ``a -> b`` passes below the terrain somewhere."""
    return min_clearance(grid, a, b) < 0.0
