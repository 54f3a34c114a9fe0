"""Initial conditions of a trial (SPEC §3, §4): radar placement and the initial estimate.

Unless the scenario fixes them (``radars = [[x, y, theta], ...]``), radars
are placed uniformly in ``[-w, w]^2`` at z = 0 by rejection sampling so
that every radar-radar distance is >= R2R and every radar-target distance
(3-D) is >= R2T; headings are uniform in (-pi, pi], v = omega = 0. Rejection is
done with a fixed number of candidates per radar (static shapes under jit):
radar i takes the first admissible of ``CANDIDATES`` draws given radars
0..i-1. ``ok`` is False if some radar found no admissible candidate; callers
check it on the host before running (``mjx-radar`` exits with code 2).
On terrain (docs/terrain.md) a candidate stands at the ground height plus the
antenna height (the 3-D R2T test uses it) and candidates on slopes steeper than
``terrain.max_slope_deg`` are not admissible.

The initial estimate is ``x_0 + e``, ``e ~ N(0, P0)``, ``P0 = p0 I`` (a consistent draw).
"""

from __future__ import annotations

import functools
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from mjx_radar.env.streams import trial_streams
from mjx_radar.scenario.schema import Scenario
from mjx_radar.world.components import Ground

CANDIDATES = 512


class Layout(NamedTuple):
    """The static parts of a trial's start: typed slices of the task (:func:`layout_of`)
    or of a scenario shape (:func:`shape_layout`).

    Attributes:
        n_radars, n_targets: N and M.
        ground: the :class:`~mjx_radar.world.components.Ground` the radars stand on.
        fixed: whether the scenario fixes the radars' starts (``radars = [...]``; their
            numbers are ``params.radar_init``).
    """

    n_radars: int
    n_targets: int
    ground: Ground
    fixed: bool


def layout_of(task) -> Layout:
    """The :class:`Layout` of a :class:`~mjx_radar.task.task.RadarTask` (its fleet,
    targets and ground)."""
    fleet = task.fleet
    return Layout(fleet.n_radars, task.n_targets, task.world.ground, fleet.fixed_starts)


@functools.lru_cache(maxsize=32)
def shape_layout(shape: Scenario) -> Layout:
    """The :class:`Layout` of a scenario shape (the placement check, before any task;
    cached, so one shape has one layout: a ``jit`` static)."""
    return Layout(shape.n_radars, shape.n_targets, Ground(shape.terrain), bool(shape.radar_init))


class Init(NamedTuple):
    radar_state: jax.Array  # [N, 6]
    target_state: jax.Array  # [M, 6]
    mean: jax.Array  # [6M] initial estimate
    cov: jax.Array  # [6M, 6M] initial covariance
    ok: jax.Array  # [] bool


def place_radars(layout: Layout, params, key: jax.Array) -> tuple[jax.Array, jax.Array]:
    """Rejection-samples radar states.

    Args:
        layout: the trial's :class:`Layout` (N, the ground, fixed starts or not).
        params: :class:`~mjx_radar.task.params.TaskParams` (box, keep-outs, starts).
        key: the trial's placement stream.

    Returns:
        ``([N, 6] radar states, ok)``.
    """
    n, w = layout.n_radars, params.placement_half_width
    targets = params.target_init[:, :3]
    k_xy, k_th = jax.random.split(key)
    cand = jax.random.uniform(k_xy, (n, CANDIDATES, 2), minval=-w, maxval=w)
    ground, steep = layout.ground.placement_height(cand)
    cand3 = jnp.concatenate([cand, ground[..., None]], axis=-1)
    d_rt = jnp.linalg.norm(cand3[:, :, None] - targets[None, None], axis=-1).min(-1)
    earlier = jnp.arange(n)

    def place(i, carry):  # radar i takes its first candidate admissible given radars < i
        placed, all_ok = carry
        d_rr = jnp.linalg.norm(cand3[i][:, None] - placed[None], axis=-1)  # [C, N]
        d_rr = jnp.where(earlier < i, d_rr, jnp.inf).min(-1)  # radars not yet placed: none
        ok = (d_rt[i] >= params.r2t) & ~steep[i] & (d_rr >= params.r2r)
        first = jnp.argmax(ok)
        return placed.at[i].set(cand3[i, first]), all_ok & ok[first]

    # A loop, not N unrolled copies: the program's size does not grow with N (32 unrolled
    # radars compiled for 6 s on 2 CPU cores), the same numbers (masked distances: +inf).
    placed, all_ok = jax.lax.fori_loop(0, n, place, (jnp.zeros((n, 3)), jnp.array(True)))
    theta = jax.random.uniform(k_th, (n,), minval=-jnp.pi, maxval=jnp.pi)
    theta = jnp.where(theta == -jnp.pi, jnp.pi, theta)  # (-pi, pi]
    if layout.fixed:  # fixed start given by the scenario file
        fixed = params.radar_init
        z = layout.ground.placement_height(fixed[:, :2])[0]
        placed = jnp.concatenate([fixed[:, :2], z[:, None]], -1)
        theta = fixed[:, 2]
        d_rt = jnp.linalg.norm(placed[:, None] - targets[None], axis=-1)
        d_rr = jnp.linalg.norm(placed[:, None] - placed[None], axis=-1) + 1e9 * jnp.eye(n)
        all_ok = jnp.all(d_rt >= params.r2t) & jnp.all(d_rr >= params.r2r)
    zeros = jnp.zeros(n)
    states = jnp.stack([placed[:, 0], placed[:, 1], placed[:, 2], theta, zeros, zeros], axis=-1)
    return states, all_ok


