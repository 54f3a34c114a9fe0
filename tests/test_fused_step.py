"""The fused physics step against C MuJoCo's ``mj_step`` and MJX's stages."""

import dataclasses

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
import pytest

from mjx_radar import physics
from mjx_radar.physics import fused_step
from mjx_radar.physics.kinematics import unicycle_rollout
from mjx_radar.physics.scene import build_scene
from mjx_radar.scenario.schema import RadarLimits

LIM = RadarLimits()


def _controls(key, steps, n):
    u = jax.random.uniform(key, (steps, n, 2), minval=-2.0, maxval=2.0)  # half saturate
    return u * jnp.array([LIM.accel, LIM.alpha])


def _initial(key, n):
    xy = jax.random.uniform(key, (n, 2), minval=-400, maxval=400)
    v, w = jnp.linspace(-LIM.speed, LIM.speed, n), jnp.linspace(LIM.omega, -LIM.omega, n)
    return jnp.stack([xy[:, 0], xy[:, 1], jnp.zeros(n), jnp.linspace(-3, 3, n), v, w], -1)


@pytest.mark.parametrize(("radars", "drones"), [(1, 0), (3, 2), (2, 4)])
def test_fused_step_equals_mj_step_over_many_steps(radars, drones):
    """Float64 numpy fused step vs C MuJoCo from random states with random
    controls beyond the ranges (clamps on): agree to 1e-10 relative over 300 steps."""
    m, index = build_scene(radars, drones, 0.025)
    fm = fused_step.build(m, index)
    assert fm is not None
    data = mujoco.MjData(m)
    rng = np.random.default_rng(3)
    data.qpos[:] = rng.uniform(-300, 300, m.nq)
    data.act[:] = rng.uniform(-5, 5, m.na)
    q, qd, act = data.qpos.copy(), data.qvel.copy(), data.act.copy()
    clamped = False
    for k in range(300):
        # first 200 steps full throttle (|a| limit 35, |alpha| limit pi: both clamp,
        # then the speed and yaw-rate activations reach their ranges), then random
        data.ctrl[:] = 60.0 if k < 200 else rng.uniform(-60, 60, m.nu)
        q, qd, act = fused_step.data_step(np, fm, q, qd, act, data.ctrl.copy())
        mujoco.mj_step(m, data)
        clamped |= bool(np.isclose(data.act[index.radar_act[:, 1]], 2 * np.pi).any())
    for ours, ref in ((q, data.qpos), (qd, data.qvel), (act, data.act)):
        np.testing.assert_allclose(ours, ref, rtol=1e-10, atol=1e-10 * np.abs(ref).max())
    assert clamped  # the activation clamp (|omega| <= 2 pi) was exercised


def test_build_refuses_a_scene_it_does_not_describe():
    """A force limit on the drive servo is not in the fused step: the check against
    mj_step fails and the plant keeps MJX's stages."""
    m, index = build_scene(2, 1, 0.025)
    m.actuator_forcelimited[index.radar_ctrl[0, 2]] = 1
    m.actuator_forcerange[index.radar_ctrl[0, 2]] = [-10.0, 10.0]
    assert fused_step.build(m, index) is None
    m2, index2 = build_scene(2, 1, 0.025)
    m2.actuator_gainprm[index2.radar_ctrl[1, 4], 0] *= 1.1  # a gain is read, not assumed
    assert fused_step.build(m2, index2) is not None


def test_plants_use_the_fused_step_where_fast():
    assert physics.make_plant(3, 2, 0.025, LIM).fused is not None
    box = physics.make_plant(2, 1, 0.025, LIM, obstacles=_one_box())
    assert not box.fast and box.fused is None


def _one_box():
    from mjx_radar.scenario.schema import Obstacle

    return (Obstacle(kind="box", pos=(0.0, 50.0, 2.0), size=(5.0, 5.0, 2.0)),)


