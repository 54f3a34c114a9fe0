"""Per-target motion of the truth plant: nominal paths, the CV perturbation, presence.

The drones stay MJCF bodies stepped by MJX (:func:`mjx_radar.physics.plant.step`): each
step commands a drone's acceleration ``a`` (its velocity activation integrates it) and
its mean velocity over the step ``v̄`` (the position servo's set-point), so

    v_k = v_{k-1} + a_k dt,        p_k = p_{k-1} + v̄_k dt.

``cv`` (the paper's model, SPEC §2): ``a = w``, ``v̄ = v + w dt / 2`` with white
acceleration ``w ~ N(0, σ_w² I)``. Every other model is a *nominal path*
``(P_k, V_k)``, k = 0..K, computed on the host in float64 from the scenario
(:func:`motion_params`), flown with a CV perturbation ``(δp, δv)`` on top:

    a_k = (V_k − V_{k−1}) / dt + w_k,     v̄_k = (P_k − P_{k−1}) / dt + (v − V_{k−1}) + w_k dt / 2,

so ``δv = v − V`` and ``δp = p − P`` follow exactly the CV map driven by ``w`` (zero with
``sigma_w2 = 0``: the truth is the nominal path). Beyond step K (``--steps`` longer than
``timing.steps``) the nominal path goes on at constant velocity ``V_K``.

Nominal paths:

* ``turn`` (rate ω): the horizontal velocity rotates at ω, the vertical one is held:
  ``v_h(t) = R(ωt) v_h(0)``, ``p_h(t) = p_h(0) + ω⁻¹ [[sin ωt, cos ωt − 1], [1 − cos ωt,
  sin ωt]] v_h(0)`` -- a circle of radius ``|v_h| / |ω|`` (closed form at every step).
* ``waypoints``: pure pursuit with bounded acceleration on the plant's Euler map: each
  step the heading turns toward waypoint ``w_i`` by at most ``a_max dt / |v|`` and the
  speed moves toward ``speed`` within what is left of ``|Δv| <= a_max dt``
  (turning has priority, :func:`_pursue`); waypoint i is passed when
  ``|w_i − p| <= capture`` (default ``2 s² / a_max``: twice the turn radius at full
  acceleration, so a waypoint inside the turning circle, which pursuit would orbit, is
  already within it); after the last, the list starts again (``loop``) or the target
  flies on at constant velocity.
* ``track``: the CSV's points linearly interpolated at ``k dt`` (extrapolated at the
  last segment's velocity after its end), ``V_k`` the central difference of ``P``.

Presence (``appear <= t < leave``): an absent target gives no measurement, no planner
cost and no error in the metrics (:mod:`mjx_radar.loop.closed_loop`).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from mjx_radar.scenario.schema import TargetMotion, Timing


class MotionParams(NamedTuple):
    """Runtime arrays of the per-target motion (a pytree; part of ``TaskParams``).

    Shapes (K = ``timing.steps``): ``accel [K, M, 3]``, ``mean_v [K, M, 3]`` (the
    nominal a_k, v̄_k of step k at index k − 1), ``vel [K+1, M, 3]`` (V_k),
    ``nominal [M]`` (bool: follows a nominal path), ``noise_std [M]`` (σ of w),
    ``appear [M]``, ``leave [M]`` [s].
    """

    accel: jax.Array
    mean_v: jax.Array
    vel: jax.Array
    nominal: jax.Array
    noise_std: jax.Array
    appear: jax.Array
    leave: jax.Array


def capture_radius(tm: TargetMotion) -> float:
    """The distance within which a waypoint counts as passed [m]."""
    return tm.capture if tm.capture > 0 else 2.0 * tm.speed**2 / tm.accel_max


def turn_path(x0: np.ndarray, rate: float, dt: float, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Closed-form coordinated turn from state ``x0 [6]``: ``(P [k+1, 3], V [k+1, 3])``."""
    t = dt * np.arange(k + 1)
    vx, vy, vz = x0[3:]
    if abs(rate) < 1e-12:
        s, c1 = t, np.zeros_like(t)  # sin(ωt)/ω -> t, (1 - cos ωt)/ω -> 0
        cw, sw = np.ones_like(t), np.zeros_like(t)
    else:
        sw, cw = np.sin(rate * t), np.cos(rate * t)
        s, c1 = sw / rate, (1.0 - cw) / rate
    pos = np.stack([x0[0] + s * vx - c1 * vy, x0[1] + c1 * vx + s * vy, x0[2] + vz * t], -1)
    vel = np.stack([cw * vx - sw * vy, sw * vx + cw * vy, np.full_like(t, vz)], -1)
    return pos, vel


