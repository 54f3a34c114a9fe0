"""One fused physics step for the contact-free scene, built from the compiled model.

For a scene that takes the plant's fast path (no contacts, constant mass matrix, zero
bias and passive forces, :mod:`~mjx_radar.physics.model_checks`) MuJoCo's step reduces,
per body, to a few lines. With ``q`` a body's joint positions ``[D]`` (slide x, y(, z),
hinge yaw), ``qd`` its velocities, ``act`` its activations and ``u = clip(ctrl)``:

    moment(q) = M0 + cos(yaw) Mc + sin(yaw) Ms                  [U, D]
    force     = gain * (act if integrator else u) + b0 + b2 * moment(q) qd     [U]
    qacc      = (moment(q)ᵀ force) / diag(M)                    [D]
    act'      = clip(act + dt * u[integrators], actrange)       (Euler, actlimited)
    qd'       = qd + dt * qacc,   q' = q + dt * qd'             (Euler)

The moment arm of a body with slide x, slide y and a yaw hinge is affine in
``(cos yaw, sin yaw)`` (a site's frame turns with the yaw; a joint transmission is
constant). :func:`build` reads ``M0, Mc, Ms`` from C MuJoCo (actuator velocities at
unit joint velocities and yaw 0, π/2, π), the gains, biases, ranges and the diagonal
mass matrix from the compiled model, then checks the fused step against ``mj_step`` at
random states and controls (relative error ≤ 1e-9 in float64); any scene it does not
describe (an off-diagonal mass matrix, a length-dependent bias, a force limit, a
coupled actuator...) fails that check and keeps MJX's stages. What it saves: MJX's
kinematics, com_pos, transmission, actuation and solve stages become one small fused
expression per step (docs/scaling.md: the MPPI call and the compile time).
"""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np

INTEGRATOR = int(mujoco.mjtDyn.mjDYN_INTEGRATOR)
CHECK_RTOL = 1e-9


@dataclasses.dataclass(frozen=True, eq=False)
class BodyBlock:
    """K bodies of one kind (radars or drones), their addresses and step parameters.

    Attributes:
        qpos: [K, D] qpos (= dof, slide/hinge joints) addresses.
        act: [K, A] activation addresses.
        ctrl: [K, U] actuator ids.
        yaw: index of the yaw hinge within D, or -1 (the moment arm is constant).
        m0, mc, ms: [K, U, D] moment arm ``m0 + cos(yaw) mc + sin(yaw) ms``.
        gain, b0, b2: [K, U] fixed gain, bias offset and velocity bias.
        lo, hi: [K, U] control range (±inf where not limited).
        integ: [K, U] integrator-dynamics actuators (force input = activation).
        slot: [U] the activation slot (within A) of each integrator actuator (0 else),
            the same for every body of the block.
        driver: [A] the actuator (within U) whose control is each activation's rate.
        act_lo, act_hi: [K, A] activation range (±inf where not limited).
        mass: [K, D] diagonal of the joint-space inertia.
    """

    qpos: np.ndarray
    act: np.ndarray
    ctrl: np.ndarray
    yaw: int
    m0: np.ndarray
    mc: np.ndarray
    ms: np.ndarray
    gain: np.ndarray
    b0: np.ndarray
    b2: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    integ: np.ndarray
    slot: np.ndarray
    driver: np.ndarray
    act_lo: np.ndarray
    act_hi: np.ndarray
    mass: np.ndarray


