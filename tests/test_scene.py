"""The MuJoCo scene builder (physics.scene): counts, flags, servo gains, obstacle geoms."""

from pathlib import Path

import mujoco
import numpy as np
import pytest
import trimesh

from mjx_radar.physics.scene import (
    CONTACT_SOLIMP,
    DRONE_ACTUATORS,
    RADAR_ACTUATORS,
    SOLVER_ITERATIONS,
    build_scene,
)
from mjx_radar.scenario.schema import Obstacle

DT = 0.025
RADAR_MASS, RADAR_IZZ, DRONE_MASS = 2000.0, 2500.0, 2.0  # models/radar.xml, drone.xml
MESH = Path(__file__).resolve().parents[1] / "scenarios" / "meshes" / "tower.obj"
OBSTACLES = (
    Obstacle("box", pos=(50.0, -20.0, 5.0), size=(4.0, 2.0, 5.0), yaw=0.6),
    Obstacle("cylinder", pos=(-30.0, 40.0, 3.0), size=(1.5, 3.0)),
    Obstacle("mesh", pos=(0.0, 90.0, 0.0), path=str(MESH), scale=2.0),
)
BITS = mujoco.mjtDisableBit


@pytest.mark.parametrize(("n", "m"), [(1, 0), (3, 2), (2, 4)])
def test_counts_and_index(n, m):
    model, idx = build_scene(n, m, DT)
    assert model.nbody == 1 + n + m  # world + one body each
    assert model.njnt == 3 * n + 3 * m and model.nq == model.nv == 3 * n + 3 * m
    assert model.nu == 5 * n + 6 * m  # speed, turn, drive, lateral, steer / vx..sz
    assert model.na == 2 * n + 3 * m  # integrator activations: (v, omega) / (vx, vy, vz)
    assert idx.radar_qpos.shape == (n, 3) and idx.radar_act.shape == (n, 2)
    assert idx.radar_ctrl.shape == (n, 5) and idx.drone_ctrl.shape == (m, 6)
    assert idx.drone_qpos.shape == (m, 3) and idx.drone_act.shape == (m, 3)
    assert idx.obstacle_geoms.size == 0 and idx.radar_hull.shape == (n,)
    # every address distinct, names as documented
    assert len(set(idx.radar_qpos.ravel()) | set(idx.drone_qpos.ravel())) == model.nq
    assert len(set(idx.radar_act.ravel()) | set(idx.drone_act.ravel())) == model.na
    for i in range(n):
        names = [model.actuator(int(a)).name for a in idx.radar_ctrl[i]]
        assert names == [f"radar{i}/{a}" for a in RADAR_ACTUATORS]
        assert model.geom(int(idx.radar_hull[i])).name == f"radar{i}/hull"
    for j in range(m):
        names = [model.actuator(int(a)).name for a in idx.drone_ctrl[j]]
        assert names == [f"drone{j}/{a}" for a in DRONE_ACTUATORS]
    # the qpos addresses move the right bodies
    data = mujoco.MjData(model)
    rng = np.random.default_rng(0)
    rq = rng.uniform(-100, 100, (n, 3))
    dq = rng.uniform(-100, 100, (m, 3))
    data.qpos[idx.radar_qpos] = rq
    data.qpos[idx.drone_qpos] = dq
    mujoco.mj_kinematics(model, data)
    for i in range(n):
        body = model.body(f"radar{i}/radar").id
        np.testing.assert_allclose(data.xpos[body], [rq[i, 0], rq[i, 1], 0.0], atol=1e-9)
        yaw = 2 * np.arctan2(data.xquat[body, 3], data.xquat[body, 0])
        np.testing.assert_allclose(np.angle(np.exp(1j * (yaw - rq[i, 2]))), 0.0, atol=1e-9)
    for j in range(m):
        body = model.body(f"drone{j}/drone").id
        np.testing.assert_allclose(data.xpos[body], dq[j], atol=1e-9)


def test_options_and_contacts_off_without_obstacles():
    model, _ = build_scene(2, 3, DT)
    assert model.opt.timestep == DT
    assert model.opt.integrator == mujoco.mjtIntegrator.mjINT_EULER
    flags = model.opt.disableflags
    for bit in (BITS.mjDSBL_GRAVITY, BITS.mjDSBL_SPRING, BITS.mjDSBL_DAMPER,
                BITS.mjDSBL_EULERDAMP, BITS.mjDSBL_CONTACT, BITS.mjDSBL_CONSTRAINT):  # fmt: skip
        assert flags & bit, bit
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    assert data.ncon == 0
    ground = model.geom("ground")
    assert ground.type[0] == mujoco.mjtGeom.mjGEOM_PLANE
    assert ground.contype[0] == 0 and ground.conaffinity[0] == 0


@pytest.mark.parametrize("dt", [0.025, 0.1])
def test_servo_gains_are_mass_over_dt(dt):
    model, idx = build_scene(2, 2, dt)
    for row in idx.radar_ctrl:
        speed, turn, drive, lateral, steer = (int(a) for a in row)
        for a, inertia in ((drive, RADAR_MASS), (lateral, RADAR_MASS), (steer, RADAR_IZZ)):
            kv = inertia / dt
            np.testing.assert_allclose(model.actuator_gainprm[a, 0], kv, rtol=1e-12)
            np.testing.assert_allclose(model.actuator_biasprm[a, :3], [0, 0, -kv], rtol=1e-12)
        for a in (speed, turn):  # integrators: state only, no force
            assert model.actuator_dyntype[a] == mujoco.mjtDyn.mjDYN_INTEGRATOR
            assert model.actuator_gainprm[a, 0] == 0 and np.all(model.actuator_biasprm[a] == 0)
    for row in idx.drone_ctrl:
        for a in row[3:]:
            np.testing.assert_allclose(model.actuator_gainprm[a, 0], DRONE_MASS / dt, rtol=1e-12)
            np.testing.assert_allclose(model.actuator_biasprm[a, 2], -DRONE_MASS / dt, rtol=1e-12)
        for a in row[:3]:
            assert model.actuator_dyntype[a] == mujoco.mjtDyn.mjDYN_INTEGRATOR


