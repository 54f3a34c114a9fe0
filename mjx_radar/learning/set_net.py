"""A permutation-equivariant policy and value network for any fleet size (flax).

The network reads one :class:`~mjx_radar.learning.set_features.SetObs` and shares every
weight across radars, targets and pairs (deep sets / graph network style)::

    r_i  = φ_r(radar_i)                        t_j = φ_t(target_j)          [H]
    e_ij = φ_e(pair_ij, r_i, t_j)                                           [H]
    h_i  = φ_h(r_i, mean_j e_ij, max_j e_ij)           (over real targets)  [H]
    g_ik = φ_g(p_k - p_i, |p_k - p_i|_xy, h_i, h_k)                         [H]
    z_i  = φ_z(h_i, mean_{k≠i} g_ik, mean_j t_j)       (over real radars)   [H]
    policy:  loc_i = W z_i                       [N, 2]  (the action is tanh(loc))
    value:   v = mean_i w · z_i                  []

so permuting the radars permutes the outputs the same way, permuting the targets
leaves them unchanged, and the same parameters apply to any N and M (padding rows,
mask 0, change nothing). ``p`` are the radars' scaled positions (``radar[:, :3]``).
"""

from __future__ import annotations

from collections.abc import Sequence

import flax.linen as nn
import jax
import jax.numpy as jnp

from mjx_radar.learning.set_features import SIZES, SetObs


class MLP(nn.Module):
    """Dense layers with ``swish`` between them (and after the last: a hidden encoder)."""

    sizes: Sequence[int]

    @nn.compact
    def __call__(self, x):
        for size in self.sizes:
            x = nn.swish(nn.Dense(size)(x))
        return x


def masked_mean(x, mask, axis):
    """Mean of ``x`` over ``axis`` where ``mask`` (broadcast to ``x``) is 1 (0 if none)."""
    mask = jnp.broadcast_to(mask, x.shape)
    return jnp.sum(x * mask, axis) / jnp.maximum(jnp.sum(mask, axis), 1.0)


def masked_max(x, mask, axis):
    """Max of ``x`` over ``axis`` where ``mask`` is 1 (0 if none)."""
    mask = jnp.broadcast_to(mask, x.shape)
    top = jnp.max(jnp.where(mask > 0, x, -jnp.inf), axis)
    return jnp.where(jnp.isfinite(top), top, 0.0)


class SetNet(nn.Module):
    """The network of the module docstring.

    Attributes:
        hidden: the width H of every encoder.
        value: False: the policy head (``[N, 2]`` pre-tanh action means); True: the
            value head (``[]``).
    """

    hidden: int = 64
    value: bool = False

    @nn.compact
    def __call__(self, x: SetObs) -> jax.Array:
        h = self.hidden
        n, m = x.radar.shape[-2], x.target.shape[-2]
        rmask, tmask = x.radar_mask, x.target_mask
        r = MLP((h, h), name="radar")(x.radar)  # [N, H]
        t = MLP((h, h), name="target")(x.target)  # [M, H]
        both = [x.pair, jnp.broadcast_to(r[:, None], (n, m, h))]
        both.append(jnp.broadcast_to(t[None], (n, m, h)))
        e = MLP((h, h), name="pair")(jnp.concatenate(both, -1))  # [N, M, H]
        tm = tmask[None, :, None]
        hr = MLP((h,), name="radar_pool")(
            jnp.concatenate([r, masked_mean(e, tm, 1), masked_max(e, tm, 1)], -1)
        )  # [N, H]
        pos = x.radar[:, :3]
        rel = pos[None, :, :] - pos[:, None, :]  # [N, N, 3]: k's position from i's
        dist = jnp.sqrt(jnp.sum(rel[..., :2] ** 2, -1, keepdims=True) + 1e-9)
        hi = jnp.broadcast_to(hr[:, None], (n, n, h))
        hk = jnp.broadcast_to(hr[None, :], (n, n, h))
        g = MLP((h, h), name="radar_pair")(jnp.concatenate([rel, dist, hi, hk], -1))
        others = (rmask[None, :] * (1.0 - jnp.eye(n, dtype=rmask.dtype)))[..., None]
        ctx = jnp.broadcast_to(masked_mean(t, tmask[:, None], 0), (n, h))
        z = MLP((h, h), name="head")(jnp.concatenate([hr, masked_mean(g, others, 1), ctx], -1))
        if self.value:
            return masked_mean(nn.Dense(1, name="value_out")(z)[:, 0], rmask, 0)
        return nn.Dense(
            2,
            name="action_out",
            kernel_init=nn.initializers.variance_scaling(0.01, "fan_in", "truncated_normal"),
        )(z)


def init_params(hidden: int, key, value: bool = False, features: str = "v1"):
    """Parameters of a :class:`SetNet` (the same for every fleet size) for the set
    features of version ``features`` (:data:`~mjx_radar.learning.set_features.SIZES`)."""
    rs, ts, ps = SIZES[features]
    x = SetObs(
        jnp.zeros((2, rs)), jnp.zeros((2, ts)), jnp.zeros((2, 2, ps)), jnp.ones(2), jnp.ones(2)
    )
    # one compiled program: flax's eager init compiles every small op on its own (~10 s
    # on 2 CPU cores, most of a tiny distillation's start-up)
    return jax.jit(SetNet(hidden, value).init)(key, x)


def policy_action(params, x: SetObs, hidden: int) -> jax.Array:
    """``[..., N, 2]`` the deterministic action ``tanh(loc)`` in ``[-1, 1]`` (batch axes
    of ``x`` are vmapped)."""
    net = SetNet(hidden)
    fn = lambda o: jnp.tanh(net.apply(params, o))  # noqa: E731
    for _ in range(x.radar.ndim - 2):
        fn = jax.vmap(fn)
    return fn(x)
