"""MJX's step by stages: contact-free, and with the sphere–mesh contacts batched.

:func:`contact_free_step` is the plant's step for a contact-free scene whose fused step
is off (below). :func:`step` is the truth plant's step with contacts:

MJX groups collision pairs by function *and mesh id*, because its convex routines need
static mesh sizes (``collision_driver._geom_groups``): a scene of K building parts
traces ``sphere_convex`` K times, one small vmap over the radars each. With the 52
convex parts of ``town_4r4t`` that is most of the truth step's program (34 k lines of
StableHLO against 8 k without the buildings) and of its compile time.

The parts are all extruded convex polygons, so most share one convex *shape* (vertex,
face and edge counts) even though their meshes differ. :func:`collision` is MJX's
``collision`` with the mesh keys of one shape merged: the meshes' convex data are
stacked ([K, ...], host-side, once per model), each pair gathers its mesh's slice,
and MJX's own ``_sphere_convex`` is vmapped over all the pairs of the shape at once.
The contacts come out in MJX's order with MJX's parameters, so the constraint solver
sees the same problem: :func:`step` equals ``mjx.step`` (tests/test_mesh_contacts.py
compares the two on the town's model with contacts active, to 1e-12 in float64).

Only sphere–mesh pairs are merged (the radars' collision hulls are spheres, SPEC §2);
every other key runs MJX's function unchanged, after MJX's broad phase (``max_geom_pairs``,
per key; a mesh key it would cull is not merged). Models with ``max_contact_points`` set
keep ``mjx.collision``. This
module reads MJX's private collision driver (``mujoco.mjx._src``, mujoco-mjx 3.x):
tests pin the agreement, so an MJX upgrade that changes it fails loudly.
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import mujoco
import numpy as np

from mjx_radar.physics import mjx_module

mjx = mjx_module.load()  # MJX's private modules below are loaded by its package
collision_convex = mjx._src.collision_convex
collision_driver = mjx._src.collision_driver
mjx_math = mjx._src.math
ConvexInfo = mjx._src.collision_types.ConvexInfo
GeomType = mjx._src.types.GeomType

_NO_BROADPHASE = collision_driver._GEOM_NO_BROADPHASE
_FIELDS = ("vert", "face", "face_normal", "edge", "edge_face_normal")


def _shape(m, mesh_id: int) -> tuple:
    convex = m._impl.mesh_convex[mesh_id]
    return tuple(np.shape(getattr(convex, f)) for f in _FIELDS)


def _culled(m, n_pairs: int) -> bool:
    """MJX's broad phase culls a key's pairs to ``max_geom_pairs`` when it has more."""
    limit = collision_driver._numeric(m, "max_geom_pairs")
    return limit > -1 and n_pairs > limit


def _merged_keys(m, groups) -> dict:
    """{(condim, convex shape): [keys]}: the sphere–mesh keys with ≥ 2 meshes of a shape.

    A key MJX's broad phase would cull (more pairs than ``max_geom_pairs``) keeps its own
    call, so the merged contacts are exactly MJX's.
    """
    merged: dict = {}
    for key, contact in groups.items():
        if tuple(key.types) == (GeomType.SPHERE, GeomType.MESH) and not _culled(
            m, contact.geom.shape[0]
        ):
            merged.setdefault((key.condim, _shape(m, key.data_ids[1])), []).append(key)
    return {k: v for k, v in merged.items() if len(v) > 1}


def _sphere_mesh(m, d, keys, contacts) -> list:
    """(dist, pos, frame) of each key's pairs, computed in one vmap over all the pairs."""
    geom = jnp.concatenate([c.geom for c in contacts])  # [P, 2]
    mesh_of_pair = np.concatenate(
        [np.full(c.geom.shape[0], j) for j, c in enumerate(contacts)]
    )  # [P] index into keys
    stacked = {  # host-side: the pairs' mesh data enter the program as constants
        f: np.stack([np.asarray(getattr(m._impl.mesh_convex[k.data_ids[1]], f)) for k in keys])[
            mesh_of_pair
        ]
        for f in _FIELDS
    }
    g1, g2 = geom.T
    sphere = collision_convex.GeomInfo(d.geom_xpos[g1], d.geom_xmat[g1], m.geom_size[g1])
    convex = ConvexInfo(d.geom_xpos[g2], d.geom_xmat[g2], m.geom_size[g2], **stacked)

    def one(s, c):
        dist, pos, n = collision_convex._sphere_convex(s, c)
        return dist, pos, mjx_math.make_frame(n)

    dist, pos, frame = jax.vmap(one)(sphere, convex)
    out, start = [], 0
    for c in contacts:
        stop = start + c.geom.shape[0]
        out.append((dist[start:stop], pos[start:stop], frame[start:stop]))
        start = stop
    return out


