"""Per-target motion in the truth plant (physics.target_motion) against closed forms.

The drones are stepped by the MJX truth plant (the closed loop's ``step_plant``), not by
the host nominal path, so these tests check the plant's realisation of each model:
the turn against the analytic circle written here, waypoints against their documented
capture distance and acceleration bound, a track against its CSV, the CV perturbation
against its Monte Carlo variance, and the cv model against the paper's CV step.
"""

from __future__ import annotations

import dataclasses
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjx_radar.physics import kinematics, target_motion
from mjx_radar.physics import plant as physics
from mjx_radar.scenario.reader import load_scenario
from mjx_radar.scenario.schema import TargetMotion

DT = 0.025


def _scenario(targets, motions, steps):
    s = load_scenario("smoke")
    s = dataclasses.replace(s, timing=dataclasses.replace(s.timing, steps=steps))
    return s.replace(targets=[list(t) for t in targets], target_motion=tuple(motions))


def _fly(scenario, keys=None, steps=None):
    """Truth target states [K+1, M, 6] (or [T, K+1, M, 6] over ``keys``) of the MJX plant."""
    tables, timing = scenario.target_motion, scenario.timing
    mp = target_motion.motion_params(
        scenario.target_init, tables, timing, scenario.sigma_w2, jnp.float32
    )
    x0 = target_motion.initial_states(scenario.target_init, tables, timing.dt_filter)
    x0 = jnp.asarray(x0, jnp.float32)
    plant = physics.make_plant(2, scenario.n_targets, DT)
    radars = jnp.array([[300.0, 0, 0, 0, 0, 0], [-300.0, 0, 0, 0, 0, 0]])
    k_total = steps or scenario.timing.steps

    def run(key):
        data = physics.init_data(plant, radars, x0)

        def body(d, k):
            d = target_motion.step_plant(
                plant, d, jnp.zeros((2, 2)), mp, jax.random.fold_in(key, k), k, 0.0
            )
            return d, physics.target_state(plant, d)

        traj = jax.lax.scan(body, data, jnp.arange(1, k_total + 1))[1]
        return jnp.concatenate([x0[None], traj])

    if keys is None:
        return np.asarray(jax.jit(run)(jax.random.PRNGKey(0)), np.float64)
    return np.asarray(jax.jit(jax.vmap(run))(keys), np.float64)


def test_turn_flies_the_analytic_circle():
    # speed 20 m/s at 0.4 rad/s: radius 50 m; 400 steps = 10 s = 4 rad of arc; climbing
    rate, v0 = 0.4, np.array([12.0, 16.0, 1.5])
    x0 = [100.0, -50.0, 60.0, *v0]
    s = _scenario([x0, [0, 0, 55, 20, 10, 0]], [TargetMotion(target=0, model="turn", rate=rate)],
                  400)  # fmt: skip
    traj = _fly(s)[:, 0]
    t = DT * np.arange(401)
    r = np.hypot(*v0[:2]) / rate
    centre = np.array(x0[:2]) + np.array([-v0[1], v0[0]]) / rate  # left of the heading
    phi = np.arctan2(x0[1] - centre[1], x0[0] - centre[0]) + rate * t
    ref = np.stack([centre[0] + r * np.cos(phi), centre[1] + r * np.sin(phi), 60 + 1.5 * t], -1)
    # float32 positions near 100 m: ulp 8e-6 m; 400 steps of rounding stay below 1 mm
    np.testing.assert_allclose(traj[:, :3], ref, atol=1e-3)
    vref = np.stack([-r * rate * np.sin(phi), r * rate * np.cos(phi), np.full_like(t, 1.5)], -1)
    np.testing.assert_allclose(traj[:, 3:], vref, atol=1e-4)


