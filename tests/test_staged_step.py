"""The staged truth step (physics/staged_step.py) against ``mjx.step``.

The staged step merges the sphere–mesh collision keys of one convex shape into one
vmapped call. It runs MJX's own contact routine on the same pairs and hands the
solver the contacts in MJX's order, so it must equal ``mjx.step`` exactly (float64;
the tolerance 1e-12 only allows for a fused multiply-add XLA might choose differently
in a larger batch). The structural check counts the traced contact routines, so the
merge cannot silently stop happening.
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import trimesh

from mjx_radar.physics import plant as plant_mod
from mjx_radar.physics import staged_step
from mjx_radar.scenario.schema import Obstacle

LIM = plant_mod.RadarLimits()


def _prism(tmp_path, name, polygon, height):
    """An OBJ of the convex polygon [P, 2] (counter-clockwise) extruded to ``height``."""
    p = len(polygon)
    verts = np.array([(x, y, z) for z in (0.0, height) for x, y in polygon], float)
    faces = [(0, i + 1, i) for i in range(1, p - 1)]  # bottom, facing down
    faces += [(p, p + i, p + i + 1) for i in range(1, p - 1)]  # top
    for i in range(p):
        j = (i + 1) % p
        faces += [(i, j, p + j), (i, p + j, p + i)]
    path = tmp_path / f"{name}.obj"
    trimesh.Trimesh(verts, np.array(faces), process=False).export(path)
    return str(path)


@pytest.fixture(scope="module")
def obstacles(tmp_path_factory):
    """4 quad prisms (one convex shape), 1 triangle prism, 3 boxes (9 pairs: MJX culls to 6)."""
    tmp = tmp_path_factory.mktemp("meshes")
    quads = [
        [(0, 0), (12, 1), (11, 9), (-1, 7)],
        [(0, 0), (8, 0), (8, 5), (0, 5)],
        [(0, 0), (10, -2), (14, 6), (2, 8)],
        [(0, 0), (6, 0), (9, 9), (-2, 6)],
    ]
    obstacles = [
        Obstacle(kind="mesh", pos=(30.0 * i, 20.0, 0.0), path=_prism(tmp, f"q{i}", q, 10.0))
        for i, q in enumerate(quads)
    ]
    tri = _prism(tmp, "tri", [(0, 0), (10, 0), (3, 8)], 6.0)
    obstacles.append(Obstacle(kind="mesh", pos=(-30.0, 20.0, 0.0), path=tri))
    obstacles += [
        Obstacle(kind="box", pos=(15.0 * i - 60.0, -30.0, 2.0), size=(3.0, 2.0, 2.0), yaw=0.3 * i)
        for i in range(3)
    ]
    return tuple(obstacles)


@pytest.fixture(scope="module")
def scene(obstacles):
    return plant_mod.make_plant(3, 0, 0.025, LIM, obstacles)


def _data_against(plant, rng):
    """Radars placed within a few metres of random obstacle geoms: contacts active."""
    import mujoco

    m = plant.mj_model
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    geoms = [g for g in range(m.ngeom) if m.geom_contype[g] == 1]
    q = np.array(d.qpos)
    for r in range(plant.n_radars):
        g = geoms[rng.integers(len(geoms))]
        q[plant.index.radar_qpos[r, :2]] = d.geom_xpos[g][:2] + rng.normal(0, 4, 2)
    data = staged_step.mjx.make_data(plant.model)
    return data.replace(qpos=jnp.asarray(q), ctrl=jnp.asarray(rng.normal(0, 2, m.nu)))


def _compare(fn_ours, fn_theirs, plant, fields, draws=4):
    ours, theirs = jax.jit(fn_ours), jax.jit(fn_theirs)
    rng = np.random.default_rng(3)
    touching = 0
    for _ in range(draws):
        d = _data_against(plant, rng)
        a, b = ours(d), theirs(d)
        touching += int(jnp.sum(b._impl.contact.dist < 0))
        for field in fields:
            x, y = field(a), field(b)
            np.testing.assert_allclose(np.asarray(x), np.asarray(y), rtol=0, atol=1e-12)
    assert touching >= draws  # the comparison saw active contacts


CONTACT = [
    lambda d: d._impl.contact.dist,
    lambda d: d._impl.contact.pos,
    lambda d: d._impl.contact.frame,
    lambda d: d._impl.contact.geom,
    lambda d: d._impl.contact.solimp,
    lambda d: d._impl.contact.includemargin,
]


def test_staged_collision_equals_mjx_collision(obstacles):
    with jax.enable_x64(True):
        plant = plant_mod.make_plant(3, 0, 0.025, LIM, obstacles)  # a float64 model
        m = plant.model
        _compare(
            lambda d: staged_step.collision(m, staged_step.mjx.kinematics(m, d)),
            lambda d: staged_step.mjx.collision(m, staged_step.mjx.kinematics(m, d)),
            plant,
            CONTACT,
        )


@pytest.mark.slow
def test_staged_step_equals_mjx_step(obstacles):
    with jax.enable_x64(True):
        plant = plant_mod.make_plant(3, 0, 0.025, LIM, obstacles)
        m = plant.model
        _compare(
            lambda d: staged_step.step(m, d),
            lambda d: staged_step.mjx.step(m, d),
            plant,
            [*CONTACT, lambda d: d.qpos, lambda d: d.qvel, lambda d: d._impl.efc_force],
        )


def test_one_contact_call_per_convex_shape(scene, monkeypatch):
    calls = []
    original = staged_step.collision_convex._sphere_convex

    def spy(*args):
        calls.append(1)
        return original(*args)

    monkeypatch.setattr(staged_step.collision_convex, "_sphere_convex", spy)
    d = staged_step.mjx.make_data(scene.model)
    jax.make_jaxpr(lambda d: staged_step.collision(scene.model, d))(d)
    # quads merged (1), the triangle prism alone (1), the 3 boxes in MJX's own key (1)
    assert len(calls) == 3
    calls.clear()
    jax.make_jaxpr(lambda d: staged_step.mjx.collision(scene.model, d))(d)
    assert len(calls) == 6  # MJX: one per mesh (5) and one for the boxes


def test_contact_parameters_equal_mjx(scene):
    """Random per-geom parameters (zero solmix, "direct" negative solref included): the
    host-side parameters equal MJX's staged ones exactly, dtype included."""
    import copy

    mj = copy.copy(scene.mj_model)
    rng = np.random.default_rng(0)
    n = mj.ngeom
    mj.geom_margin[:] = 0.0  # MJX refuses margins on sphere-mesh pairs
    mj.geom_solmix[:] = rng.choice([0.0, 0.3, 1.0, 2.5], n)
    mj.geom_friction[:] = rng.uniform(0.1, 2.0, (n, 3))
    mj.geom_solref[:] = rng.uniform(0.01, 0.05, (n, 2)) * rng.choice([-1, 1], (n, 1))
    mj.geom_solimp[:, :3] = np.sort(rng.uniform(0.5, 0.99, (n, 3)), axis=1)
    model = staged_step.mjx.put_model(mj)
    d = staged_step.mjx.make_data(model)
    ours = staged_step._contact_groups(model, d)
    theirs = staged_step.collision_driver._contact_groups(model, d)
    assert list(ours) == list(theirs)
    fields = ("includemargin", "friction", "solref", "solreffriction", "solimp")
    for key in theirs:
        for f in (*fields, "geom", "geom1", "geom2"):
            a, b = getattr(ours[key], f), getattr(theirs[key], f)
            assert a.dtype == b.dtype, f
            np.testing.assert_array_equal(np.asarray(a), np.asarray(b), err_msg=f)
