"""mjx_radar.batching: loop carries batched from the start under vmap."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from jax._src.interpreters import batching as jax_batching  # to count batchings (below)

from mjx_radar.batching import batched_like


def _loop(start, xs, mark: bool):
    """A scan whose carry starts from ``start`` (shared) and mixes in ``xs`` (per item)."""
    init = (start, jnp.zeros(3))
    if mark:
        init = batched_like(init, xs)

    def body(carry, x):
        s, acc = carry
        return (0.5 * s + x, acc + jnp.sin(x)), s.sum()

    return jax.lax.scan(body, init, xs)


def test_values_dtypes_and_gradients_are_unchanged():
    x = {"a": jnp.arange(4.0), "b": jnp.arange(3, dtype=jnp.int32), "c": jnp.zeros((0, 2))}
    ref = jnp.asarray([jnp.nan, 1.0])  # whatever the reference holds, NaN included
    out = batched_like(x, ref)
    for k in x:
        assert out[k].dtype == x[k].dtype and out[k].shape == x[k].shape
        np.testing.assert_array_equal(out[k], x[k])
    key = jax.random.split(jax.random.key(0), 3)  # a typed key array as the reference
    np.testing.assert_array_equal(batched_like(x["a"], key), x["a"])
    grad = jax.grad(lambda v: jnp.sum(batched_like(v, ref) ** 2))(x["a"])
    np.testing.assert_array_equal(grad, 2.0 * x["a"])
    assert batched_like(x, jnp.zeros(0)) is x  # nothing to follow: x itself


def test_a_vmapped_loop_is_batched_once_with_the_same_numbers(monkeypatch):
    start = jnp.linspace(-1.0, 1.0, 3)
    xs = jax.random.normal(jax.random.key(1), (5, 4, 3))  # [batch, steps, 3]
    calls = []
    real = jax_batching.batch_jaxpr

    def counting(*args, **kwargs):
        calls.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(jax_batching, "batch_jaxpr", counting)
    results = {}
    for mark in (False, True):
        calls.clear()
        f = jax.vmap(lambda x, m=mark: _loop(start, x, m))
        results[mark] = jax.jit(f)(xs)
        # JAX's fixpoint: the unmarked body is batched a second time when it finds the
        # shared start turned batched; the marked one is batched once
        assert len(calls) == (1 if mark else 2), (mark, len(calls))
    for a, b in zip(jax.tree.leaves(results[False]), jax.tree.leaves(results[True]), strict=True):
        np.testing.assert_array_equal(a, b)
