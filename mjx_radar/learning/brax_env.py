"""The environment as a brax ``Env`` (brax PPO / SAC train on it), not a second loop.

:class:`BraxRadarEnv` wraps a :class:`~mjx_radar.env.environment.RadarEnv`: its
``pipeline_state`` is the environment's own :class:`~mjx_radar.env.state.State`, each
``step`` is one ``RadarEnv.step`` (one control period), the observation, action and
reward are those of :mod:`mjx_radar.learning.features`::

    obs    = features(env, state.obs)                       [feature_size]
    u      = action_to_control(env, a)                      a in [-1, 1]^{2N}
    reward = -Σ_m log det P_m,pos  -  c · penalty(...)  -  g · keepout_depth(...)

A NaN or inf control of a traced action is applied as 0 (the reward and features stay
finite) and flagged in ``pipeline_state.obs.nonfinite_action``; outside ``jit`` it is
refused in one line. The base environment never ends (``done = 0``); the episode
length, truncation and auto-reset are wrappers (:func:`wrap_for_training`, the ``wrap_env_fn`` of
``brax.training.agents.ppo.train``). Every episode draws a new trial: the auto-reset
calls ``reset`` with a fresh key (radar placement, drone states and noise follow the
scenario's sampling: the domain randomisation), unlike brax's ``AutoResetWrapper``
which restarts from the first state of its slot.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
from brax.envs.base import Env, State, Wrapper
from brax.envs.wrappers.training import EpisodeWrapper, VmapWrapper

from mjx_radar.env.environment import METRICS
from mjx_radar.env.environment import make as make_env
from mjx_radar.env.inputs import finite_controls
from mjx_radar.learning.config import check_setting
from mjx_radar.learning.features import (
    action_to_control,
    feature_size,
    features,
    keepout_depth,
    penalty,
)
from mjx_radar.learning.set_features import flat_size, flatten, set_features
from mjx_radar.learning.shield import shield as keepout_shield

_CLIP = 1e3  # |reward| and |feature| bound (a diverged track gives inf log dets)


class BraxRadarEnv(Env):
    """A :class:`~mjx_radar.env.environment.RadarEnv` behind brax's ``Env`` contract.

    Args:
        env: the radar environment (``mjx_radar.env.make(scenario, method)``).
        penalty_scale: ``c``, the penalty's weight in the reward (1: the MPC objective's
            own weights; smaller values are reward shaping for training, the keep-outs
            then cost less than they do to MPPI).
        keepout_grade: ``g``, the weight of the graded radar-drone keep-out
            (:func:`~mjx_radar.learning.features.keepout_depth`; 0: none).
        shield: pass the control through the keep-out shield
            (:func:`mjx_radar.learning.shield.shield`) before it is applied.
        observation: ``"flat"`` (:func:`~mjx_radar.learning.features.features`) or
            ``"set"`` (the flattened :func:`~mjx_radar.learning.set_features.set_features`,
            the set network's input; ``"set-v2"``: their version v2).

    ``metrics`` (per period, float32): ``information`` (``-Σ log det P_pos``),
    ``penalty`` (the keep-out terms, unscaled) and the environment's metrics (``rmse_pos``,
    ``lost``, ...), summed over an episode by brax's ``EpisodeWrapper``.
    """

    def __init__(
        self,
        env,
        penalty_scale: float = 1.0,
        keepout_grade: float = 0.0,
        shield: bool = False,
        observation: str = "flat",
    ):
        if observation not in ("flat", "set", "set-v2"):
            raise ValueError(f"observation = {observation!r}: flat, set or set-v2")
        check_setting("penalty_scale", penalty_scale)
        check_setting("keepout_grade", keepout_grade)
        self.radar_env = env
        self.observation = observation
        self._version = "v2" if observation == "set-v2" else "v1"  # the set features'
        self.shield = bool(shield)
        self.penalty_scale = float(penalty_scale)
        self.keepout_grade = float(keepout_grade)
        self.episode_length = env.episode_length

    @property
    def observation_size(self) -> int:
        env = self.radar_env
        if self.observation != "flat":
            return flat_size(env.n_radars, env.n_tracks, self._version)
        return feature_size(env.n_radars, env.n_targets)

    @property
    def action_size(self) -> int:
        return self.radar_env.action_size

    @property
    def backend(self) -> str:
        return "mjx"

    def reset(self, rng: jax.Array) -> State:
        s = self.radar_env.reset(rng)
        zero = jnp.zeros((), jnp.float32)
        return State(
            pipeline_state=s,
            obs=self._obs(s),
            reward=zero,
            done=zero,
            metrics=self._metrics(s, zero, zero),
            info={},
        )

    def step(self, state: State, action: jax.Array) -> State:
        env = self.radar_env
        u, bad = finite_controls(action_to_control(env, action))  # a NaN control: 0
        if self.shield:
            u = keepout_shield(env, state.pipeline_state.obs, u)
        s = env.step(state.pipeline_state, u)
        s = s._replace(obs=s.obs._replace(nonfinite_action=bad | s.obs.nonfinite_action))
        info = jnp.clip(jnp.nan_to_num(s.reward.astype(jnp.float32), nan=-_CLIP), -_CLIP, _CLIP)
        pen = jnp.clip(penalty(env, state.pipeline_state.obs, s.obs, u), 0.0, _CLIP)
        return state.replace(
            pipeline_state=s,
            obs=self._obs(s),
            reward=info - self.penalty_scale * pen - self._graded(s),
            metrics={**state.metrics, **self._metrics(s, info, pen)},  # wrappers add keys
        )

    def _graded(self, s) -> jax.Array:
        if not self.keepout_grade:  # off: the program has no such term
            return jnp.zeros((), jnp.float32)
        depth = jnp.clip(keepout_depth(self.radar_env, s.obs), 0.0, _CLIP)
        return self.keepout_grade * depth

    def _obs(self, s) -> jax.Array:
        if self.observation != "flat":
            return flatten(
                set_features(self.radar_env, s.obs, self._version)
            )  # already finite, clipped
        f = features(self.radar_env, s.obs)
        return jnp.clip(jnp.nan_to_num(f, nan=0.0), -_CLIP, _CLIP)

    @staticmethod
    def _metrics(s, info, pen) -> dict:
        out = {"information": info, "penalty": pen}
        out.update({k: jnp.nan_to_num(s.metrics[k].astype(jnp.float32)) for k in METRICS})
        return out


class FullResetWrapper(Wrapper):
    """Auto-reset with a *new* trial: a finished episode restarts from ``reset`` of a
    fresh key (split from the slot's key at every step), selected with ``where``."""

    def __init__(self, env, base: BraxRadarEnv):
        super().__init__(env)
        self._reset = jax.vmap(base.reset)

    def reset(self, rng: jax.Array) -> State:
        state = self.env.reset(rng)
        state.info["reset_key"] = rng
        return state

    def step(self, state: State, action: jax.Array) -> State:
        steps = jnp.where(state.done, jnp.zeros_like(state.info["steps"]), state.info["steps"])
        state.info.update(steps=steps)
        state = self.env.step(state.replace(done=jnp.zeros_like(state.done)), action)
        keys = jax.vmap(jax.random.split)(state.info["reset_key"])  # [B, 2, 2]
        fresh = self._reset(keys[:, 0])

        def where_done(new, old):
            done = jnp.reshape(state.done, (-1,) + (1,) * (old.ndim - 1))
            return jnp.where(done > 0, new, old)

        state.info["reset_key"] = keys[:, 1]
        return state.replace(
            pipeline_state=jax.tree.map(where_done, fresh.pipeline_state, state.pipeline_state),
            obs=where_done(fresh.obs, state.obs),
        )


def wrap_for_training(env: BraxRadarEnv, episode_length=None, action_repeat=1, **kw):
    """``FullReset(Episode(Vmap(env)))``: brax's ``wrap_env_fn`` for this environment.

    Args:
        env: a :class:`BraxRadarEnv`.
        episode_length: control periods per episode (default the scenario's).
        action_repeat: periods an action is held (1: a decision every ``dt_control``).
        **kw: ``randomization_fn`` must be None (trials are drawn by ``reset``'s key).
    """
    if kw.get("randomization_fn") is not None:
        raise ValueError("randomization_fn: trials are randomised by reset(key); give None")
    length = env.episode_length if episode_length is None else episode_length
    return FullResetWrapper(EpisodeWrapper(VmapWrapper(env), length, action_repeat), env)


def make(
    scenario,
    method="ddr-sfim",
    seed=None,
    steps=None,
    penalty_scale=1.0,
    keepout_grade=0.0,
    shield=False,
    observation="flat",
) -> BraxRadarEnv:
    """The brax environment of a scenario (``mjx_radar.env.make``'s arguments, the
    reward's weights, the shield and the observation: :class:`BraxRadarEnv`)."""
    env = make_env(scenario, method, seed, steps)
    return BraxRadarEnv(env, penalty_scale, keepout_grade, shield, observation)
