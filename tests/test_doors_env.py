"""The environment door: env.make, reset and step, and the gymnasium and brax wrappers
refuse a user's mistakes in one line naming the argument; an action is never reshaped."""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import mjx_radar
from mjx_radar import ScenarioError
from mjx_radar import env as radar_env


@pytest.fixture(scope="module")
def env():
    return radar_env.make("smoke", steps=8)


@pytest.fixture(scope="module")
def state(env):
    return jax.jit(env.reset)(env.trial_key(0, 0))  # one program (eagerly: op by op)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"scenario": None}, "scenario = None: must be a Scenario"),
        ({"scenario": "smoke", "seed": -1}, r"seed = -1: must be an integer in \[0, 2\^31 - 1\]"),
        ({"scenario": "smoke", "seed": 2**40}, "seed = 1099511627776"),
        ({"scenario": "smoke", "seed": 1.5}, "seed = 1.5"),
        ({"scenario": "smoke", "steps": 0}, "steps = 0: must be an integer >= 1"),
        ({"scenario": "smoke", "steps": 6}, "steps = 6: must be a multiple of"),
        ({"scenario": "smoke", "method": "nope"}, "method: 'nope' is not one of"),
    ],
)
def test_make_refuses_in_one_line(kwargs, message):
    with pytest.raises(ScenarioError, match=message) as err:
        radar_env.make(**kwargs)
    assert "\n" not in str(err.value)


def test_make_validates_a_scenario_object():
    bad = dataclasses.replace(mjx_radar.load_scenario("smoke"), p0=-5.0)
    with pytest.raises(ScenarioError, match="p0 = -5.0"):
        radar_env.make(bad)


def test_reset_needs_a_key(env):
    with pytest.raises(ScenarioError, match="reset: key = 7: must be a PRNG key"):
        env.reset(7)
    with pytest.raises(ScenarioError, match=r"not an array float32\[3\]"):
        env.reset(jnp.zeros(3))


def test_step_refuses_a_wrong_state_and_wrong_actions(env, state):
    with pytest.raises(ScenarioError, match="step: state = 7: must be the State"):
        env.step(7, jnp.zeros((2, 2)))
    for bad in (jnp.zeros((2, 3)), jnp.zeros((3, 2)), jnp.zeros(6), jnp.zeros((1, 4))):
        with pytest.raises(ScenarioError, match=r"must be \[2, 2\] .* or \[4\]"):
            env.step(state, bad)
    with pytest.raises(ScenarioError, match="action holds NaN or inf"):
        env.step(state, jnp.array([[0.0, jnp.nan], [0.0, 0.0]]))
    with pytest.raises(ScenarioError, match="must be an array"):
        env.step(state, "fast")


def test_a_transposed_action_is_refused_where_traced(env, state):
    # a [2, N] action on N = 2 radars has the right shape; on 3 radars [2, 3] it had been
    # reshaped silently into scrambled controls
    with pytest.raises(ScenarioError, match=r"action of shape \[3, 2\]"):
        jax.eval_shape(env.step, state, jax.ShapeDtypeStruct((3, 2), jnp.float32))
    assert env.clip_action(jnp.arange(4.0)).shape == (2, 2)  # [2N] stays accepted


def test_gymnasium_step_refuses_wrong_shapes_and_nan():
    from mjx_radar.learning.gym_env import RadarGymEnv, RadarVectorEnv

    g = RadarGymEnv("smoke")
    g._state = object()  # as after reset(): the action is checked before anything runs
    with pytest.raises(ScenarioError, match=r"action of shape \[2, 3\]: must be \[4\]"):
        g.step(np.zeros((2, 3)))
    with pytest.raises(ScenarioError, match=r"action of shape \[2, 2\]: must be \[4\]"):
        g.step(np.zeros((2, 2)))
    with pytest.raises(ScenarioError, match="NaN or inf"):
        g.step(np.array([0.0, np.nan, 0.0, 0.0]))
    v = RadarVectorEnv("smoke", num_envs=2)
    v._state = object()
    with pytest.raises(ScenarioError, match=r"action of shape \[8\]: must be \[2, 4\]"):
        v.step(np.zeros(8))


def test_brax_action_is_checked_not_reshaped(env):
    from mjx_radar.learning.features import action_to_control

    with pytest.raises(ScenarioError, match=r"action of shape \[3\]"):
        action_to_control(env, jnp.zeros(3))
    assert action_to_control(env, jnp.zeros(4)).shape == (2, 2)


def test_a_nonfinite_action_inside_jit_is_applied_as_zero_and_flagged(env, state):
    assert not bool(state.obs.nonfinite_action)
    step = jax.jit(env.step)
    bad = step(state, jnp.array([[jnp.nan, 0.0], [jnp.inf, 0.0]]))
    zero = step(state, jnp.zeros((2, 2)))
    assert bool(bad.obs.nonfinite_action) and not bool(zero.obs.nonfinite_action)
    for a, b in zip(jax.tree.leaves(bad.loop), jax.tree.leaves(zero.loop), strict=True):
        np.testing.assert_array_equal(a, b)  # what the radars did: no acceleration
    assert np.isfinite(float(bad.reward)) and float(bad.reward) == float(zero.reward)
    assert not bool(step(bad, jnp.zeros((2, 2))).obs.nonfinite_action)  # the last action's


def test_a_finite_action_is_applied_unchanged(env, state):
    a = jnp.array([[0.3, -0.1], [5.0, 0.2]])  # 5.0 beyond the limits: clipped as before
    s = jax.jit(env.step)(state, a)
    runner = jax.jit(lambda s, a: env.transition(s, a, keep_nonfinite=True)[0])(state, a)
    for x, y in zip(jax.tree.leaves(s), jax.tree.leaves(runner), strict=True):
        np.testing.assert_array_equal(x, y)


def test_brax_step_inside_jit_flags_a_nan_action():
    from mjx_radar.learning import brax_env

    b = brax_env.make("smoke", steps=8)
    s = jax.jit(b.reset)(radar_env.RadarEnv.trial_key(0, 0))
    nan = jax.jit(b.step)(s, jnp.array([jnp.nan, 0.0, 0.0, 0.0]))
    ok = jax.jit(b.step)(s, jnp.zeros(4))
    assert bool(nan.pipeline_state.obs.nonfinite_action)
    assert not bool(ok.pipeline_state.obs.nonfinite_action)
    assert np.isfinite(float(nan.reward)) and np.isfinite(np.asarray(nan.obs)).all()
    with pytest.raises(ScenarioError, match="action holds NaN or inf"):
        b.step(s, jnp.array([jnp.nan, 0.0, 0.0, 0.0]))  # outside jit: refused


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"penalty_scale": -1}, "penalty_scale = -1: must be a finite number >= 0"),
        ({"penalty_scale": float("nan")}, "penalty_scale = nan"),
        ({"keepout_grade": float("inf")}, "keepout_grade = inf"),
    ],
)
def test_brax_reward_weights_are_checked(env, kwargs, message):
    from mjx_radar.learning.brax_env import BraxRadarEnv

    with pytest.raises(ScenarioError, match=message):
        BraxRadarEnv(env, **kwargs)


def test_a_text_action_is_refused_without_a_warning(env, state):
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")  # jnp.asarray of text warned before refusing
        with pytest.raises(ScenarioError, match=r"must be an array \[2, 2\] .* not list"):
            env.step(state, [["a", "b"], ["c", "d"]])
