"""MJX physics against the closed-form Euler models of SPEC §2 and §3."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjx_radar import physics
from mjx_radar.physics.kinematics import cv_step, sample_white_accel, unicycle_rollout
from mjx_radar.scenario.schema import RadarLimits, Scenario

LIM = RadarLimits()


def _controls(key, steps, n):
    # Uniform in twice the limits: about half the draws saturate |a| and |alpha|.
    u = jax.random.uniform(key, (steps, n, 2), minval=-2.0, maxval=2.0)
    return u * jnp.array([LIM.accel, LIM.alpha])


def _initial(n, key):
    xy = jax.random.uniform(key, (n, 2), minval=-400, maxval=400)
    # Start some radars at the speed / turn-rate limits so both saturate early.
    v = jnp.linspace(-LIM.speed, LIM.speed, n)
    w = jnp.linspace(LIM.omega, -LIM.omega, n)
    th = jnp.linspace(-3.0, 3.0, n)
    return jnp.stack([xy[:, 0], xy[:, 1], jnp.zeros(n), th, v, w], axis=-1)


@pytest.mark.parametrize("fused", [True, False])
@pytest.mark.parametrize(("steps", "dt", "pos_tol"), [(15, 0.1, 1e-3), (600, 0.025, 0.05)])
def test_mjx_radar_rollout_matches_analytic(steps, dt, pos_tol, fused):
    import dataclasses

    n = 3
    k1, k2 = jax.random.split(jax.random.PRNGKey(7))
    s0, u = _initial(n, k1), _controls(k2, steps, n)
    plant = physics.make_plant(n, 0, dt, LIM)
    assert plant.fused is not None
    plant = plant if fused else dataclasses.replace(plant, fused=None)  # MJX's stages
    mjx_traj = jax.jit(physics.radar_rollout, static_argnums=0)(plant, s0, u)
    ref = unicycle_rollout(s0, u, dt, LIM)
    # Every limit is hit in the reference trajectory (else the test proves less).
    assert np.any(np.abs(np.asarray(u)[..., 0]) > LIM.accel)
    assert np.any(np.abs(np.asarray(u)[..., 1]) > LIM.alpha)
    assert np.isclose(np.abs(ref[..., 4]).max(), LIM.speed)
    assert np.isclose(np.abs(ref[..., 5]).max(), LIM.omega)
    err = np.abs(np.asarray(mjx_traj - ref))
    assert err[..., :2].max() <= pos_tol  # SPEC accuracy goal (issue 2)
    assert err[..., 2].max() == 0.0  # radars stay on the ground
    if steps == 15:
        assert err[..., 3].max() <= 1e-4  # heading goal over the MPC horizon
    # v and omega come from MuJoCo's clamped activations: float32 round-off only.
    assert err[..., 4:].max() <= 1e-4 * LIM.speed


def test_public_rollout_radars_uses_control_step():
    scenario = Scenario(name="t", n_radars=2, target_init=((0, 0, 50, 1, 1, 0),))
    s0 = jnp.array([[0.0, 0, 0, 0.5, 3, 0.2], [200, -100, 0, -2, 0, 0]])
    u = _controls(jax.random.PRNGKey(1), 15, 2)
    out = physics.rollout_radars(scenario, s0, u)
    ref = unicycle_rollout(s0, u, scenario.timing.dt_control, scenario.limits)
    assert out.shape == (15, 2, 6)
    assert np.abs(np.asarray(out - ref))[..., :2].max() <= 1e-3


def test_drone_truth_matches_cv_model():
    plant = physics.make_plant(1, 4, 0.025, LIM)
    t0 = jnp.array(
        [[0, 0, 55, 20, 10, 0], [15.4, 15.32, 70, 15, 20, 0], [10, 10, 55, 17, 19, 0],
         [20, 20, 45, 6, 8, 0]], jnp.float32)  # fmt: skip
    keys = jax.random.split(jax.random.PRNGKey(3), 600)
    w = jax.vmap(lambda k: sample_white_accel(k, 4, 10.0))(keys)
    data = physics.init_data(plant, jnp.zeros((1, 6)), t0)

    def body(carry, wk):
        d, t = carry
        d = physics.step(plant, d, jnp.zeros((1, 2)), wk)
        t = cv_step(t, wk, plant.dt)
        return (d, t), (physics.target_state(plant, d), t)

    _, (sim, ref) = jax.jit(lambda d, t, w: jax.lax.scan(body, (d, t), w))(data, t0, w)
    assert np.abs(np.asarray(sim - ref))[..., :3].max() <= 1e-3  # issue 2 goal
    assert np.abs(np.asarray(sim - ref))[..., 3:].max() <= 1e-3


def test_drone_one_step_noise_covariance_matches_w():
    dt, s2, n = 0.025, 10.0, 40000
    plant = physics.make_plant(1, 1, dt, LIM)
    t0 = jnp.array([[10.0, -5.0, 60.0, 3.0, -2.0, 0.5]])

    def one(key):
        d = physics.init_data(plant, jnp.zeros((1, 6)), t0)
        d = physics.step(plant, d, jnp.zeros((1, 2)), sample_white_accel(key, 1, s2))
        return physics.target_state(plant, d)[0]

    nxt = jax.jit(jax.vmap(one))(jax.random.split(jax.random.PRNGKey(0), n))
    a = np.block([[np.eye(3), dt * np.eye(3)], [np.zeros((3, 3)), np.eye(3)]])
    resid = np.asarray(nxt, np.float64) - (a @ np.asarray(t0[0], np.float64))
    g = np.vstack([0.5 * dt**2 * np.eye(3), dt * np.eye(3)])
    w_true = s2 * g @ g.T
    emp = resid.T @ resid / n  # mean is zero by construction
    # MC relative error of a covariance from 4e4 draws is ~sqrt(2/n) = 0.7%: 5% is ~7 sigma.
    assert np.linalg.norm(emp - w_true) / np.linalg.norm(w_true) < 0.05


def test_gravity_does_not_act_on_drones():
    plant = physics.make_plant(1, 1, 0.025, LIM)
    d = physics.init_data(plant, jnp.zeros((1, 6)), jnp.array([[0.0, 0, 50, 0, 0, 0]]))
    step = jax.jit(lambda d: physics.step(plant, d, jnp.zeros((1, 2)), jnp.zeros((1, 3))))
    for _ in range(40):  # one program (suite time: eager ops compile one by one)
        d = step(d)
    np.testing.assert_allclose(physics.target_state(plant, d)[0], [0, 0, 50, 0, 0, 0], atol=1e-6)


def test_contacts_off_without_obstacles():
    plant = physics.make_plant(2, 1, 0.1, LIM)
    import mujoco

    assert plant.mj_model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_CONTACT


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: physics.make_plant(0, 1, 0.1), "n_radars"),
        (lambda: physics.make_plant(1, 1, 0.0), "dt"),
        (
            lambda: physics.truth_plant(1, 0, 0.025, RadarLimits()),
            "n_targets",
        ),
        (
            lambda: physics.init_data(physics.make_plant(1, 0, 0.1), jnp.full((1, 6), jnp.nan)),
            "radar_state",
        ),
        (
            lambda: physics.init_data(
                physics.make_plant(1, 1, 0.1), jnp.zeros((1, 6)), jnp.full((1, 6), jnp.inf)
            ),
            "target_state",
        ),
        (lambda: physics.init_data(physics.make_plant(2, 0, 0.1), jnp.zeros((3, 6))), "shape"),
    ],
)
def test_invalid_model_inputs_raise(call, match):
    with pytest.raises(ValueError, match=match):
        call()


def test_contact_free_step_equals_mjx_step():
    import dataclasses

    plant = dataclasses.replace(physics.make_plant(3, 2, 0.025, LIM), fused=None)  # stages
    assert plant.fast
    slow = dataclasses.replace(plant, fast=False)
    k1, k2, k3 = jax.random.split(jax.random.PRNGKey(5), 3)
    s0 = _initial(3, k1)
    t0 = jnp.concatenate([jax.random.normal(k2, (2, 3)) * 50, jnp.ones((2, 3))], -1)
    u = _controls(k3, 40, 3)
    w = jax.random.normal(k3, (40, 2, 3)) * 3

    def run(p):
        def body(d, uw):
            return physics.step(p, d, *uw), None

        d = jax.lax.scan(body, physics.init_data(p, s0, t0), (u, w))[0]
        return physics.radar_state(p, d), physics.target_state(p, d)

    fast_r, fast_t = jax.jit(lambda: run(plant))()
    slow_r, slow_t = jax.jit(lambda: run(slow))()
    # Same arithmetic up to float32 round-off of the skipped (zero) stages.
    np.testing.assert_allclose(fast_r, slow_r, atol=1e-4)
    np.testing.assert_allclose(fast_t, slow_t, atol=1e-4)


def test_zero_bias_check_rejects_an_offset_centre_of_mass():
    """The fast step skips the bias forces only where they vanish (closed form: a hinge
    spinning a mass off its axis has a centrifugal bias, one on its axis none)."""
    import mujoco

    from mjx_radar.physics.model_checks import zero_bias

    xml = """<mujoco><option gravity="0 0 0"/><worldbody><body>
      <joint name="x" type="slide" axis="1 0 0"/><joint name="yaw" type="hinge" axis="0 0 1"/>
      <geom type="sphere" size="0.1" pos="{off} 0 0" mass="1"/></body></worldbody></mujoco>"""
    assert zero_bias(mujoco.MjModel.from_xml_string(xml.format(off=0.0)))
    assert not zero_bias(mujoco.MjModel.from_xml_string(xml.format(off=0.5)))