def waypoint_path(
    x0: np.ndarray, tm: TargetMotion, dt: float, k: int
) -> tuple[np.ndarray, np.ndarray]:
    """Bounded-acceleration pursuit of ``tm.waypoints`` from ``x0 [6]`` (module docstring)."""
    wps = np.asarray(tm.waypoints, np.float64)
    cap, amax = capture_radius(tm), tm.accel_max
    p, v = np.array(x0[:3], np.float64), np.array(x0[3:], np.float64)
    pos, vel = np.empty((k + 1, 3)), np.empty((k + 1, 3))
    pos[0], vel[0] = p, v
    i, done = 0, False
    for step in range(1, k + 1):
        for _ in range(len(wps)):  # pass every waypoint already within capture
            if done or np.linalg.norm(wps[i] - p) > cap:
                break
            i += 1
            if i == len(wps):
                i, done = (0, False) if tm.loop else (i - 1, True)
        a = np.zeros(3) if done else (_pursue(v, wps[i] - p, tm.speed, amax, dt) - v) / dt
        p = p + (v + 0.5 * dt * a) * dt
        v = v + a * dt
        pos[step], vel[step] = p, v
    return pos, vel


def _pursue(v: np.ndarray, d: np.ndarray, speed: float, amax: float, dt: float) -> np.ndarray:
    """The velocity after one step turning ``v`` toward direction ``d``, ``|Δv| <= amax dt``.

    Turning first: the heading rotates toward ``d`` (in their plane) by at most
    ``amax dt / |v|``; the speed then moves toward ``speed`` as far as the bound allows
    (``|s' ŵ − v| <= amax dt`` <=> ``s'`` in ``|v| cos Δ ± sqrt((amax dt)² − |v|² sin² Δ)``).
    """
    u = d / max(np.linalg.norm(d), 1e-12)
    vn, step = np.linalg.norm(v), amax * dt
    if vn < 1e-9:  # from rest: straight toward the waypoint
        return u * min(speed, step)
    t = v / vn
    theta = math.acos(float(np.clip(t @ u, -1.0, 1.0)))
    perp = u - (t @ u) * t
    if np.linalg.norm(perp) < 1e-12:  # straight ahead, or straight behind: any normal
        perp = np.cross(t, [0.0, 0.0, 1.0] if abs(t[2]) < 0.9 else [1.0, 0.0, 0.0])
    n = perp / np.linalg.norm(perp)
    turn = min(theta, step / vn)
    w = math.cos(turn) * t + math.sin(turn) * n
    root = math.sqrt(max(step**2 - (vn * math.sin(turn)) ** 2, 0.0))
    lo, hi = vn * math.cos(turn) - root, vn * math.cos(turn) + root
    return w * float(np.clip(speed, max(lo, 0.0), hi))


def track_path(rows, dt: float, k: int) -> tuple[np.ndarray, np.ndarray]:
    """The CSV ``(t, x, y, z)`` rows interpolated at ``j dt``: ``(P [k+1, 3], V [k+1, 3])``."""
    data = np.asarray(rows, np.float64)
    tt, xyz = data[:, 0], data[:, 1:]
    t = dt * np.arange(k + 2)  # one more for the central difference
    slope = (xyz[-1] - xyz[-2]) / (tt[-1] - tt[-2])
    pos = np.stack([np.interp(t, tt, xyz[:, c]) for c in range(3)], -1)
    after = t > tt[-1]
    pos[after] = xyz[-1] + (t[after] - tt[-1])[:, None] * slope
    vel = np.empty((k + 1, 3))
    vel[0] = (pos[1] - pos[0]) / dt
    vel[1:] = (pos[2:] - pos[:-2]) / (2 * dt)
    return pos[: k + 1], vel


