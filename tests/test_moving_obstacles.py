"""Moving obstacles (docs/maps.md): closed-form pose, keep-out cost over the horizon, line
of sight at two times, the truth plant's mocap contacts, the scenario table."""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjx_radar.scenario.reader import ScenarioError, load_scenario
from mjx_radar.scenario.schema import MovingObstacle, Obstacle
from mjx_radar.task import costs
from mjx_radar.world import moving
from mjx_radar.world.obstacles import footprint_sdf

SQUARE = ((-100.0, -100.0), (100.0, -100.0), (100.0, 100.0), (-100.0, 100.0))
CAR = MovingObstacle(kind="box", size=(3.0, 1.5), height=3.0, path=SQUARE, speed=10.0,
                     offset=50.0, end="loop")  # fmt: skip
POLE = MovingObstacle(kind="cylinder", size=(2.0,), height=4.0, path=((0.0, 50.0), (0.0, 150.0)),
                      speed=10.0, end="stop")  # fmt: skip


def _scenario(tiny, *mov):
    return dataclasses.replace(
        tiny, radar_init=((300.0, 0.0, 3.14159), (-300.0, 0.0, 0.0)), n_radars=2,
        moving_obstacles=mov, mpc=dataclasses.replace(tiny.mpc, horizon=6, alpha_obs=7.0,
                                                      obs_margin=6.0))  # fmt: skip


def _reference_pose(path, loop, s):
    """Brute force: the point at arc length s by np.interp on the densely listed polyline."""
    w = np.asarray(path + (path[:1] if loop else ()), float)
    cum = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(w, axis=0), axis=1))])
    s = np.mod(s, cum[-1]) if loop else np.clip(s, 0.0, cum[-1])
    return np.stack([np.interp(s, cum, w[:, 0]), np.interp(s, cum, w[:, 1])], -1)


def test_pose_closed_form_loop_and_stop():
    mp = moving.moving_params((CAR, POLE), jnp.float32)
    pose = jax.jit(moving.pose)  # one program per shape of t (not op by op)
    t = jnp.asarray([0.0, 5.0, 19.0, 75.0, 79.0, 160.0, 1234.5])
    xy, unit = (np.asarray(a) for a in pose(mp, t))
    # hand values: car s = 50 + 10 t mod 800 on the 200 m square; pole s = min(10 t, 100)
    car = [(-50, -100), (0, -100), (100, -60), (-100, -100), (-60, -100), (-50, -100)]
    np.testing.assert_allclose(xy[:6, 0], car, atol=2e-3)
    np.testing.assert_allclose(unit[[1, 2, 4], 0], [(1, 0), (0, 1), (1, 0)], atol=1e-6)
    np.testing.assert_allclose(xy[:, 1], [(0, 50), (0, 100), (0, 150), (0, 150), (0, 150),
                                          (0, 150), (0, 150)], atol=1e-4)  # fmt: skip
    ts = np.random.default_rng(0).uniform(0.0, 500.0, 400)
    xy = np.asarray(pose(mp, jnp.asarray(ts))[0])
    np.testing.assert_allclose(xy[:, 0], _reference_pose(SQUARE, True, 50 + 10 * ts), atol=5e-3)
    np.testing.assert_allclose(xy[:, 1], _reference_pose(POLE.path, False, 10 * ts), atol=5e-3)


