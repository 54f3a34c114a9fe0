"""An associator of one's own: global nearest neighbour by Bertsekas' auction (one module).

Radar after radar, every live track k and return l of the scan get the cost
``d²_kl = ν_klᵀ S_k⁻¹ ν_kl`` (the cubature prediction of the track's measurement;
``+BIG`` outside the gate ``d² < γ``, for invalid returns and dead tracks), and each track a
private "miss" column of cost γ. :func:`assign` finds the assignment of tracks to
columns of least total cost (within K·eps of the optimum) by the auction algorithm; a
track assigned a return takes the Kalman update with it, a missed one keeps its
prediction. Pure JAX: ``lax.while_loop`` with fixed shapes, so it runs in the closed
loop's scan and under ``vmap`` over trials. Registered by examples/custom_associator.py.
"""

import jax
import jax.numpy as jnp

from mjx_radar.estimation.data_association import pda

BIG = 1e6  # the cost of a forbidden pair (outside the gate, another track's miss column)


def assign(cost, eps=1e-3, max_bids=20_000):
    """Rows to columns of ``cost [K, J]`` (J >= K) at least total cost: ``[K]`` column indices.

    Gauss-Seidel auction: the first unassigned row bids for its best column
    ``j1 = argmax(−c_ij − p_j)``, raising its price by ``w1 − w2 + eps`` (best minus
    second-best value) and taking it from its owner. Ends with every row assigned, the
    total within ``K eps`` of the optimum (or after ``max_bids`` bids).
    """
    k, j = cost.shape
    value = -cost

    def bid(state):
        price, owner, col, n = state
        i = jnp.argmax(col < 0)  # the first unassigned row
        v = value[i] - price
        j1 = jnp.argmax(v)
        w2 = jnp.max(jnp.where(jnp.arange(j) == j1, -jnp.inf, v))
        price = price.at[j1].add(v[j1] - w2 + eps)
        col = jnp.where(jnp.arange(k) == owner[j1], -1, col).at[i].set(j1)
        return price, owner.at[j1].set(i), col, n + 1

    def bidding(state):
        return jnp.any(state[2] < 0) & (state[3] < max_bids)

    start = (jnp.zeros(j, cost.dtype), jnp.full(j, -1), jnp.full(k, -1), jnp.int32(0))
    return jax.lax.while_loop(bidding, bid, start)[2]


def auction_associator(task, params):
    """``factory(task, params) -> associate`` (mjx_radar.contracts.AssociatorFactory)."""
    model, gate = task.measurement, params.detection.gate

    def one_radar(means, covs, live, z, ok, h, R):
        K, S, nu, d2, logdet = jax.vmap(pda.innovations, (0, 0, None, None, None, None))(
            means, covs, z, h, R, model.residual
        )  # K [T, 6, p], S [T, p, p], nu [T, L, p], d2 [T, L], logdet [T]
        inside = (d2 < gate) & ok[None, :] & live[:, None]
        t = means.shape[0]
        miss = jnp.where(jnp.eye(t, dtype=bool), gate, BIG)
        col = assign(jnp.concatenate([jnp.where(inside, d2, BIG), miss], axis=1))
        got = (col >= 0) & (col < z.shape[0])  # a return (not its miss column)
        pick = jnp.clip(col, 0, z.shape[0] - 1)[:, None, None]
        nu_k = jnp.take_along_axis(nu, pick, 1)[:, 0]
        step = jnp.einsum("tnp,tp->tn", K, nu_k)
        gain = jnp.einsum("tnp,tpq,tmq->tnm", K, S, K)
        means = jnp.where(got[:, None], means + step, means)
        covs = jnp.where(got[:, None, None], covs - gain, covs)
        return means, covs, jnp.where(inside, d2 + logdet[:, None], jnp.inf)

    def associate(means, covs, live, zs, valid, radar_pos):
        nll = []
        for i in range(radar_pos.shape[0]):  # radar after radar (static N)
            h, R = pda.radar_model(model, params.noise, params.method.ccr, radar_pos, i)
            means, covs, out = one_radar(means, covs, live, zs[i], valid[i], h, R)
            nll.append(out)
        return means, covs, jnp.stack(nll, axis=1)

    return associate