@pytest.mark.parametrize("x64", [False, True])
def test_fused_rollout_equals_mjx_stages(x64):
    """The planner's rollout through the fused step vs MJX's stages (the same plant with
    ``fused=None``), 600 steps with saturating controls: float64 to 1e-9 m, float32 to
    the round-off of hundreds of metres over 600 steps (1e-3 m)."""
    with jax.enable_x64(x64):
        plant = physics.make_plant(1, 0, 0.025, LIM)
        stages = dataclasses.replace(plant, fused=None)
        k1, k2 = jax.random.split(jax.random.PRNGKey(11))
        s0, u = _initial(k1, 4), _controls(k2, 600, 4)
        roll = jax.jit(physics.radar_rollout, static_argnums=0)
        a, b = np.asarray(roll(plant, s0, u)), np.asarray(roll(stages, s0, u))
        ref = np.asarray(unicycle_rollout(s0, u, 0.025, LIM))
    np.testing.assert_allclose(a, b, atol=1e-9 if x64 else 1e-3)
    np.testing.assert_allclose(a, ref, atol=1e-8 if x64 else 5e-2)


def test_fused_truth_step_equals_mjx_stages_in_float64():
    """Radars and drones through :func:`physics.step` (fused) vs the same plant on MJX's
    stages, 100 steps of random controls and drone accelerations, float64."""
    with jax.enable_x64(True):
        plant = physics.make_plant(3, 2, 0.025, LIM)
        stages = dataclasses.replace(plant, fused=None)
        k1, k2, k3 = jax.random.split(jax.random.PRNGKey(5), 3)
        s0 = _initial(k1, 3)
        t0 = jnp.concatenate([jax.random.normal(k2, (2, 3)) * 50, jnp.ones((2, 3))], -1)
        u, w = _controls(k3, 100, 3), jax.random.normal(k3, (100, 2, 3)) * 3

        def run(p):
            def body(d, uw):
                return physics.step(p, d, *uw), None

            d = jax.lax.scan(body, physics.init_data(p, s0, t0), (u, w))[0]
            return physics.radar_state(p, d), physics.target_state(p, d)

        fused, ref = jax.jit(lambda: run(plant))(), jax.jit(lambda: run(stages))()
    for x, y in zip(fused, ref, strict=True):
        np.testing.assert_allclose(x, y, rtol=1e-12, atol=1e-9)


def test_mjx_import_mutes_only_the_importing_thread():
    """The lazy MJX import drops its own thread's chatter ("Failed to import warp") but
    not what other threads write meanwhile (the CLI's "interrupted" line on Ctrl-C during
    a compile was lost while the import had swapped the process's stderr)."""
    import io
    import subprocess
    import sys
    import threading

    from mjx_radar.physics import mjx_module

    target = io.StringIO()
    muted = threading.Thread(target=lambda: proxy.write("dropped\n"))
    proxy = mjx_module._MuteThread(target, 0)
    muted.start()  # the muted thread is alive while it writes, so its ident is its own
    muted.join()
    assert target.getvalue() == "dropped\n"  # ident 0 is no thread: nothing is muted
    target.seek(0), target.truncate()
    go, done = threading.Event(), threading.Event()

    def write_when_told():
        go.wait()
        proxy.write("dropped\n")
        done.set()

    muted = threading.Thread(target=write_when_told)
    muted.start()
    proxy = mjx_module._MuteThread(target, muted.ident)
    proxy.write("main thread\n")
    go.set()
    done.wait()
    muted.join()
    proxy.flush()
    assert target.getvalue() == "main thread\n"

    code = ("import sys, threading; from mjx_radar.physics import mjx_module; "
            "t = threading.Thread(target=mjx_module.load); t.start(); t.join(); "
            "assert 'mujoco.mjx' in sys.modules and sys.stdout is sys.__stdout__; "
            "print('kept'); print('kept too', file=sys.stderr)")  # fmt: skip
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert done.stdout == "kept\n" and done.stderr == "kept too\n", (done.stdout, done.stderr)