def test_keep_out_cost_follows_path(tiny):
    from mjx_radar.env import presence
    from mjx_radar.task.task import build

    task, params = build(_scenario(tiny, CAR))
    params = presence.plan_params(params, 4.0)  # planning at t = 4 s: car at s = 90
    assert float(params.plan_time) == 4.0
    hz = 6
    tk = 4.0 + 0.1 * np.arange(1, hz + 1)
    car_x = -100.0 + 50.0 + 10.0 * tk  # on the first side, heading +x
    radar = np.zeros((hz, 2, 6), np.float32)
    radar[:, 0, :2] = np.stack([np.full(hz, -8.0), np.full(hz, -96.0)], -1)  # the car passes
    radar[:, 1, :2] = np.stack([car_x + 1.0, np.full(hz, -104.5)], -1)  # alongside the car
    h = costs.Horizon(jnp.zeros((hz, 2, 2)), jnp.asarray(radar), jnp.zeros((hz, 12, 1, 6)),
                      jnp.zeros((1, 6, 6)))  # fmt: skip
    got = np.asarray(jax.jit(lambda h, params: costs.moving_obstacle(h, task, params))(h, params))
    ref = np.zeros(hz)
    for k in range(hz):  # the static cost with the car as a static box at its pose at t_k
        box = Obstacle(kind="box", pos=(car_x[k], -100.0, 1.5), size=(3.0, 1.5, 1.5), yaw=0.0)
        ref[k] = 7.0 * np.maximum(6.0 - footprint_sdf(box, radar[k, :, :2]), 0.0).sum()
    assert ref.min() > 0 and np.ptp(ref) > 1.0  # the cost changes as the car moves
    np.testing.assert_allclose(got, ref, rtol=1e-5, atol=1e-4)
    assert [t.name for t in task.terms].count("moving_obstacle") == 1


def test_line_of_sight_at_two_times():
    mp = moving.moving_params((CAR, POLE), jnp.float32)
    radar = jnp.asarray([[0.0, -130.0, 0.0], [-20.0, 100.0, 0.0]])
    target = jnp.asarray([[0.0, -70.0, 2.0], [0.0, -70.0, 10.0], [20.0, 100.0, 1.0]])
    a, b = radar[:, None], target[None]
    # t = 5: car at (0, -100) (s = 100) across the first radar's sight lines; the line to
    # the high target crosses y = -100 at z = 10 * 30 / 60 = 5 > 3 m (clears the roof).
    # The line to the third target crosses y = -100 at x = 20 * 30 / 230 = 2.6 (inside the
    # car's half length 3), z = 0.13. Pole at (0, 100) between the second radar and it.
    blocked = jax.jit(lambda mp, t, a, b: moving.blocked((CAR, POLE), mp, t, a, b))  # one program
    b5 = np.asarray(blocked(mp, 5.0, a, b))
    # t = 15: car at (100, -100) (s = 200), pole at (0, 150): nothing blocked.
    b15 = np.asarray(blocked(mp, 15.0, a, b))
    np.testing.assert_array_equal(b5, [[True, False, True], [False, False, True]])
    np.testing.assert_array_equal(b15, np.zeros((2, 3), bool))


def test_plan_visibility_uses_horizon_times(tiny):
    from mjx_radar.task.task import build

    s = _scenario(tiny, CAR)
    task, params = build(s.replace(mpc={"los": True}))
    params = params._replace(plan_time=jnp.float32(4.4))  # t_k = 4.5 .. 5.0: car x -5 .. 0
    radar = jnp.broadcast_to(jnp.asarray([[2.0, -130.0, 0.0], [300.0, 0.0, 0.0]]), (6, 2, 3))
    tgt = jnp.broadcast_to(jnp.asarray([[2.0, -70.0, 2.0]]), (6, 1, 3))
    plan_visibility = jax.jit(lambda params: moving.plan_visibility(task.world, params, radar, tgt))
    vis = np.asarray(plan_visibility(params))  # one program for both planning times
    car_x = -50.0 + 10.0 * (4.4 + 0.1 * np.arange(1, 7))
    clear = np.abs(car_x - 2.0) > 3.0  # the sight line x = 2 is outside the car's length
    np.testing.assert_array_equal(clear, [True] * 4 + [False] * 2)
    np.testing.assert_array_equal(vis[:, 0, 0], clear)
    assert vis[:, 1, 0].all()
    params = params._replace(plan_time=jnp.float32(5.5))  # car x 6 .. 11: rear > 2
    vis = np.asarray(plan_visibility(params))
    assert vis.all()


