"""The environment for gymnasium users (Stable-Baselines3 and the like, on a CPU).

:class:`RadarGymEnv` is a ``gymnasium.Env`` over one
:class:`~mjx_radar.learning.brax_env.BraxRadarEnv` (the same observation, action and
reward as brax training); :class:`RadarVectorEnv` a ``gymnasium.vector.VectorEnv`` over
``num_envs`` of them, batched with ``jax.vmap`` in one jitted call per step. Arrays
cross to numpy (float32) at each call: a host round trip per step, as gymnasium's
contract wants; train on the GPU with brax (:mod:`mjx_radar.learning.train`).

* ``observation_space``: ``Box(-1e3, 1e3, (feature_size,), float32)``
  (:func:`~mjx_radar.learning.features.features`, clipped to ±1e3);
* ``action_space``: ``Box(-1, 1, (2N,), float32)``, mapped onto the radars' limits;
* ``reset(seed=...)`` draws a trial (placement, drones, noise) from the key
  ``PRNGKey(s)``, ``s`` drawn from ``np_random``; ``terminated`` is always False and
  ``truncated`` is True after the scenario's ``episode_length`` control periods.
* the vector env autoresets in gymnasium's ``NEXT_STEP`` mode: the step after a
  sub-env's episode ends resets it (its action is ignored, reward 0).

Example:
    >>> env = RadarGymEnv("smoke")
    >>> obs, info = env.reset(seed=0)
    >>> obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
"""

from __future__ import annotations

import gymnasium
import jax
import jax.numpy as jnp
import numpy as np
from gymnasium import spaces
from gymnasium.vector import AutoresetMode, VectorEnv

from mjx_radar.io.checks import ScenarioError
from mjx_radar.learning import brax_env

_BOUND = 1e3


def _spaces(env: brax_env.BraxRadarEnv):
    obs = spaces.Box(-_BOUND, _BOUND, (env.observation_size,), np.float32)
    act = spaces.Box(-1.0, 1.0, (env.action_size,), np.float32)
    return obs, act


def _action(action, shape: tuple, where: str) -> np.ndarray:
    """``action`` as float32 of the action space's ``shape``, finite (one line otherwise;
    never reshaped: a transposed action would scramble the radars' controls)."""
    try:
        a = np.asarray(action, np.float32)
    except (TypeError, ValueError):
        raise ScenarioError(
            f"{where}: action = {action!r:.40}: must be an array of shape {list(shape)}"
        ) from None
    if a.shape != tuple(shape):
        raise ScenarioError(
            f"{where}: action of shape {list(a.shape)}: must be {list(shape)} (action_space)"
        )
    if not np.isfinite(a).all():
        raise ScenarioError(f"{where}: action holds NaN or inf: every component must be finite")
    return a


def _info(state) -> dict:
    return {k: np.asarray(v) for k, v in state.metrics.items()}


class RadarGymEnv(gymnasium.Env):
    """One radar environment as a ``gymnasium.Env`` (module docstring).

    Args:
        scenario: a scenario (name, path or :class:`~mjx_radar.Scenario`).
        method: the tracker's method (default ``ddr-sfim``).
    """

    metadata = {"render_modes": []}

    def __init__(self, scenario="smoke", method: str = "ddr-sfim"):
        self.env = brax_env.make(scenario, method)
        self.observation_space, self.action_space = _spaces(self.env)
        self.episode_length = self.env.episode_length
        self._reset = jax.jit(self.env.reset)
        self._step = jax.jit(self.env.step)
        self._state, self._t = None, 0

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        key = jax.random.PRNGKey(int(self.np_random.integers(0, 2**31 - 1)))
        self._state, self._t = self._reset(key), 0
        return np.asarray(self._state.obs, np.float32), _info(self._state)

    def step(self, action):
        if self._state is None:
            raise gymnasium.error.ResetNeeded("call reset() before step()")
        a = jnp.asarray(_action(action, self.action_space.shape, "step"))
        self._state = self._step(self._state, a)
        self._t += 1
        truncated = self._t >= self.episode_length
        obs = np.asarray(self._state.obs, np.float32)
        return obs, float(self._state.reward), False, truncated, _info(self._state)


class RadarVectorEnv(VectorEnv):
    """``num_envs`` radar environments, vmapped, as a ``gymnasium.vector.VectorEnv``.

    Args:
        scenario: a scenario (name, path or :class:`~mjx_radar.Scenario`).
        num_envs: parallel environments (>= 1).
        method: the tracker's method (default ``ddr-sfim``).
    """

    metadata = {"render_modes": [], "autoreset_mode": AutoresetMode.NEXT_STEP}

    def __init__(self, scenario="smoke", num_envs: int = 4, method: str = "ddr-sfim"):
        if isinstance(num_envs, bool) or not isinstance(num_envs, int) or num_envs < 1:
            raise ValueError(f"num_envs = {num_envs!r}: must be an integer >= 1")
        self.env = brax_env.make(scenario, method)
        self.num_envs = num_envs
        self.single_observation_space, self.single_action_space = _spaces(self.env)
        self.observation_space = spaces.Box(
            -_BOUND, _BOUND, (num_envs, self.env.observation_size), np.float32
        )
        self.action_space = spaces.Box(-1.0, 1.0, (num_envs, self.env.action_size), np.float32)
        self.episode_length = self.env.episode_length
        self._reset = jax.jit(jax.vmap(self.env.reset))
        self._step = jax.jit(self._masked_step)
        self._state = None
        self._t = np.zeros(num_envs, np.int64)
        self._needs_reset = np.zeros(num_envs, bool)

    def _masked_step(self, state, action, fresh_keys, reset_mask):
        stepped = jax.vmap(self.env.step)(state, action)
        fresh = jax.vmap(self.env.reset)(fresh_keys)

        def pick(new, old):
            m = jnp.reshape(reset_mask, (-1,) + (1,) * (old.ndim - 1))
            return jnp.where(m, new, old)

        return jax.tree.map(pick, fresh, stepped)

    def _keys(self) -> jax.Array:
        seeds = self.np_random.integers(0, 2**31 - 1, size=self.num_envs)
        return jax.vmap(jax.random.PRNGKey)(jnp.asarray(seeds, jnp.uint32))

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self._state = self._reset(self._keys())
        self._t[:] = 0
        self._needs_reset[:] = False
        return np.asarray(self._state.obs, np.float32), _info(self._state)

    def step(self, actions):
        if self._state is None:
            raise gymnasium.error.ResetNeeded("call reset() before step()")
        a = jnp.asarray(_action(actions, self.action_space.shape, "step"))
        mask = self._needs_reset.copy()
        self._state = self._step(self._state, a, self._keys(), jnp.asarray(mask))
        self._t = np.where(mask, 0, self._t + 1)
        truncated = self._t >= self.episode_length
        self._needs_reset = truncated.copy()
        reward = np.where(mask, 0.0, np.asarray(self._state.reward, np.float64))
        obs = np.asarray(self._state.obs, np.float32)
        terminated = np.zeros(self.num_envs, bool)
        return obs, reward, terminated, truncated, _info(self._state)