def test_waypoints_pass_within_capture_in_order_with_bounded_acceleration():
    wps = [[200.0, 0.0, 60.0], [200.0, 200.0, 90.0], [0.0, 200.0, 60.0]]
    tm = TargetMotion(target=0, model="waypoints", waypoints=tuple(map(tuple, wps)), speed=20.0,
                      accel_max=8.0, loop=True)  # fmt: skip
    s = _scenario([[0, 0, 55, 0, 0, 0], [0, 50, 55, 20, 10, 0]], [tm], 1800)  # 45 s
    traj = _fly(s)[:, 0]
    cap = target_motion.capture_radius(tm)
    assert cap == pytest.approx(2 * 20.0**2 / 8.0)  # the documented default: 100 m
    d = np.linalg.norm(traj[:, None, :3] - np.asarray(wps)[None], axis=-1)  # [K+1, 3]
    first = [int(np.argmax(d[:, j] <= cap)) for j in range(3)]
    assert all(d[:, j].min() <= cap for j in range(3))
    assert first[0] < first[1] < first[2]  # in order
    # the loop brings it back to the first waypoint after the last
    assert (d[first[2] :, 0] <= cap).any()
    acc = np.linalg.norm(np.diff(traj[:, 3:], axis=0), axis=-1) / DT
    assert acc.max() <= 8.0 * (1 + 1e-3)
    speed = np.linalg.norm(traj[:, 3:], axis=-1)
    assert speed.max() <= 20.0 * (1 + 1e-4)
    # turning first, the speed held: at the commanded speed once it got there (~2.5 s)
    np.testing.assert_allclose(speed[200:], 20.0, rtol=1e-4)


def test_track_reproduces_its_csv(tmp_path):
    rows = [[0.0, 0.0, 0.0, 50.0], [1.0, 15.0, 5.0, 52.0], [2.5, 20.0, 40.0, 60.0],
            [4.0, -10.0, 60.0, 55.0]]  # fmt: skip
    csv = tmp_path / "track.csv"
    csv.write_text("t,x,y,z\n" + "".join(",".join(map(str, r)) + "\n" for r in rows))
    toml = tmp_path / "s.toml"
    toml.write_text(
        'name = "trk"\nn_radars = 2\ntargets = [[1, 1, 50, 0, 0, 0], [0, 50, 55, 20, 10, 0]]\n'
        '[timing]\nsteps = 240\n[[target_motion]]\ntarget = 0\nmodel = "track"\n'
        'path = "track.csv"\n'
    )
    s = load_scenario(toml)
    traj = _fly(s)[:, 0]
    for t, *xyz in rows:  # sample times are multiples of dt
        np.testing.assert_allclose(traj[round(t / DT), :3], xyz, atol=1e-3)
    # between samples: linear; after the last: on at the last segment's velocity
    np.testing.assert_allclose(traj[20, :3], [7.5, 2.5, 51.0], atol=1e-3)
    slope = (np.array(rows[3][1:]) - rows[2][1:]) / 1.5
    np.testing.assert_allclose(traj[200, :3], np.array(rows[3][1:]) + 1.0 * slope, atol=2e-3)
    # the track's start overrides the targets row
    x0 = target_motion.initial_states(s.target_init, s.target_motion, s.timing.dt_filter)
    np.testing.assert_allclose(x0[0, :3], [0, 0, 50])


def test_noise_on_top_is_a_cv_perturbation_of_the_nominal_path():
    # turn with sigma_w2 = 4: δv = v - V after K steps ~ N(0, σ² K dt² I), δp variance
    # σ² dt⁴ Σ (k - 1/2)² ... use the velocity (closed form σ² K dt²)
    s = _scenario([[0, 0, 60, 15, 0, 0], [0, 50, 55, 20, 10, 0]],
                  [TargetMotion(target=0, model="turn", rate=0.3, sigma_w2=4.0)], 80)  # fmt: skip
    trials = 400
    traj = _fly(s, jax.random.split(jax.random.PRNGKey(3), trials))[:, :, 0]
    _, vel, _ = target_motion.nominal_paths(s.target_init, s.target_motion, s.timing)
    dv = traj[:, -1, 3:] - vel[-1, 0]
    var = dv.var(axis=0)
    expect = 4.0 * 80 * DT**2  # 0.2 (m/s)²
    # 400 samples: the variance's relative standard error is sqrt(2/400) = 7%; 4 sigma
    np.testing.assert_allclose(var, expect, rtol=0.28)
    assert np.all(np.abs(dv.mean(0)) < 4 * math.sqrt(expect / trials))