def test_truth_plant_stops_radar_at_vehicle():
    """A radar driving at full throttle into a slow vehicle's side stops at its hull."""
    from mjx_radar.physics import moving_bodies, plant
    from mjx_radar.scenario.schema import RadarLimits
    from mjx_radar.world.obstacles import HULL_RADIUS, contact_envelope

    van = MovingObstacle(kind="box", size=(4.0, 1.5), height=2.5,
                         path=((0.0, -2.0), (0.0, 40.0)), speed=1.0, end="stop")  # fmt: skip
    lim = RadarLimits()
    p = plant.make_plant(1, 0, 0.025, lim, moving=(van,))
    mp = moving.moving_params((van,), jnp.float32)
    s0 = jnp.asarray([[-30.0, 0.0, 0.0, 0.0, lim.speed, 0.0]])

    def body(d, k):
        d = moving_bodies.pose_bodies(p, d, mp, k * p.dt)
        d = plant.step(p, d, jnp.asarray([[lim.accel, 0.0]]))
        return d, (plant.radar_state(p, d), plant.obstacle_contacts(p, d), d.geom_xpos)

    ks = jnp.arange(1, 241)
    run = jax.jit(lambda s0: jax.lax.scan(body, plant.init_data(p, s0), ks))  # one program
    _, (states, contacts, gx) = run(s0)
    x = np.asarray(states[:, 0, 0])
    gid = int(p.index.obstacle_geoms[-1])
    np.testing.assert_allclose(np.asarray(gx[:, gid, 1]), -2.0 + np.asarray(ks) * 0.025,
                               atol=1e-3)  # the body follows the closed-form path  # fmt: skip
    assert int(contacts.sum()) > 0
    # the physical hull (2.5 m) never enters the van's side at x = -1.5 (3 cm leak allowed)
    assert x.max() <= -1.5 - 2.5 + 0.03, x.max()
    # held where its collision sphere (hull grown by the contact envelope) meets the side
    grown = HULL_RADIUS + contact_envelope(lim, 0.025)
    assert abs(x[-1] - (-1.5 - grown)) < 0.05, (x[-1], -1.5 - grown)


def test_scenario_table_and_town(tiny):
    s = _scenario(tiny, CAR, POLE)
    from mjx_radar.scenario import edit as scenario_edit

    assert scenario_edit.validate(s) == s  # the TOML rules round trip
    with pytest.raises(ScenarioError, match=r"moving_obstacles\[0\]\.size"):
        s.replace(moving_obstacles=(dataclasses.replace(CAR, size=(3.0,)),))
    town = load_scenario("town_4r4t")
    assert len(town.moving_obstacles) == 2 and {m.end for m in town.moving_obstacles} == {"loop"}
    from mjx_radar.task.params import shape_key

    other = town.replace(moving_obstacles=tuple(dataclasses.replace(m, speed=3.0)
                                                for m in town.moving_obstacles))  # fmt: skip
    assert shape_key(other) == shape_key(town)  # speeds and paths are runtime numbers
    assert load_scenario("smoke").moving_obstacles == ()
    with pytest.raises(ScenarioError, match=r"not supported with \[terrain\]"):
        load_scenario("hills_4r4t").replace(moving_obstacles=(POLE,))
    with pytest.raises(ScenarioError, match=r"radars\[0\]: .* from moving_obstacles\[0\]"):
        s.replace(moving_obstacles=(dataclasses.replace(POLE, path=((300.0, 1.0), (300.0, 9.0))),))


def test_render_places_vehicles(tiny):
    """render's scene holds the vehicles as mocap bodies at their pose at (k + 1) dt."""
    import mujoco

    from mjx_radar.viz.render import scene_model, set_state
    from mjx_radar.viz.run_dir import Trial
    from mjx_radar.viz.scene import scene_of

    s = _scenario(tiny, CAR, POLE)
    k_steps, dt = 12, 0.025
    radar = np.zeros((k_steps, 2, 6))
    radar[:, :, 0] = [300.0, -300.0]
    target = np.tile(np.asarray(s.target_init, float)[None], (k_steps, 1, 1))
    tr = Trial({"r2t": 125.0}, scene_of(s), target, target[..., :3],
               np.ones_like(target[..., :3]), radar, np.zeros((3, 1, 3, 2, 2)), np.zeros((3, 1)),
               4, dt)  # fmt: skip
    model, index = scene_model(tr)
    data = mujoco.MjData(model)
    set_state(model, data, index, tr, 7)  # t = 0.2 s: car s = 52 (x = -48), pole y = 52
    car, pole = model.geom("moving0").id, model.geom("moving1").id
    np.testing.assert_allclose(data.geom_xpos[car], [-48.0, -100.0, 1.5], atol=1e-3)
    np.testing.assert_allclose(data.geom_xpos[pole], [0.0, 52.0, 2.0], atol=1e-3)


