"""The track table's measurement update: association behind one function (issue 35).

An *associator* is ``associate(means [K, 6], covs [K, 6, 6], live [K], zs [N, L, dim],
valid [N, L], radar_pos [N, 3]) -> (means, covs, nll [K, N, L])``: it updates every
live slot from every radar's unlabelled scan and gives each return's negative
log-likelihood under each track's predicted measurement, ``nll = d² + log det S``
(``d² = νᵀ S⁻¹ ν``; ``+inf`` outside the gate ``d² < γ``, for invalid returns and
empty slots). :func:`pda_associator` is the per-track PDA of
:mod:`~mjx_radar.estimation.data_association.pda` (radar after radar, each track on its own); a
joint
associator with the same signature drops in: :func:`gnn_associator` (``association =
"gnn"``) gives each return to at most one track, the best joint event per radar;
:func:`jpda_associator` (``association = "jpda"``) shares it by the JPDA's marginals.

From ``nll`` the table learns (:func:`update`), per radar i: each track's nearest
return (its *claim*, min over l of ``nll[k, i, l]``); the track *sees* radar i when it
is also the most likely track of the return it claims (two tracks on one return: only
the likelier sees it, so a ghost built from other drones' returns earns no hits). A
*hit* is seeing at least ``hit_radars`` radars; the claimed returns are *explained*
(no birth from them), the others stay free.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from mjx_radar.estimation import linalg
from mjx_radar.estimation.data_association import assignment, association, lbp, pda
from mjx_radar.estimation.filters import ckf, ground_prior
from mjx_radar.estimation.sensor import detection
from mjx_radar.estimation.sensor.noise import at_radar
from mjx_radar.estimation.tracks import track_table

__all__ = [
    "pda_associator",
    "gnn_associator",
    "jpda_associator",
    "update",
    "sorted_scans",
    "innovation_nll",
]


def innovation_nll(mean, cov, zs, h, R, residual, gate):
    """``[L]`` ``d² + log det S`` of returns ``zs [L, p]`` under the cubature prediction
    of ``h`` at ``(mean, cov)`` (``+inf`` where ``d² >= γ``)."""
    dx = ckf.cubature_offsets(cov)
    ref = h(mean)
    dv = jax.vmap(residual, in_axes=(0, None))(jax.vmap(h)(mean[None, :] + dx), ref)
    m = jnp.mean(dv, axis=0)
    z_hat, dz = ref + m, dv - m[None, :]
    S = dz.T @ dz / dx.shape[0] + R(z_hat)
    nu = jax.vmap(residual, in_axes=(0, None))(zs, z_hat)
    d2 = jnp.sum(nu * linalg.psd_solve(S, nu.T).T, axis=-1)
    return jnp.where(d2 < gate, d2 + linalg.logdet_psd(S), jnp.inf)


def sorted_scans(zs, valid):
    """Each radar's buffer ordered by its first component (range), invalid returns last.

    The scan buffer lists the drones' returns in the truth's order; a tracker that must
    not know which return is which drone sees them in range order (what a radar reports).
    """
    key = jnp.where(valid, zs[..., 0], jnp.inf)
    order = jnp.argsort(key, axis=1)
    return jnp.take_along_axis(zs, order[..., None], 1), jnp.take_along_axis(valid, order, 1)


def pda_associator(
    model, noise, ccr, det_model, det_params, density, gate, pg, reflect, exclusive=True
):
    """The per-track PDA associator (module docstring).

    With ``exclusive`` each track's PDA at radar i uses only the returns of which it is
    the likeliest track (``argmin_k nll``): the per-target PDA otherwise takes the
    neighbouring drones' returns for its own and the tracks coalesce (issue 35); this
    is the simple stand-in until a joint associator (JPDA, GNN) drops in.

    Args:
        model: measurement model (static); noise: ``NoiseParams``; ccr: the filter's flag.
        det_model: ``[detection] model`` (static); det_params: ``DetectionParams``: the
            filter's Pd of a track at its predicted range.
        density: clutter density per unit measurement volume (> 0).
        gate, pg: the gate γ and its probability P_G.
        reflect: apply the ground prior (reflect ``ẑ < 0``) after the update (static).
        exclusive: each return updates only its likeliest track (static).
    """

    def radar_step(x, P, on, z, ok, r, own):
        def h(x6):
            return model.predict(r[None], x6[None, :3]).reshape(model.dim)

        def R(zh):
            return jnp.diag(model.variance(zh, own, ccr))

        nll = innovation_nll(x, P, z, h, R, model.residual, gate)
        return jnp.where(ok & on, nll, jnp.inf), h, R

    def one_radar(means, covs, on, pd, z, ok, r, own):
        """Every track's update from one radar's scan ``z [L, dim]``, ``ok [L]``."""
        nll = jax.vmap(lambda x, P, o: radar_step(x, P, o, z, ok, r, own)[0])(means, covs, on)
        mine = jnp.argmin(nll, axis=0)[None, :] == jnp.arange(means.shape[0])[:, None]

        def step(x, P, on_k, pd_k, mine_k):
            _, h, R = radar_step(x, P, on_k, z, ok, r, own)
            use = ok & mine_k if exclusive else ok
            (x, P), _ = pda.pda_update(
                x, P, z, use, h, R, pd_k, density, gate, pg, residual=model.residual
            )
            return x, P

        return (*jax.vmap(step)(means, covs, on, pd, mine), nll)

    def associate(means, covs, on, zs, valid, radar_pos):
        d2 = jnp.sum((means[:, None, :3] - radar_pos[None]) ** 2, -1)  # [K, N]
        pd = detection.pair_probability(det_model, det_params, d2)
        pd = jnp.clip(jnp.where(on[:, None], pd, 0.0), 0.0, 1.0 - 1e-6)  # b > 0 if perfect
        out = []
        for i in range(radar_pos.shape[0]):  # radar after radar (static N)
            own = at_radar(noise, i)
            means, covs, nll = one_radar(
                means, covs, on, pd[:, i], zs[i], valid[i], radar_pos[i], own
            )
            out.append(nll)
        if reflect:
            means, covs = jax.vmap(ground_prior.apply_ground_prior)(means, covs)
        return means, covs, jnp.stack(out, axis=1)

    return associate


def _pd(det_model, det_params, means, on, radar_pos):
    """``[K, N]`` the filter's Pd of each live slot at each radar (0 for empty slots)."""
    d2 = jnp.sum((means[:, None, :3] - radar_pos[None]) ** 2, -1)
    pd = detection.pair_probability(det_model, det_params, d2)
    return jnp.clip(jnp.where(on[:, None], pd, 0.0), 0.0, 1.0 - 1e-6)  # b > 0 if perfect