def test_cv_table_is_the_papers_cv_step():
    # a cv table (e.g. only for appear times) flies exactly the CV model of SPEC §2
    s = _scenario([[0, 0, 60, 15, 0, 0], [0, 50, 55, 20, 10, 0]],
                  [TargetMotion(target=1, appear=1.0)], 40)  # fmt: skip
    mp = target_motion.motion_params(
        s.target_init, s.target_motion, s.timing, s.sigma_w2, jnp.float32
    )
    assert not bool(mp.nominal.any())
    np.testing.assert_allclose(np.asarray(mp.noise_std), math.sqrt(s.sigma_w2))
    plant = physics.make_plant(2, 2, DT)
    radars = jnp.zeros((2, 6)).at[:, 0].set(jnp.array([300.0, -300.0]))
    x0 = jnp.asarray(s.target_init, jnp.float32)
    key = jax.random.PRNGKey(5)
    u0 = jnp.zeros((2, 2))

    @jax.jit
    def both(key):  # one step each way, from the same state and key
        d0 = physics.init_data(plant, radars, x0)
        d_motion = target_motion.step_plant(plant, d0, u0, mp, key, 1, s.sigma_w2)
        d_cv = physics.step(plant, d0, u0, kinematics.sample_white_accel(key, 2, s.sigma_w2))
        return physics.target_state(plant, d_motion), physics.target_state(plant, d_cv)

    np.testing.assert_array_equal(*both(key))


def test_presence_and_appearance_times():
    mp = target_motion.MotionParams(*([None] * 5), jnp.array([0.0, 2.0]), jnp.array([5.0, 3.0]))
    assert np.asarray(target_motion.present(mp, 1.0)).tolist() == [True, False]
    assert np.asarray(target_motion.present(mp, 2.0)).tolist() == [True, True]
    assert np.asarray(target_motion.present(mp, 3.0)).tolist() == [True, False]
    assert np.asarray(target_motion.appears_between(mp, 1.99, 2.0)).tolist() == [False, True]
    assert not np.asarray(target_motion.appears_between(mp, 0.0, 0.025)).any()


def test_track_csv_is_bundled_and_scenarios_round_trip(tmp_path):
    from mjx_radar.scenario.bundle import bundle_scenario

    (tmp_path / "tracks").mkdir()
    (tmp_path / "tracks" / "d.csv").write_text("0,0,0,50\n2,40,0,50\n")
    src = tmp_path / "s.toml"
    src.write_text(
        'name = "trk"\nn_radars = 2\ntargets = [[1, 1, 50, 0, 0, 0], [0, 50, 55, 20, 10, 0]]\n'
        '[[target_motion]]\ntarget = 0\nmodel = "track"\npath = "tracks/d.csv"  # recorded\n'
        '[[target_motion]]\ntarget = 1\nmodel = "waypoints"\nwaypoints = [[0, 0, 60], '
        "[100, 0, 60]]\nloop = true\nappear = 1.5\n"
    )
    s = load_scenario(src)
    out = tmp_path / "run"
    written = bundle_scenario(src, out)
    assert (out / "tracks" / "d.csv").read_text() == "0,0,0,50\n2,40,0,50\n"
    assert out / "tracks" / "d.csv" in written
    src.unlink()
    (tmp_path / "tracks" / "d.csv").unlink()  # the run directory stands alone
    again = load_scenario(out / "scenario.toml")
    assert again.target_motion[0].track == s.target_motion[0].track
    assert again.target_motion[0].path == str((out / "tracks" / "d.csv").resolve())
    assert again.target_motion[1] == s.target_motion[1]
    # Python: to_toml / replace keep every field (absolute track path)
    text = again.to_toml(tmp_path / "copy.toml")
    assert "allow_external_paths = true" in text
    assert load_scenario(tmp_path / "copy.toml") == again
    moved = again.replace(target_motion=(TargetMotion(target=1, model="turn", rate=0.1),))
    assert moved.target_motion[0].model == "turn" and moved.target_motion[0].sigma_w2 == -1.0