@pytest.mark.slow
def test_closed_loop_vehicle_blocks_and_is_avoided(tiny):
    """A closed-loop run (2 trials x 80 steps, analytic rollouts): a 200 m tall 60 m long
    vehicle drives north along x = 150 and, after about 1.5 s, crosses the sight line
    from the radar at (300, 0) to the drone near the origin: the truth loses that pair;
    no radar touches the vehicle."""
    import mjx_radar

    wall = MovingObstacle(kind="box", size=(30.0, 2.0), height=200.0,
                          path=((150.0, -300.0), (150.0, 300.0)), speed=20.0, offset=250.0,
                          end="stop")  # fmt: skip
    s = _scenario(tiny, wall).replace(name="mv", timing={"steps": 80})
    run = mjx_radar.simulate(s, method="ddr-sfim", trials=2, steps=80, progress=False)
    m = run.metrics.sort_values(["trial", "step"])
    assert (m["obstacle_contacts"] == 0).all()
    tr = run.trajectories
    radar, target = tr.radar_states.values[..., :3], tr.truth.values[..., :3]  # [T, K, ., 3]
    t = tr.time_s.values  # t_k = k dt: the vehicle's centre y = -300 + 250 + 20 t
    u = np.linspace(0.0, 1.0, 4001)
    pts = radar[:, :, :, None, None] + u[:, None] * (target[:, :, None, :, None]
                                                     - radar[:, :, :, None, None])  # fmt: skip
    yc = (-50.0 + 20.0 * t)[None, :, None, None, None]
    inside = ((np.abs(pts[..., 0] - 150.0) < 2.0) & (np.abs(pts[..., 1] - yc) < 30.0)
              & (pts[..., 2] < 200.0))  # fmt: skip  # [T, K, N, M, U] dense segment samples
    expected = (~inside.any(-1)).sum((-1, -2))  # [T, K] visible pairs
    assert expected.min() < 4 and expected.max() == 4  # the vehicle blocks some steps
    np.testing.assert_array_equal(m["visible_pairs"].to_numpy().reshape(expected.shape),
                                  expected)  # fmt: skip


def test_snapshot_draws_vehicles(tiny):
    """snapshot's map draws each vehicle's footprint at the step's time (k + 1) dt."""
    import matplotlib.pyplot as plt

    from mjx_radar.viz.run_dir import Trial
    from mjx_radar.viz.scene import scene_of
    from mjx_radar.viz.snapshot import snapshot_figure

    s = _scenario(tiny, CAR, POLE)
    radar = np.zeros((12, 2, 6))
    radar[:, :, 0] = [300.0, -300.0]
    target = np.tile(np.asarray(s.target_init, float)[None], (12, 1, 1))
    meta = {"r2t": 125.0, "r2r": 10.0, "dt_filter": 0.025, "noise_constant": 1e6}
    tr = Trial(meta, scene_of(s), target, target[..., :3], np.ones_like(target[..., :3]), radar,
               np.zeros((3, 1, 3, 2, 2)), np.zeros((3, 1)), 4, 0.025)  # fmt: skip
    fig = snapshot_figure(tr, 7, grid=20)  # t = 0.2 s: car centre (-48, -100), pole (0, 52)
    patches = [p for ax in fig.axes for p in ax.patches if p.get_gid() == "moving"]
    plt.close(fig)
    assert len(patches) == 4  # two vehicles on two panels
    car = patches[0].get_xy()[:4]
    np.testing.assert_allclose(car.mean(0), [-48.0, -100.0], atol=1e-3)
    np.testing.assert_allclose(np.ptp(car, 0), [6.0, 3.0], atol=1e-3)
    np.testing.assert_allclose(patches[1].get_xy().mean(0), [0.0, 52.0], atol=0.2)
