"""Loop carries batched from the start under ``vmap``: a loop body batched once, not twice.

Under :func:`jax.vmap`, ``lax.scan`` (and ``fori_loop``) learn which parts of the carry
are batched by a fixpoint: they batch the body's jaxpr with the initial carry's batching
and, when the body turns an unbatched part of the carry batched, batch the whole body
again. That happens wherever a loop starts from something shared by the batch and
mixes in something that is not: a zero initial factor filled from a batched matrix, a
radar state shared by all MPPI samples rolled out under each sample's controls, MPPI's
placeholders for the iteration's samples. Loops nest (filter steps, MPPI iterations,
rollouts, the PFIM recursion); marking them cut the first trace of the paper study's
program by about 5-10 % (docs/notes/scaling-history.md). :func:`batched_like` marks
such a carry batched from the start, with its values unchanged.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp


def batched_like(x, ref):
    """``x`` unchanged in value, but batched wherever any leaf of ``ref`` is (under ``vmap``).

    It is ``where(p, x, x)`` with a predicate ``p`` that is always True but computed from
    ``ref`` (``(r != r) | True`` of one element of each leaf ``r``), so its batching
    follows ``ref``'s: the value is ``x`` whatever ``ref`` holds (NaN included), the
    gradient reaches ``x`` untouched, and XLA compiles the select away (``select(p, x, x)
    = x``: the same optimised program, hence the same numbers). Outside ``vmap`` nothing
    is batched and only the select is added.

    Args:
        x: a pytree of arrays (a loop's initial carry, or a part of it).
        ref: a pytree of arrays that the loop's carry will depend on.

    Returns:
        ``x``, leaf for leaf.
    """
    flags = [_first(r) != _first(r) for r in jax.tree.leaves(ref) if jnp.size(r)]
    if not flags:
        return x
    p = jnp.logical_or(jnp.any(jnp.stack(flags)), True)
    return jax.tree.map(lambda a: jnp.where(p, a, a), x)


def _first(r):
    """One element of an array (a PRNG key array's first word)."""
    if jnp.issubdtype(r.dtype, jax.dtypes.prng_key):
        r = jax.random.key_data(r)
    return jnp.ravel(r)[0]