_GROUPS: dict = {}  # id(model) -> (model, {key: the key's contact parameters, numpy})


_GEOM_FIELDS = ("geom_margin", "geom_solmix", "geom_friction", "geom_solref", "geom_solimp")


def _geom_params(f: dict, g1, g2) -> dict:
    """MJX's contact parameters of geom pairs ``g1, g2`` [P] (``_contact_groups``' rules:
    margins add, friction is the larger, solref and solimp mix by solmix, solref "direct"
    takes the smaller), in numpy, in the model's float type; ``f``: the model's
    :data:`_GEOM_FIELDS` as numpy arrays."""
    eps = mujoco.mjMINVAL
    s1, s2 = f["geom_solmix"][g1], f["geom_solmix"][g2]
    with np.errstate(divide="ignore", invalid="ignore"):
        mix = s1 / (s1 + s2)
    mix = np.where((s1 < eps) & (s2 < eps), 0.5, mix)
    mix = np.where((s1 < eps) & (s2 >= eps), 0.0, mix)
    mix = np.where((s1 >= eps) & (s2 < eps), 1.0, mix).astype(s1.dtype)[:, None]
    r1, r2 = f["geom_solref"][g1], f["geom_solref"][g2]
    standard = (r1[:, [0, 0]] > 0) & (r2[:, [0, 0]] > 0)
    friction = np.maximum(f["geom_friction"][g1], f["geom_friction"][g2])
    return {
        "includemargin": f["geom_margin"][g1] + f["geom_margin"][g2],
        "friction": friction[:, [0, 0, 1, 2, 2]],
        "solref": np.where(standard, mix * r1 + (1 - mix) * r2, np.minimum(r1, r2)),
        "solreffriction": np.zeros((len(g1), mujoco.mjNREF), mix.dtype),
        "solimp": mix * f["geom_solimp"][g1] + (1 - mix) * f["geom_solimp"][g2],
    }


def _contact_groups(m, d) -> dict:
    """MJX's ``_contact_groups(m, d)`` with the parameters computed once, on the host.

    The groups' parameters are constants of the model. MJX computes them in every
    trace, as staged operations (4.5 k of them for the town's 53 keys); here they are
    computed once per model in numpy (:func:`_geom_params`, tests compare them with
    MJX's) and enter the program as constants. Models with explicit contact pairs or
    geom priorities keep MJX's computation.
    """
    entry = _GROUPS.get(id(m))
    if entry is None or entry[0] is not m:
        groups = collision_driver._geom_groups(m)
        ids = {k: np.array(v) for k, v in groups.items()}
        plain = all((v[:, 2] == -1).all() for v in ids.values())
        prio = np.asarray(m.geom_priority)
        if not plain or any((prio[v[:, 0]] != prio[v[:, 1]]).any() for v in ids.values()):
            return collision_driver._contact_groups(m, d)
        fields = {k: np.asarray(getattr(m, k)) for k in _GEOM_FIELDS}  # one copy each
        params = {
            k: {**_geom_params(fields, v[:, 0], v[:, 1]), "geom": v[:, :2]} for k, v in ids.items()
        }
        while len(_GROUPS) >= 16:  # plants are few; tests build many
            _GROUPS.pop(next(iter(_GROUPS)))
        entry = _GROUPS[id(m)] = (m, params)
    con = d._impl.contact
    return {
        key: mjx.Contact(
            dist=None,
            pos=None,
            frame=None,
            dim=con.dim,
            efc_address=con.efc_address,
            geom1=jnp.asarray(p["geom"][:, 0]),
            geom2=jnp.asarray(p["geom"][:, 1]),
            **{k: jnp.asarray(v) for k, v in p.items()},
        )
        for key, p in entry[1].items()
    }