def test_servos_are_deadbeat_in_one_euler_step():
    # kv = M/dt with Euler: qvel' = qvel + dt kv (v_cmd - qvel) / M = v_cmd exactly
    model, idx = build_scene(1, 1, DT)
    data = mujoco.MjData(model)
    th = 0.7
    data.qpos[idx.radar_qpos[0, 2]] = th
    ctrl = np.zeros(model.nu)
    ctrl[idx.radar_ctrl[0, 2]] = 3.0  # drive: mean forward speed
    ctrl[idx.radar_ctrl[0, 4]] = 0.5  # steer: mean yaw rate
    ctrl[idx.drone_ctrl[0, 3:]] = [2.0, -1.0, 0.5]
    data.ctrl[:] = ctrl
    mujoco.mj_step(model, data)
    qv = data.qvel
    rx, ry, ryaw = idx.radar_qpos[0]  # slide/hinge joints: dof address = qpos address
    # the body-frame drive acts along the heading at the start of the step
    np.testing.assert_allclose([qv[rx], qv[ry]], [3 * np.cos(th), 3 * np.sin(th)], atol=1e-9)
    np.testing.assert_allclose(qv[ryaw], 0.5, atol=1e-12)
    np.testing.assert_allclose(qv[idx.drone_qpos[0]], [2.0, -1.0, 0.5], atol=1e-12)
    np.testing.assert_allclose(data.qpos[idx.drone_qpos[0]], DT * np.array([2.0, -1.0, 0.5]),
                               atol=1e-12)  # fmt: skip


def test_obstacle_geoms_types_sizes_and_collision_bits():
    margin = 1.3
    model, idx = build_scene(2, 1, DT, OBSTACLES, hull_margin=margin)
    assert not model.opt.disableflags & BITS.mjDSBL_CONTACT
    assert not model.opt.disableflags & BITS.mjDSBL_CONSTRAINT
    assert model.opt.iterations == SOLVER_ITERATIONS
    np.testing.assert_array_equal(model.numeric("max_geom_pairs").data, [4.0])  # 2N
    assert idx.obstacle_geoms.shape == (3,)
    box, cyl, mesh = (model.geom(int(g)) for g in idx.obstacle_geoms)
    assert [g.name for g in (box, cyl, mesh)] == ["obstacle0", "obstacle1", "obstacle2"]
    assert box.type[0] == mujoco.mjtGeom.mjGEOM_BOX
    np.testing.assert_allclose(box.size, [4.0, 2.0, 5.0])
    np.testing.assert_allclose(box.pos, [50.0, -20.0, 5.0])
    np.testing.assert_allclose(box.quat, [np.cos(0.3), 0, 0, np.sin(0.3)], atol=1e-12)
    assert cyl.type[0] == mujoco.mjtGeom.mjGEOM_CYLINDER
    np.testing.assert_allclose(cyl.size[:2], [1.5, 3.0])
    np.testing.assert_allclose(cyl.pos, [-30.0, 40.0, 3.0])
    assert mesh.type[0] == mujoco.mjtGeom.mjGEOM_MESH
    # the mesh's vertices are the file's, scaled (MuJoCo recentres them on the mesh frame)
    tm = trimesh.load(str(MESH), force="mesh")
    mid = int(mesh.dataid[0])
    adr, nv = model.mesh_vertadr[mid], model.mesh_vertnum[mid]
    verts = model.mesh_vert[adr : adr + nv]
    ext = verts.max(0) - verts.min(0)
    np.testing.assert_allclose(np.sort(ext), np.sort(2.0 * tm.extents), rtol=1e-6)
    for g in (box, cyl, mesh):  # obstacles: type 1, collide with type 2 (radars)
        assert (g.contype[0], g.conaffinity[0], g.condim[0]) == (1, 2, 1)
        np.testing.assert_allclose(g.solimp, CONTACT_SOLIMP)
    for h in idx.radar_hull:  # radar hulls: type 2, collide with type 1; grown by the margin
        g = model.geom(int(h))
        assert (g.contype[0], g.conaffinity[0], g.condim[0]) == (2, 1, 1)
        assert g.type[0] == mujoco.mjtGeom.mjGEOM_SPHERE
        np.testing.assert_allclose(g.size[0], 2.5 + margin)
    # radars do not collide with each other (2 & 1 == 0 both ways), nor with drones/ground
    for g in range(model.ngeom):
        if g not in set(idx.obstacle_geoms) | set(idx.radar_hull):
            assert model.geom_contype[g] & 1 == 0 and model.geom_conaffinity[g] & 2 == 0
    # without obstacles the hull keeps its size whatever the margin
    plain, pidx = build_scene(2, 1, DT, (), hull_margin=margin)
    np.testing.assert_allclose(plain.geom_size[pidx.radar_hull, 0], 2.5)


@pytest.mark.parametrize(
    ("args", "field"),
    [((0, 1, DT), "n_radars"), ((1, -1, DT), "n_drones"), ((1, 1, 0.0), "dt"),
     ((1, 1, float("nan")), "dt"), ((1, 0, DT, (Obstacle("cone", size=(1.0,)),)), "obstacle.kind")],
)  # fmt: skip
def test_bad_arguments_raise_one_line(args, field):
    with pytest.raises(ValueError) as e:
        build_scene(*args)
    assert str(e.value).startswith(field) and "\n" not in str(e.value)