def block_step(xp, b: BodyBlock, dt: float, q, qd, act, ctrl):
    """One Euler step of K bodies (module docstring); ``xp`` is numpy or jax.numpy.

    Args:
        q, qd: [K, D] joint positions and velocities.
        act: [K, A] activations.
        ctrl: [K, U] controls (clipped here to the control range).

    Returns:
        ``(q', qd', act')`` after one step of ``dt``.
    """
    dtype = q.dtype
    u = xp.clip(ctrl, b.lo.astype(dtype), b.hi.astype(dtype))
    mom = b.m0.astype(dtype)
    if b.yaw >= 0:
        c, s = xp.cos(q[:, b.yaw]), xp.sin(q[:, b.yaw])
        mom = mom + c[:, None, None] * b.mc.astype(dtype) + s[:, None, None] * b.ms.astype(dtype)
    vel = xp.sum(mom * qd[:, None, :], axis=-1)  # actuator velocities [K, U]
    inp = xp.where(b.integ, act[:, b.slot], u)
    force = b.gain.astype(dtype) * inp + b.b0.astype(dtype) + b.b2.astype(dtype) * vel
    qacc = xp.sum(mom * force[:, :, None], axis=1) / b.mass.astype(dtype)
    rate = u[:, b.driver]
    act = xp.clip(act + dt * rate, b.act_lo.astype(dtype), b.act_hi.astype(dtype))
    qd = qd + dt * qacc
    return q + dt * qd, qd, act


@dataclasses.dataclass(frozen=True, eq=False)
class FusedModel:
    """The fused step of a whole scene: its body blocks and time step."""

    blocks: tuple[BodyBlock, ...]
    dt: float


def data_step(xp, fm: FusedModel, qpos, qvel, act, ctrl):
    """One step of the whole scene on flat ``qpos, qvel [nq], act [na], ctrl [nu]``."""
    for b in fm.blocks:
        q, qd, a = block_step(xp, b, fm.dt, qpos[b.qpos], qvel[b.qpos], act[b.act], ctrl[b.ctrl])
        qpos, qvel, act = (
            _set(xp, qpos, b.qpos, q),
            _set(xp, qvel, b.qpos, qd),
            _set(xp, act, b.act, a),
        )
    return qpos, qvel, act


def _set(xp, a, idx, v):
    if xp is np:
        a = a.copy()
        a[idx] = v
        return a
    return a.at[idx].set(v.astype(a.dtype))


def _moment_columns(m: mujoco.MjModel, data, qpos_adr, ctrl, yaw_adr, yaw):
    """[U, D] actuator moment of one body at the given yaw (unit joint velocities)."""
    data.qpos[:] = 0.0
    if yaw_adr >= 0:
        data.qpos[yaw_adr] = yaw
    cols = []
    for d in qpos_adr:
        data.qvel[:] = 0.0
        data.qvel[d] = 1.0
        mujoco.mj_forward(m, data)
        cols.append(data.actuator_velocity[ctrl].copy())
    return np.stack(cols, axis=-1)


def _block(m: mujoco.MjModel, qpos, act, ctrl, yaw: int) -> BodyBlock | None:
    data = mujoco.MjData(m)
    qpos, act, ctrl = (np.asarray(a, dtype=np.int32) for a in (qpos, act, ctrl))
    mom = {}
    for y in (0.0, 0.5 * math.pi, math.pi):
        mom[y] = np.stack(
            [
                _moment_columns(m, data, qpos[k], ctrl[k], qpos[k, yaw] if yaw >= 0 else -1, y)
                for k in range(len(qpos))
            ]
        )
    m0 = 0.5 * (mom[0.0] + mom[math.pi]) if yaw >= 0 else mom[0.0]
    mc = 0.5 * (mom[0.0] - mom[math.pi]) if yaw >= 0 else np.zeros_like(m0)
    ms = mom[0.5 * math.pi] - m0 if yaw >= 0 else np.zeros_like(m0)
    m0, mc, ms = (np.where(np.abs(a) < 1e-12, 0.0, a) for a in (m0, mc, ms))  # cos(π/2) ≠ 0
    limited = m.actuator_ctrllimited[ctrl].astype(bool)
    rng = m.actuator_ctrlrange[ctrl]
    lo, hi = np.where(limited, rng[..., 0], -np.inf), np.where(limited, rng[..., 1], np.inf)
    integ = m.actuator_dyntype[ctrl] == INTEGRATOR
    adr = m.actuator_actadr[ctrl]
    slot = np.zeros(ctrl.shape, np.int32)
    driver = np.zeros(act.shape, np.int32)
    for k in range(len(ctrl)):
        for j in np.flatnonzero(integ[k]):
            s = int(np.flatnonzero(act[k] == adr[k, j])[0])
            slot[k, j], driver[k, s] = s, j
    if np.any(slot != slot[:1]) or np.any(driver != driver[:1]):
        return None  # bodies of one kind wired differently: not this model
    act_ids = _act_owner(m)[act]
    alim = m.actuator_actlimited[act_ids].astype(bool)
    arng = m.actuator_actrange[act_ids]
    full = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, data, full)
    return BodyBlock(
        qpos,
        act,
        ctrl,
        yaw,
        m0,
        mc,
        ms,
        m.actuator_gainprm[ctrl, 0],
        m.actuator_biasprm[ctrl, 0],
        m.actuator_biasprm[ctrl, 2],
        lo,
        hi,
        integ,
        slot[0],
        driver[0],
        np.where(alim, arng[..., 0], -np.inf),
        np.where(alim, arng[..., 1], np.inf),
        np.diagonal(full)[qpos],
    )