def gnn_associator(model, noise, ccr, det_model, det_params, density, gate, pg, reflect):
    """The joint GNN associator of the track table (``association = "gnn"``).

    Radar after radar, the live slots' cubature moments against the scan give the log
    likelihood ratios ``log r[K, L]`` (:func:`association.log_ratios`: ``−inf`` outside
    the gate, for invalid returns and empty slots); the best joint event
    (:func:`assignment.gnn_assignment`, exact over all K slots) gives each track one
    return or none and no return to two tracks; each track takes the Kalman update with
    its return (:func:`pda.mixture` with hard weights). ``nll`` is finite only on the
    assigned pairs, so the table's hits and explained returns are the assignment's.

    Args: as :func:`pda_associator` (without ``exclusive``: the assignment is exclusive).
    """
    args = (model, noise, ccr, det_model, det_params, density, gate, pg, reflect)
    return _joint_associator(assignment.gnn_assignment, True, *args)


def jpda_associator(
    model, noise, ccr, det_model, det_params, density, gate, pg, reflect, iterations=20
):
    """The joint PDA associator of the track table (``association = "jpda"``,
    ``marginals = "lbp"``).

    As :func:`gnn_associator`, with the JPDA's association marginals ``(β_0[K], β[K, L])``
    by loopy belief propagation over all K slots
    (:func:`~mjx_radar.estimation.data_association.lbp.lbp_marginals`: linear in K and
    L, exact where no two tracks share more than a chain of gated returns) and each
    track's PDA mixture of them (:func:`pda.mixture`). ``nll`` is finite on every gated
    pair, as the per-track PDA's, so hits and explained returns follow the gates.

    Args: as :func:`pda_associator`; ``iterations``: message-passing sweeps (static).
    """
    args = (model, noise, ccr, det_model, det_params, density, gate, pg, reflect)
    return _joint_associator(lambda logr: lbp.lbp_marginals(logr, iterations), False, *args)


