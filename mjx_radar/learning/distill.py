"""Distillation of the MPPI planner into a set policy: rollouts labelled by the teacher,
and the cloning loss's gradient steps (pure functions; the driver is
:mod:`mjx_radar.learning.distill_train`).

The teacher is the scenario's MPPI planner (``planners.make("mppi", env)``, the
planner the simulator runs) called on the observation of every visited state, its warm
start carried along the trajectory. One rollout (``lax.scan`` over control periods,
``vmap`` over trials) applies in each period the teacher's control with probability
β and the policy's otherwise::

    u_T, carry = MPPI.plan(carry, obs, key)              the label
    u_π = action_to_control(env, tanh(SetNet(set_features(obs))))   (then the shield,
                                                          if configured)
    u   = u_T if uniform() < β else u_π                  β = 1: behaviour cloning
                                                          β < 1: DAgger (policy drives)

and keeps ``(set_features(obs), control_to_action(u_T))`` of every period. The loss is
the mean squared difference of the policy's action ``tanh(loc)`` and the teacher's, in
``[-1, 1]`` action units, over the real radars (``radar_mask``), averaged over the
scenarios (each its own buffer: fleets of several sizes train one network).

``keepout_weight`` w > 0 (off by default) adds a keep-out hinge on where the policy's own
action would bring each radar within K = :data:`HINGE_PERIODS` control periods (the
action held, the drone at its estimated velocity), differentiable in the action::

    t = K T,   v_K = clip(v + ā a t, -v̄, v̄)   (the clip's gradient taken as 1)
    p̂ = p + (v + v_K) t / 2 · h,   q̂ = q + t q̇
    loss += w · mean_i Σ_j present_j · relu((R2T - |p̂_i - q̂_j|) / R2T)²

(everything read back from the set features: positions ``·L``, speeds ``·v̄``). MPPI's
own labels keep it zero on the states it drives through (its radars ride the keep-out's
edge, a few metres out: a longer look-ahead or a margin would penalise the teacher's own
controls), so it acts where the policy has driven a radar towards or into the keep-out:
there it pulls the action out, also where the teacher's label does not.
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
import optax

from mjx_radar import precision
from mjx_radar.env.streams import streams_of
from mjx_radar.learning import replay
from mjx_radar.learning.features import action_to_control, control_to_action
from mjx_radar.learning.set_features import SetObs, set_features
from mjx_radar.learning.set_net import policy_action
from mjx_radar.learning.shield import shield


class Sample(NamedTuple):
    """One labelled state: the policy's input and the teacher's action."""

    obs: SetObs
    action: jax.Array  # [N, 2] the teacher's control in [-1, 1] action units


class RolloutStats(NamedTuple):
    """Per period and trial (``[E, P]``): what the rollout's controls did."""

    rmse_pos: jax.Array  # the tracker's position RMSE [m]
    inside: jax.Array  # fraction of radar-target pairs inside R2T (estimates)
    gap: jax.Array  # mean squared policy - teacher action difference (before updates)


class Scales(NamedTuple):
    """One scenario's constants that turn set features back into metres and seconds."""

    half_width: float  # L [m]
    speed: float  # v̄ [m/s]
    accel: jax.Array  # [N] ā per radar [m/s²]
    dt: float  # T, the control period [s]
    r2t: float  # the radar-drone keep-out radius [m]


def scales_of(env) -> Scales:
    """The :class:`Scales` of a :class:`~mjx_radar.env.environment.RadarEnv` (its task's
    fleet limits and clocks, its runtime numbers)."""
    task = env.task
    return Scales(
        float(env.params.placement_half_width),
        float(task.fleet.limits.speed),
        jnp.asarray(env.action_bounds[1][:, 0], jnp.float32),
        float(task.timing.dt_control),
        float(env.params.r2t),
    )


def make_collect(
    env, teacher, hidden: int, periods: int, shielded: bool = False, features: str = "v1"
):
    """``collect(params, keys [E, 2], beta) -> (Sample [E·P], RolloutStats [E, P])``.

    Args:
        env: the :class:`~mjx_radar.env.environment.RadarEnv`.
        teacher: its MPPI planner (``init``, ``plan``).
        hidden: the set network's width.
        periods: control periods per rollout (P).
        shielded: the policy's control passes the keep-out shield before it is applied.
        features: the set features' version (:func:`set_features`).
    """

    def trial(params, key, beta):
        state = env.reset(key)

        def period(carry, _):
            state, tcarry = carry
            obs = state.obs
            pkey = jax.random.fold_in(streams_of(state.info["key"]).planner, state.info["period"])
            u_t, tcarry = teacher.plan(tcarry, obs, pkey)
            u_t = env.clip_action(u_t)
            x = set_features(env, obs, features)
            a_p = policy_action(params, x, hidden)  # [N, 2]
            u_p = action_to_control(env, a_p.reshape(-1)).astype(u_t.dtype)
            if shielded:
                u_p = shield(env, obs, u_p)
            coin = jax.random.uniform(jax.random.fold_in(pkey, 0x0DA6)) < beta
            state = env.step(state, jnp.where(coin, u_t, u_p))
            a_t = control_to_action(env, u_t).reshape(-1, 2).astype(jnp.float32)
            stats = RolloutStats(
                state.metrics["rmse_pos"].astype(jnp.float32),
                jnp.mean((x.pair[..., 4] < 0).astype(jnp.float32)),
                jnp.mean((a_p - a_t) ** 2),
            )
            return (state, tcarry), (Sample(x, a_t), stats)

        _, out = jax.lax.scan(period, (state, teacher.init()), None, length=periods)
        return out

    @precision.pinned  # full float32 dots, as the simulator's closed loop (GPUs too)
    def collect(params, keys, beta):
        samples, stats = jax.vmap(trial, in_axes=(None, 0, None))(params, keys, beta)
        flat = jax.tree.map(lambda x: x.reshape((-1,) + x.shape[2:]), samples)
        return flat, stats

    return collect