def build(m: mujoco.MjModel, index) -> FusedModel | None:
    """The fused step of a fast-path scene (``physics.scene.SceneIndex``), or None where
    it does not reproduce ``mj_step`` (checked here at random states, module docstring)."""
    if m.nq != m.nv or m.nmocap or m.opt.integrator != mujoco.mjtIntegrator.mjINT_EULER:
        return None
    blocks = []
    if len(index.radar_qpos):
        blocks.append(_block(m, index.radar_qpos, index.radar_act, index.radar_ctrl, yaw=2))
    if len(index.drone_qpos):
        blocks.append(_block(m, index.drone_qpos, index.drone_act, index.drone_ctrl, yaw=-1))
    if any(b is None for b in blocks):
        return None
    fm = FusedModel(tuple(blocks), float(m.opt.timestep))
    covered = sum(b.ctrl.size for b in blocks), sum(b.qpos.size for b in blocks)
    if covered != (m.nu, m.nv) or sum(b.act.size for b in blocks) != m.na:
        return None
    return fm if matches_mj_step(m, fm) else None


def matches_mj_step(m: mujoco.MjModel, fm: FusedModel, tries: int = 6) -> bool:
    """True if the fused step equals C MuJoCo's ``mj_step`` at random states and
    controls (up to 1.5x the control ranges, so the clamps are exercised)."""
    data = mujoco.MjData(m)
    rng = np.random.default_rng(2)
    owner = _act_owner(m)
    for _ in range(tries):
        mujoco.mj_resetData(m, data)
        data.qpos[:] = rng.uniform(-500, 500, m.nq)
        for b in fm.blocks:
            if b.yaw >= 0:
                data.qpos[b.qpos[:, b.yaw]] = rng.uniform(-math.pi, math.pi, len(b.qpos))
        data.qvel[:] = rng.uniform(-20, 20, m.nv)
        data.act[:] = rng.uniform(-1.5, 1.5, m.na) * _span(m.actuator_actrange[owner])
        data.ctrl[:] = rng.uniform(-1.5, 1.5, m.nu) * _span(m.actuator_ctrlrange)
        ours = data_step(
            np, fm, data.qpos.copy(), data.qvel.copy(), data.act.copy(), data.ctrl.copy()
        )
        mujoco.mj_step(m, data)
        for a, ref in zip(ours, (data.qpos, data.qvel, data.act), strict=True):
            if not np.allclose(a, ref, rtol=CHECK_RTOL, atol=CHECK_RTOL * (1 + np.abs(ref).max())):
                return False
    return True


def _act_owner(m: mujoco.MjModel) -> np.ndarray:
    """[na] the actuator whose activation sits at each activation address."""
    return np.array([np.flatnonzero(m.actuator_actadr == a)[0] for a in range(m.na)], np.int64)


def _span(ranges: np.ndarray) -> np.ndarray:
    """Per-entry scale for random draws: the range's half width, or 10 if unlimited."""
    half = 0.5 * (ranges[:, 1] - ranges[:, 0]) if len(ranges) else np.zeros(0)
    return np.where(half > 0, half, 10.0)
