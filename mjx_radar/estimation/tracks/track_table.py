"""A fixed-capacity, padded track table and its life cycle (issue 35, docs/track_management.md).

The table holds K slots (``max_tracks``), each empty, tentative or confirmed, so an
unknown and changing number of drones is tracked with static shapes (jit, vmap over
trials, scan over time). Per slot: the 6-D CV estimate ``mean [6]``, ``cov [6, 6]``,
``status``, the hit history of the last ``n`` scans (a bit field, newest in bit 0),
the consecutive misses, the age in scans and a label (unique per trial, never reused).

Life cycle, per scan (:func:`maintain`), with ``hit`` whether the slot's track was
associated (gated returns from enough radars, :mod:`~mjx_radar.estimation.tracks.track_update`):

* history ``h ← ((h << 1) | hit) mod 2ⁿ``, ``misses ← 0 if hit else misses + 1``, ``age ← age + 1``;
* **M-of-N confirmation**: a tentative track with ``popcount(h) >= m`` becomes confirmed;
  one that reaches age ``n`` unconfirmed is deleted (its first n scans had < m hits);
* **deletion** of a confirmed track after ``delete_misses`` consecutive misses, or when
  ``tr P_pos > delete_cov`` [m²], or when its moments are not finite; with
  ``vanish_misses = V > 0`` also after V consecutive misses when no radar sees it at
  this scan (``gated`` all false: the drone has gone, it is not merely hidden behind a
  neighbour's return at one radar).

Births (:func:`insert`) take the lowest empty slots, tentative, with ``h = 1`` (the birth
scan counts as a hit), ``age = 1``; births beyond the free slots are dropped.
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp

__all__ = ["EMPTY", "TENTATIVE", "CONFIRMED", "TrackTable", "LifeRules", "empty", "maintain"]
__all__ += ["insert", "popcount", "live", "TrackView", "view"]

EMPTY, TENTATIVE, CONFIRMED = 0, 1, 2


class TrackTable(NamedTuple):
    """K track slots (a pytree; leading axis K; vmaps over trials).

    Attributes:
        mean: ``[K, 6]`` ``[x, y, z, vx, vy, vz]`` per slot.
        cov: ``[K, 6, 6]`` its covariance P (``p_empty I`` in empty slots).
        status: ``[K]`` int32 :data:`EMPTY`, :data:`TENTATIVE` or :data:`CONFIRMED`.
        history: ``[K]`` int32 hits of the last n scans, bit i = scan k − i.
        misses: ``[K]`` int32 consecutive scans without a hit.
        age: ``[K]`` int32 scans since birth (1 at birth).
        label: ``[K]`` int32 the track's id (−1 in empty slots).
        gated: ``[K, N]`` bool the radars whose last scan had a return in the gate.
        next_label: ``[]`` int32 the next birth's label.
    """

    mean: jax.Array
    cov: jax.Array
    status: jax.Array
    history: jax.Array
    misses: jax.Array
    age: jax.Array
    label: jax.Array
    gated: jax.Array
    next_label: jax.Array


class LifeRules(NamedTuple):
    """Confirmation and deletion thresholds (static Python numbers)."""

    confirm_m: int = 3
    confirm_n: int = 5
    delete_misses: int = 10
    delete_cov: float = 2500.0  # [m²] bound on tr P_pos
    vanish_misses: int = 0  # misses that delete a track no radar sees (0: off)


def empty(k: int, n_radars: int, dtype=jnp.float32, p_empty: float = 1.0) -> TrackTable:
    """A table of ``k`` empty slots (``cov = p_empty I`` keeps every block invertible)."""
    z = jnp.zeros(k, jnp.int32)
    return TrackTable(
        mean=jnp.zeros((k, 6), dtype),
        cov=jnp.broadcast_to(p_empty * jnp.eye(6, dtype=dtype), (k, 6, 6)),
        status=z,
        history=z,
        misses=z,
        age=z,
        label=z - 1,
        gated=jnp.zeros((k, n_radars), bool),
        next_label=jnp.int32(0),
    )


def popcount(x, bits: int):
    """Set bits among the lowest ``bits`` of the int32 array ``x`` (static unrolled sum)."""
    return sum((x >> i) & 1 for i in range(bits))


def live(table: TrackTable) -> jax.Array:
    """``[K]`` bool: the slot holds a track (tentative or confirmed)."""
    return table.status != EMPTY


def _clear(table: TrackTable, gone, p_empty) -> TrackTable:
    """``table`` with the slots ``gone [K]`` emptied."""
    eye = p_empty * jnp.eye(6, dtype=table.cov.dtype)
    keep_i = lambda a, b: jnp.where(gone, b, a)  # noqa: E731
    return table._replace(
        mean=jnp.where(gone[:, None], 0.0, table.mean),
        cov=jnp.where(gone[:, None, None], eye, table.cov),
        status=keep_i(table.status, EMPTY),
        history=keep_i(table.history, 0),
        misses=keep_i(table.misses, 0),
        age=keep_i(table.age, 0),
        label=keep_i(table.label, -1),
        gated=table.gated & ~gone[:, None],
    )


def maintain(table: TrackTable, hit, rules: LifeRules, p_empty: float = 1.0) -> TrackTable:
    """One scan of the life cycle (module docstring): counters, M-of-N, deletion.

    Args:
        table: the table after the scan's update; hit: ``[K]`` bool associated this scan.
        rules: :class:`LifeRules`; p_empty: the covariance scale of emptied slots.
    """
    on = live(table)
    hit = hit & on
    mask = (1 << rules.confirm_n) - 1
    hist = jnp.where(on, ((table.history << 1) | hit.astype(jnp.int32)) & mask, 0)
    misses = jnp.where(on, jnp.where(hit, 0, table.misses + 1), 0)
    age = jnp.where(on, table.age + 1, 0)
    tent = table.status == TENTATIVE
    confirm = tent & (popcount(hist, rules.confirm_n) >= rules.confirm_m)
    status = jnp.where(confirm, CONFIRMED, table.status)
    expired = (status == TENTATIVE) & (age >= rules.confirm_n)
    pos_var = jnp.trace(table.cov[:, :3, :3], axis1=-2, axis2=-1)
    finite = jnp.all(jnp.isfinite(table.mean), -1) & jnp.all(jnp.isfinite(table.cov), (-2, -1))
    lost = (status == CONFIRMED) & (misses >= rules.delete_misses)
    if rules.vanish_misses:  # seen by no radar at this scan, after vanish_misses misses
        blind = ~jnp.any(table.gated, axis=1) & (misses >= rules.vanish_misses)
        lost = lost | ((status == CONFIRMED) & blind)
    gone = on & (expired | lost | ~finite | ~(pos_var <= rules.delete_cov))
    out = table._replace(status=status, history=hist, misses=misses, age=age)
    return _clear(out, gone, p_empty)


def insert(table: TrackTable, mean, cov, ok) -> TrackTable:
    """Births into the lowest empty slots, tentative (``h = 1``, age 1, new labels).

    Args:
        mean: ``[B, 6]``; cov: ``[B, 6, 6]``; ok: ``[B]`` bool the candidates to insert
            (in order; those beyond the free slots are dropped).
    """
    free = table.status == EMPTY
    slot_rank = jnp.cumsum(free) - 1  # rank of each free slot among the free ones
    birth_rank = jnp.cumsum(ok) - 1  # rank of each accepted birth
    # match[k, b]: slot k takes birth b
    match = free[:, None] & ok[None, :] & (slot_rank[:, None] == birth_rank[None, :])
    take = jnp.any(match, axis=1)
    b = jnp.argmax(match, axis=1)
    labels = table.next_label + birth_rank[b]
    born = jnp.sum(ok & (birth_rank < jnp.sum(free))).astype(jnp.int32)
    return table._replace(
        mean=jnp.where(take[:, None], mean[b], table.mean),
        cov=jnp.where(take[:, None, None], cov[b], table.cov),
        status=jnp.where(take, TENTATIVE, table.status),
        history=jnp.where(take, 1, table.history),
        misses=jnp.where(take, 0, table.misses),
        age=jnp.where(take, 1, table.age),
        label=jnp.where(take, labels, table.label),
        next_label=table.next_label + born,
    )


class TrackView(NamedTuple):
    """What the planner, the reward and the records see of a table."""

    mean: jax.Array  # [K, 6]
    cov: jax.Array  # [K, 6, 6]
    weight: jax.Array  # [K] planner weight: 1 confirmed, tentative_weight tentative, 0 empty
    exist: jax.Array  # [K] bool confirmed tracks (the estimate set of GOSPA)
    seen: jax.Array  # [N, K] bool radars with a return in the track's gate at the last scan


def view(table: TrackTable, tentative_weight: float = 0.0) -> TrackView:
    """The table's :class:`TrackView`."""
    conf = table.status == CONFIRMED
    w = jnp.where(conf, 1.0, jnp.where(table.status == TENTATIVE, tentative_weight, 0.0))
    return TrackView(table.mean, table.cov, w.astype(table.mean.dtype), conf, table.gated.T)