def collision(m, d):
    """``mjx.collision`` with the sphere–mesh keys of one convex shape merged (module doc)."""
    if d._impl.ncon == 0:
        return d
    if collision_driver._numeric(m, "max_contact_points") > -1:
        return mjx.collision(m, d)
    groups = _contact_groups(m, d)
    merged = _merged_keys(m, groups)
    done = set()
    for keys in merged.values():
        results = _sphere_mesh(m, d, keys, [groups[k] for k in keys])
        for key, (dist, pos, frame) in zip(keys, results, strict=True):
            groups[key] = groups[key].replace(dist=dist, pos=pos, frame=frame)
            done.add(key)
    for key, contact in groups.items():
        if key in done:
            continue
        if _culled(m, contact.geom.shape[0]) and not set(key.types) & _NO_BROADPHASE:
            pos1, pos2 = d.geom_xpos[contact.geom.T]  # MJX's broad phase, as in its collision()
            size1, size2 = m.geom_rbound[contact.geom.T]
            dist = jax.vmap(jnp.linalg.norm)(pos2 - pos1) - (size1 + size2)
            _, keep = jax.lax.top_k(-dist, k=collision_driver._numeric(m, "max_geom_pairs"))
            contact = jax.tree_util.tree_map(lambda x, keep=keep: x[keep], contact)
        func = collision_driver._COLLISION_FUNC[key.types]
        dist, pos, frame = func(m, d, key, contact.geom)
        if func.ncon > 1:
            contact = jax.tree_util.tree_map(
                functools.partial(jnp.repeat, repeats=func.ncon, axis=0), contact
            )
        groups[key] = contact.replace(dist=dist, pos=pos, frame=frame)
    by_condim: dict = {}
    for key, contact in groups.items():  # MJX's order: keys in insertion order, by condim
        by_condim.setdefault(key.condim, []).append(contact)
    contacts = sum([by_condim[k] for k in sorted(by_condim)], [])
    contact = jax.tree_util.tree_map(lambda *x: jnp.concatenate(x), *contacts)
    return d.tree_replace({"_impl.contact": contact})


def step(m, d):
    """``mjx.step`` (Euler) with :func:`collision` in its position stage.

    The stages of MJX's ``forward`` and ``euler`` in MJX's order; any other integrator
    keeps ``mjx.step``.
    """
    if m.opt.integrator != mujoco.mjtIntegrator.mjINT_EULER:
        return mjx.step(m, d)
    d = mjx.kinematics(m, d)
    d = mjx.com_pos(m, d)
    d = mjx.camlight(m, d)
    d = mjx.tendon(m, d)
    d = mjx.crb(m, d)
    d = mjx.tendon_armature(m, d)
    d = mjx.factor_m(m, d)
    d = collision(m, d)
    d = mjx.make_constraint(m, d)
    d = mjx.transmission(m, d)
    d = mjx.sensor_pos(m, d)
    d = mjx.fwd_velocity(m, d)
    d = mjx.sensor_vel(m, d)
    d = mjx.fwd_actuation(m, d)
    d = mjx.fwd_acceleration(m, d)
    if d._impl.efc_J.size == 0:
        return mjx.euler(m, d.replace(qacc=d.qacc_smooth))
    d = mjx.solve(m, d)
    d = mjx.sensor_acc(m, d)
    return mjx.euler(m, d)


def contact_free_step(model, data):
    """``mjx.step`` for a contact-free scene with a constant mass matrix and no bias force.

    Runs the kinematics, transmission, actuator-velocity and actuation stages and the
    Euler update; skips collision, constraints, sensors and the velocity stage's
    com_vel / passive / RNE passes (their forces are zero, checked by
    `model_checks.zero_bias` when the plant is built), and reuses the mass-matrix factor
    computed once by :func:`init_data` (tests compare it with ``mjx.step``).
    """
    data = mjx.kinematics(model, data)
    data = mjx.com_pos(model, data)
    data = mjx.transmission(model, data)
    impl = data._impl  # actuator velocities: fwd_velocity's first line, without the rest
    data = data.tree_replace({"_impl.actuator_velocity": impl.actuator_moment @ data.qvel})
    data = mjx.fwd_actuation(model, data)
    data = mjx.fwd_acceleration(model, data)
    return mjx.euler(model, data.replace(qacc=data.qacc_smooth))