def initial_conditions(layout: Layout, params, streams) -> Init:
    """Radar placement, true target states and the consistent initial estimate of the
    trial of ``streams`` (``layout``: :func:`layout_of` the task)."""
    radars, ok = place_radars(layout, params, streams.placement)
    targets = params.target_init
    dim = 6 * layout.n_targets
    cov = params.p0 * jnp.eye(dim)
    err = jnp.sqrt(params.p0) * jax.random.normal(streams.estimate, (dim,))
    return Init(radars, targets, targets.reshape(-1) + err, cov, ok)


def check_placeable(scenario: Scenario, seed: int, trials, placeable=None) -> None:
    """Raises ValueError naming the placement fields if some trial cannot place its radars.

    ``trials``: a count (trials ``0..trials-1``) or the trial indices themselves (only
    those are drawn: ``[10**6]`` is one trial, not a million). ``placeable``: how the
    check's program is had, ``placeable(shape) -> f(params, ids) -> ok [len(ids)]``
    (default :func:`placeable_program`, traced in this process; the engine passes one that
    keeps the compiled program on disk, :mod:`mjx_radar.engine.placement_cache`).
    """

    from mjx_radar.task.method import METHODS
    from mjx_radar.task.params import shape_key, task_params

    params = task_params(scenario, METHODS["stationary"], seed)
    ids = np.arange(trials) if np.ndim(trials) == 0 else np.unique(np.asarray(trials))
    if not len(ids):  # no trial: nothing to place
        return
    size = max(8, 1 << int(len(ids) - 1).bit_length())  # padded: few distinct programs
    padded = np.concatenate([ids, np.full(size - len(ids), ids[0])])
    program = (placeable or placeable_program)(shape_key(scenario))
    oks = np.asarray(program(params, jnp.asarray(padded)))[: len(ids)]
    if not oks.all():
        raise ValueError(placement_error(scenario, int(ids[np.argmin(oks)])))


def placement_error(scenario: Scenario, trial: int) -> str:
    """The one line that refuses a scenario whose ``trial`` cannot place its radars,
    naming the fields to change (:func:`check_placeable`; the runner's own check of the
    trials' ``placement_ok``, :func:`mjx_radar.engine.runner.run_trials`)."""
    if scenario.radar_init:  # fixed starts: the box plays no part
        return (
            f"radars: the fixed starts (on the ground: terrain height + antenna height) are "
            f"not >= mpc.r2r = {scenario.mpc.r2r} m apart and >= mpc.r2t = "
            f"{scenario.mpc.r2t} m from every target; move them or lower the keep-outs"
        )
    return (
        f"placement_half_width = {scenario.placement_half_width}: cannot place "
        f"{scenario.n_radars} radars >= mpc.r2r = {scenario.mpc.r2r} m apart and >= "
        f"mpc.r2t = {scenario.mpc.r2t} m from every target (trial {trial}); widen the box "
        "or lower the keep-out distances"
    )


@functools.lru_cache(maxsize=32)
def placeable_program(shape: Scenario):
    """``jit(vmap)`` of the trials' placement success for one compiled shape, built once
    per process: the numbers (``params``) are arguments, so every scenario of the shape
    and every seed reuse one traced program (it was traced anew on every run)."""

    layout = shape_layout(shape)

    def ok(params, t):
        return place_radars(layout, params, trial_streams(params.seed, t).placement)[1]

    return jax.jit(jax.vmap(ok, in_axes=(None, 0)))
