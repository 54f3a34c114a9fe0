"""A fixed-size replay buffer on the device: a ring of labelled samples (a pytree).

Distillation (:mod:`mjx_radar.learning.distill`) aggregates every rollout's states and
the teacher's labels here; once full, the oldest samples are overwritten. Pure
functions of arrays, jit-able; the buffer's shapes never change, so one compiled
update program serves every iteration.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import jax
import jax.numpy as jnp


class Buffer(NamedTuple):
    """``data``: a pytree of ``[C, ...]`` arrays; ``ptr``: the next slot; ``size``: how
    many slots hold samples (≤ C)."""

    data: Any
    ptr: jax.Array  # [] int32
    size: jax.Array  # [] int32


def empty(example, capacity: int) -> Buffer:
    """A buffer of ``capacity`` samples shaped like ``example`` (one sample's pytree of
    arrays or ``jax.ShapeDtypeStruct``)."""
    data = jax.tree.map(lambda x: jnp.zeros((capacity,) + tuple(x.shape), x.dtype), example)
    return Buffer(data, jnp.int32(0), jnp.int32(0))


def capacity(buf: Buffer) -> int:
    """C, the number of slots."""
    return jax.tree.leaves(buf.data)[0].shape[0]


def add(buf: Buffer, batch) -> Buffer:
    """``buf`` with the ``[K, ...]`` samples of ``batch`` written from ``ptr`` on (the
    last C of them when K > C)."""
    cap = capacity(buf)
    k = jax.tree.leaves(batch)[0].shape[0]
    if k > cap:
        batch = jax.tree.map(lambda x: x[k - cap :], batch)
        k = cap
    idx = (buf.ptr + jnp.arange(k)) % cap
    data = jax.tree.map(lambda d, x: d.at[idx].set(x.astype(d.dtype)), buf.data, batch)
    return Buffer(data, (buf.ptr + k) % cap, jnp.minimum(buf.size + k, cap).astype(jnp.int32))


def sample(buf: Buffer, key, batch_size: int):
    """``[batch_size, ...]`` samples drawn uniformly (with replacement) from the filled
    slots."""
    idx = jax.random.randint(key, (batch_size,), 0, jnp.maximum(buf.size, 1))
    return jax.tree.map(lambda d: d[idx], buf.data)