def optimizer(learning_rate: float, max_grad_norm: float):
    """Adam after a global gradient-norm clip."""
    return optax.chain(optax.clip_by_global_norm(max_grad_norm), optax.adam(learning_rate))


def clone_loss(params, batch: Sample, hidden: int) -> jax.Array:
    """``[]`` mean squared action difference over the real radars of ``batch`` ``[B, ...]``."""
    pred = policy_action(params, batch.obs, hidden)  # [B, N, 2]
    mask = batch.obs.radar_mask[..., None]
    return jnp.sum(mask * (pred - batch.action) ** 2) / (2.0 * jnp.maximum(jnp.sum(mask), 1.0))


#: control periods of the keep-out hinge's look-ahead (module docstring)
HINGE_PERIODS = 3


def keepout_hinge(action, x: SetObs, scales: Scales, periods: int = HINGE_PERIODS) -> jax.Array:
    """``[...]`` the keep-out hinge of the module docstring for actions ``[..., N, 2]``
    taken on the states ``x`` (batch axes alike), summed over drones, mean over the
    real radars."""
    s = scales
    n = action.shape[-2]
    acc = jnp.broadcast_to(jnp.asarray(s.accel, jnp.float32), (n,))
    t = periods * s.dt
    p = x.radar[..., :3] * s.half_width
    th = jnp.arctan2(x.radar[..., 4], x.radar[..., 3])
    v = x.radar[..., 5] * s.speed
    raw = v + action[..., 0] * acc * t
    # the speed limit clips v_K, but the gradient passes as if it did not (straight
    # through): a radar at full speed towards a drone still learns to brake
    vk = raw + jax.lax.stop_gradient(jnp.clip(raw, -s.speed, s.speed) - raw)
    head = jnp.stack([jnp.cos(th), jnp.sin(th), jnp.zeros_like(th)], -1)
    p_next = p + (0.5 * (v + vk) * t)[..., None] * head  # [..., N, 3]
    q = x.target[..., :3] * s.half_width  # [..., M, 3]
    q_next = q + t * x.target[..., 3:6] * s.speed
    gap = p_next[..., :, None, :] - q_next[..., None, :, :]
    d = jnp.sqrt(jnp.sum(gap**2, -1) + 1e-6)  # [..., N, M]
    present = x.target_mask * (x.target[..., 27] > 0)  # [..., M]
    hinge = jax.nn.relu((s.r2t - d) / s.r2t) ** 2 * present[..., None, :]
    per_radar = jnp.sum(hinge, -1)
    rmask = x.radar_mask
    return jnp.sum(per_radar * rmask, -1) / jnp.maximum(jnp.sum(rmask, -1), 1.0)


def make_update(
    hidden: int, tx, batch_size: int, updates: int, keepout: tuple = (), weight: float = 0.0
):
    """``update(params, opt_state, buffers, key) -> (params, opt_state, losses [updates])``:
    ``updates`` Adam steps, each on ``batch_size`` samples of every buffer (the clone
    loss, plus ``weight`` times :func:`keepout_hinge` with each buffer's
    :class:`Scales` in ``keepout`` when ``weight > 0``)."""

    def one(params, b, i):
        loss = clone_loss(params, b, hidden)
        if weight > 0:  # off: the program has no such term
            pred = policy_action(params, b.obs, hidden)
            loss = loss + weight * jnp.mean(keepout_hinge(pred, b.obs, keepout[i]))
        return loss

    def loss_fn(params, batches):
        return jnp.mean(jnp.stack([one(params, b, i) for i, b in enumerate(batches)]))

    def update(params, opt_state, buffers, key):
        def step(carry, k):
            params, opt = carry
            keys = jax.random.split(k, len(buffers))
            batches = [
                replay.sample(b, kk, batch_size) for b, kk in zip(buffers, keys, strict=True)
            ]
            loss, grad = jax.value_and_grad(loss_fn)(params, batches)
            upd, opt = tx.update(grad, opt, params)
            return (optax.apply_updates(params, upd), opt), loss

        (params, opt_state), losses = jax.lax.scan(
            step, (params, opt_state), jax.random.split(key, updates)
        )
        return params, opt_state, losses

    return update