def nominal_paths(
    target_init, motion: tuple[TargetMotion, ...], timing: Timing
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Host float64 nominal paths of every target: ``(P [K+1, M, 3], V [K+1, M, 3], nominal [M])``.

    ``target_init``: the ``[M, 6]`` ``targets`` rows; ``motion``: the ``[[target_motion]]``
    tables; ``timing``: the clocks (``dt_filter``, K = ``steps``). CV targets get their
    straight line (unused by the plant: ``nominal`` is False).
    """
    dt, k = timing.dt_filter, timing.steps
    x0 = np.asarray(target_init, np.float64)
    m = len(x0)
    pos, vel = np.empty((k + 1, m, 3)), np.empty((k + 1, m, 3))
    nominal = np.zeros(m, bool)
    by_target = {tm.target: tm for tm in motion}
    for j in range(m):
        tm = by_target.get(j)
        model = "cv" if tm is None else tm.model
        if model == "waypoints":
            pos[:, j], vel[:, j] = waypoint_path(x0[j], tm, dt, k)
        elif model == "track":
            pos[:, j], vel[:, j] = track_path(tm.track, dt, k)
        else:  # turn, and cv's straight line (rate 0)
            pos[:, j], vel[:, j] = turn_path(x0[j], tm.rate if model == "turn" else 0.0, dt, k)
        nominal[j] = model != "cv"
    return pos, vel, nominal


def initial_states(target_init, motion: tuple[TargetMotion, ...], dt: float) -> np.ndarray:
    """``[M, 6]`` true initial states: the ``targets`` rows ``target_init``, a track's start
    for a ``track`` table of ``motion`` (sampled at the filter step ``dt``)."""
    x0 = np.array(target_init, np.float64)
    for tm in motion:
        if tm.model == "track":
            pos, vel = track_path(tm.track, dt, 1)
            x0[tm.target] = np.concatenate([pos[0], vel[0]])
    return x0


def motion_params(
    target_init, motion: tuple[TargetMotion, ...], timing: Timing, sigma_w2: float, dtype
) -> MotionParams:
    """The runtime :class:`MotionParams` of targets with ``[[target_motion]]`` tables
    ``motion`` (``target_init``, ``timing``: as :func:`nominal_paths`; ``sigma_w2``: the
    scenario's white-acceleration variance, a CV target's default)."""
    dt = timing.dt_filter
    pos, vel, nominal = nominal_paths(target_init, motion, timing)
    m = pos.shape[1]
    var = np.full(m, float(sigma_w2))
    appear, leave = np.zeros(m), np.full(m, np.inf)
    for tm in motion:
        var[tm.target] = (sigma_w2 if tm.model == "cv" else 0.0) if tm.sigma_w2 < 0 else tm.sigma_w2
        appear[tm.target], leave[tm.target] = tm.appear, tm.leave
    arr = lambda x: jnp.asarray(x, dtype)  # noqa: E731
    return MotionParams(
        accel=arr(np.diff(vel, axis=0) / dt),
        mean_v=arr(np.diff(pos, axis=0) / dt),
        vel=arr(vel),
        nominal=jnp.asarray(nominal),
        noise_std=arr(np.sqrt(var)),
        appear=arr(appear),
        leave=arr(leave),
    )


def drone_command(mp: MotionParams, k, vel_state, noise, dt: float):
    """The drones' ``(a [M, 3], v̄ [M, 3])`` of filter step ``k`` (1-based, traced).

    Args:
        mp: the motion arrays.
        k: global filter step (the state before it is at ``(k − 1) dt``).
        vel_state: [M, 3] the drones' velocities before the step.
        noise: [M, 3] standard normal draws (scaled by ``noise_std`` here).
        dt: filter step [s].
    """
    w = mp.noise_std[:, None] * noise
    n_steps = mp.accel.shape[0]
    inside = k <= n_steps
    i = jnp.clip(k - 1, 0, n_steps - 1)
    a_nom = jnp.where(inside, mp.accel[i], 0.0)
    vbar_nom = jnp.where(inside, mp.mean_v[i], mp.vel[n_steps])
    v_nom = mp.vel[jnp.clip(k - 1, 0, n_steps)]
    sel = mp.nominal[:, None]
    accel = jnp.where(sel, a_nom + w, w)
    vbar = jnp.where(sel, vbar_nom + (vel_state - v_nom), vel_state) + 0.5 * dt * w
    return accel, vbar


def step_plant(plant, data, radar_u, mp: MotionParams | None, key, k, sigma_w2, moving=None):
    """One truth-plant step; the drones on their motion models (:func:`drone_command`).

    ``moving`` (:class:`~mjx_radar.world.moving.MovingParams`, or None): the moving
    obstacles' mocap bodies are first posed at ``t_k = k dt`` (:mod:`.moving_bodies`).

    ``mp`` None: the paper's CV drones, ``w = sqrt(sigma_w2) N(0, I)`` from ``key``
    (:func:`~mjx_radar.physics.kinematics.sample_white_accel`). Else the standard
    normal draws of the same key drive :func:`drone_command` (``sigma_w2`` unused).
    """
    from mjx_radar.physics import kinematics, moving_bodies
    from mjx_radar.physics import plant as physics

    if moving is not None:
        data = moving_bodies.pose_bodies(plant, data, moving, k * plant.dt)
    if mp is None:
        return physics.step(
            plant, data, radar_u, kinematics.sample_white_accel(key, plant.n_drones, sigma_w2)
        )
    v_now = physics.target_state(plant, data)[:, 3:]
    unit = jax.random.normal(key, (plant.n_drones, 3))
    accel, vbar = drone_command(mp, k, v_now, unit, plant.dt)
    return physics.step(plant, data, radar_u, accel, vbar)


def present(mp: MotionParams, t) -> jax.Array:
    """[M] bool: the targets present at time ``t`` (``appear <= t < leave``)."""
    return (t >= mp.appear) & (t < mp.leave)


def appears_between(mp: MotionParams, t0, t1) -> jax.Array:
    """[M] bool: targets absent at ``t0`` and present at ``t1`` (a track starts)."""
    return present(mp, t1) & ~present(mp, t0)