def _joint_associator(
    rule, hard, model, noise, ccr, det_model, det_params, density, gate, pg, reflect
):
    """Radar after radar, the weights ``rule(log r [K, L]) -> (β_0, β)`` of the live
    slots and each slot's PDA mixture; ``hard``: ``nll`` only on the pairs with β > 1/2."""

    def one_radar(means, covs, pd, z, ok, h, R):
        moments = jax.vmap(lambda x, P: pda.innovations(x, P, z, h, R, model.residual))
        K, S, nu, d2, logdet = moments(means, covs)
        b, seen = pda.miss_ratio(pd, density, logdet, pg)
        logr = association.log_ratios(d2, ok, b, seen, gate)
        beta0, beta = rule(logr)
        means, covs = jax.vmap(pda.mixture)(means, covs, K, S, nu, beta0, beta)
        paired = beta > 0.5 if hard else jnp.isfinite(logr)
        nll = jnp.where(paired, d2 + logdet[:, None], jnp.inf)
        return means, covs, nll

    def associate(means, covs, on, zs, valid, radar_pos):
        pd = _pd(det_model, det_params, means, on, radar_pos)
        out = []
        for i in range(radar_pos.shape[0]):  # radar after radar (static N)
            h, R = pda.radar_model(model, noise, ccr, radar_pos, i)
            means, covs, nll = one_radar(means, covs, pd[:, i], zs[i], valid[i], h, R)
            out.append(nll)
        if reflect:
            means, covs = jax.vmap(ground_prior.apply_ground_prior)(means, covs)
        return means, covs, jnp.stack(out, axis=1)

    return associate


def update(table, zs, valid, radar_pos, associate, hit_radars: int):
    """The table after one scan's association.

    Returns:
        ``(table, hit [K], explained [N, L])`` (``hit``: returns in the gate from at
        least ``hit_radars`` radars; ``table.gated`` the radars that saw each slot).
    """
    on = track_table.live(table)
    means, covs, nll = associate(table.mean, table.cov, on, zs, valid, radar_pos)
    nll = jnp.where(on[:, None, None] & valid[None], nll, jnp.inf)  # [K, N, L]
    means = jnp.where(on[:, None], means, table.mean)
    covs = jnp.where(on[:, None, None], covs, table.cov)
    k, n, ell = nll.shape
    claim = jnp.argmin(nll, axis=-1)  # [K, N] each track's nearest return
    has = jnp.isfinite(jnp.min(nll, axis=-1))
    owner = jnp.argmin(nll, axis=0)  # [N, L] each return's likeliest track
    seen = has & (owner[jnp.arange(n)[None, :], claim] == jnp.arange(k)[:, None])
    hit = jnp.sum(seen, -1) >= hit_radars
    picked = jax.nn.one_hot(claim, ell, dtype=bool) & has[..., None]  # [K, N, L]
    table = table._replace(mean=means, cov=covs, gated=seen)
    return table, hit, jnp.any(picked, 0)
