"""The settled MHT: after S scans only the K₂ heaviest hypotheses go on.

With ``settle = (S, K₂)`` (``[tracker] settle_scans``, ``settled_hypotheses``) and
branching over the first scans only, the MHT's scans from the S-th on update only the K₂
heaviest of its K hypotheses (:func:`settled`); every other slot's weight becomes −inf,
and a slot of weight −inf never weighs again (a soft scan adds to ``log w``, so −inf
stays −inf). From then on (``scans > S``: the settled scan has run) the per-hypothesis
work outside the scans, the time update and what follows a scan, needs only those K₂
slots (:func:`live_only`): the others' banks are never read with any weight. Gathering
the K₂ slots, working on them and scattering them back gives the live hypotheses what the
K-slot work gives them, up to float round-off (XLA vectorises a batch of K₂ differently
from one of K), and it spares the K − K₂ stale slots' cubature time updates, which at
K = 1024 and K₂ = 64 cost more than the settled scan itself.

The slots kept are ``lax.top_k`` of the log weights, as in the settled scan. Pure JAX,
static shapes; ``scans`` is the loop's counter (one for every trial), so ``lax.cond``
runs one branch under ``vmap``.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

__all__ = ["settled", "on_heaviest", "live_only"]


def settled(hyp, pd, k2: int, run):
    """One scan of the K₂ heaviest hypotheses only (``lax.top_k`` of ``log w``): they take
    ``run(sub, pd [N, K₂, M])`` (the soft scan of a K₂-slot state, weights renormalised
    among them) and return to their slots; every other slot's weight becomes −inf (its
    stale bank weighs nothing in the estimate, the mixture or the next ``top_k``).

    Args:
        hyp: the MHT's state (:class:`~mjx_radar.estimation.data_association.mht.HypState`,
            K slots).
        pd: ``[N, K, M]`` detection probabilities; k2: K₂ (static, < K).
        run: ``run(sub, pd_sub) -> sub`` the soft scan.
    """
    keep, sub = _heaviest(hyp, k2)
    return _put(hyp, keep, run(sub, pd[:, keep]), jnp.full_like(hyp.logw, -jnp.inf))


def on_heaviest(hyp, k2: int, f):
    """``f`` applied to the K₂ heaviest hypotheses only (a K₂-slot state); the other
    slots unchanged.

    Args:
        hyp: K slots; k2: K₂ (static, < K).
        f: ``f(sub) -> sub`` on a K₂-slot state (its weights may change; a renormalisation
            inside it is over the K₂, which is over all K once the others are −inf).
    """
    keep, sub = _heaviest(hyp, k2)
    return _put(hyp, keep, f(sub), hyp.logw)


def _heaviest(hyp, k2: int):
    """``(keep [K₂], sub)``: the K₂ heaviest slots (``lax.top_k`` of ``log w``) as a state."""
    _, keep = jax.lax.top_k(hyp.logw, k2)
    return keep, hyp._replace(means=hyp.means[keep], covs=hyp.covs[keep], logw=hyp.logw[keep])


def _put(hyp, keep, sub, logw):
    """``hyp`` with ``sub`` back in the slots ``keep``; the other slots' weights ``logw``."""
    return hyp._replace(
        means=hyp.means.at[keep].set(sub.means),
        covs=hyp.covs.at[keep].set(sub.covs),
        logw=logw.at[keep].set(sub.logw),
    )


def live_only(hyp, settle, f):
    """``f(hyp)``, on the K₂ heaviest slots only once the settled scans have begun.

    Args:
        hyp: K slots, ``hyp.scans`` the scans updated so far.
        settle: static ``(S, K₂)``; ``S <= 0`` or ``K₂ >= K``: never settled (``f(hyp)``).
        f: ``f(state) -> state`` for a state of any number of slots, slot by slot but for
            a renormalisation of the weights.

    Returns:
        ``f(hyp)`` while ``scans <= S``; afterwards :func:`on_heaviest` with K₂, which
        gives the live slots what ``f(hyp)`` would (up to the summation order of a
        renormalisation).
    """
    late, k2 = settle
    if late <= 0 or k2 >= hyp.logw.shape[0]:
        return f(hyp)
    return jax.lax.cond(hyp.scans > late, lambda h: on_heaviest(h, k2, f), f, hyp)
