"""The world's typed components, built once per scenario shape (``task.task.build``).

Each component holds its own parameters, its part of the objective, line of sight and
the planner's view of the scene, and is *empty* when the scenario has none of it, so the
floors that use it never ask whether it is there::

    ground     Ground            [terrain]                     flat z = 0 when empty
    obstacles  StaticObstacles   [[obstacles]], [forest], maps  no footprints when empty
    moving     MovingObstacles   [[moving_obstacles]]          no vehicles when empty

:class:`World` groups them with the line-of-sight data both loops share: the truth's
occluders (static obstacles and the ground) and the planner's (the same when
``mpc.los``, else none). The components are hashable by identity (``jit`` statics, like
the task that holds them); their arrays are float32 constants built on the host and
cached per configuration (:func:`~mjx_radar.world.terrain.terrain_grid`,
:func:`~mjx_radar.world.occlusion.occluders`, :func:`~mjx_radar.world.obstacles.sdf_grid`).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import jax
import jax.numpy as jnp

from mjx_radar.scenario.schema import MovingObstacle, Obstacle, Terrain
from mjx_radar.world import moving as moving_mod
from mjx_radar.world import obstacles as sdf_mod
from mjx_radar.world import occlusion, terrain


@dataclasses.dataclass(frozen=True, eq=False)
class Ground:
    """The ground: the ``[terrain]`` table and its height grid (empty: flat ground z = 0).

    Attributes:
        config: the :class:`~mjx_radar.scenario.schema.Terrain` table, or None.
    """

    config: Terrain | None = None

    @property
    def present(self) -> bool:
        return self.config is not None

    @property
    def grid(self) -> terrain.TerrainGrid | None:
        """The :class:`~mjx_radar.world.terrain.TerrainGrid` (cached constants) or None."""
        return None if self.config is None else terrain.terrain_grid(self.config)

    @property
    def slope_cost_on(self) -> bool:
        """Whether the objective has the ``terrain_slope`` term (``alpha_slope > 0``)."""
        return self.present and self.config.alpha_slope > 0

    @property
    def summary(self) -> str | None:
        """A few words on the ground for reports (``mjx-radar validate``), None when flat."""
        if self.config is None:
            return None
        t = self.config
        return f"terrain {t.extent_x:g} x {t.extent_y:g} m ({t.path.rsplit('/', 1)[-1]})"

    @property
    def antenna_height(self) -> float:
        """The antenna's height above the ground [m] (0 on flat ground)."""
        return 0.0 if self.config is None else float(self.config.antenna_height)

    def on_ground(self, radar: jax.Array) -> jax.Array:
        """Radar states ``[..., 6]`` with z on the ground plus the antenna (unchanged when flat)."""
        if self.config is None:
            return radar
        return terrain.on_ground(self.grid, radar, self.config.antenna_height)

    def placement_height(self, xy: jax.Array) -> tuple[jax.Array, jax.Array]:
        """``(z, steep)`` of radars at ``xy [..., 2]``: 0 and False on flat ground; on
        terrain the ground height plus the antenna height, and grade beyond the limit."""
        if self.config is None:
            return jnp.zeros(xy.shape[:-1], xy.dtype), jnp.zeros(xy.shape[:-1], bool)
        z = terrain.height(self.grid, xy) + self.config.antenna_height
        return z, terrain.slope(self.grid, xy) > terrain.max_grade(self.config)

    def too_steep(self, xy: jax.Array, nxt: jax.Array) -> jax.Array:
        """``[N]`` whether radars moving from ``xy [N, 2]`` to ``nxt [N, 2]`` end on
        ground steeper than the limit *and* steeper than where they stand (the truth
        plant's slope stop, :func:`mjx_radar.physics.terrain_follow.slope_stop`); never
        on flat ground."""
        if self.config is None:
            return jnp.zeros(xy.shape[:-1], bool)
        s_now, s_next = terrain.slope(self.grid, xy), terrain.slope(self.grid, nxt)
        return (s_next > terrain.max_grade(self.config)) & (s_next > s_now)

    def targets_above(self, xyz):
        """Drone starts ``[M, >= 3]`` (numpy) with z raised by the ground's height under
        them when the terrain's ``targets_agl`` (unchanged otherwise)."""
        if self.config is None or not self.config.targets_agl:
            return xyz
        from mjx_radar.io.terrain_file import height_np

        xyz[:, 2] += height_np(self.config, xyz[:, :2])
        return xyz

    def occluding(self, occ: occlusion.Occluders | None) -> occlusion.Occluders | None:
        """``occ`` with the ground masking lines of sight too (``occ`` itself when flat)."""
        return occ if self.config is None else occlusion.with_terrain(occ, self.grid)

    def slope_cost(self, xy: jax.Array) -> jax.Array:
        """``α_slope Σ_n relu(|∇h(p_n)| − tan(max_slope))`` over the last axis but one of
        ``xy [..., N, 2]``: the grade beyond the vehicles' limit."""
        grade = terrain.slope(self.grid, xy)  # [..., N]
        return self.config.alpha_slope * jnp.sum(
            jax.nn.relu(grade - terrain.max_grade(self.config)), axis=-1
        )


@dataclasses.dataclass(frozen=True, eq=False)
class StaticObstacles:
    """The static obstacles (``[[obstacles]]``, ``[forest]`` and the map tables).

    Attributes:
        shapes: the obstacles (empty: none).
        cost_grid: the footprints' signed-distance grid of the ``obstacle`` cost term
            (:func:`~mjx_radar.world.obstacles.sdf_grid`), or None when the term is off.
    """

    shapes: tuple[Obstacle, ...] = ()
    cost_grid: Any = None

    @property
    def present(self) -> bool:
        return bool(self.shapes)

    @property
    def occluders(self) -> occlusion.Occluders | None:
        """Their :class:`~mjx_radar.world.occlusion.Occluders` (cached), or None."""
        return occlusion.occluders(self.shapes) if self.shapes else None

    def signed_distance(self, xy: jax.Array) -> jax.Array:
        """``[...]`` the footprints' signed distance at ``xy [..., 2]`` (from the cost grid)."""
        return sdf_mod.sdf(self.cost_grid, xy)


@dataclasses.dataclass(frozen=True, eq=False)
class MovingObstacles:
    """Vehicles on closed-form paths (``[[moving_obstacles]]``; empty: none).

    Attributes:
        vehicles: the :class:`~mjx_radar.scenario.schema.MovingObstacle` tables.
        dt_control: the control period [s] (the planner's horizon steps).
    """

    vehicles: tuple[MovingObstacle, ...] = ()
    dt_control: float = 0.0

    @property
    def present(self) -> bool:
        return bool(self.vehicles)

    def params(self, dtype) -> moving_mod.MovingParams | None:
        """Their runtime :class:`~mjx_radar.world.moving.MovingParams` (None when empty)."""
        return moving_mod.moving_params(self.vehicles, dtype)


@dataclasses.dataclass(frozen=True, eq=False)
class World:
    """The scene's components and the lines of sight of the truth and the planner.

    Attributes:
        ground, obstacles, moving: the components (each empty when absent).
        occluders: what masks the truth's lines of sight: static obstacles and the
            ground (None: nothing does).
        plan_occluders: ``occluders`` if the planner is occlusion-aware (``mpc.los``),
            else None.
        plan_los: whether the planner's line of sight counts (``mpc.los``): the moving
            obstacles mask it too.
    """

    ground: Ground = Ground()
    obstacles: StaticObstacles = StaticObstacles()
    moving: MovingObstacles = MovingObstacles()
    occluders: Any = None
    plan_occluders: Any = None
    plan_los: bool = False


def make_world(
    ground: Terrain | None,
    shapes: tuple[Obstacle, ...],
    vehicles: tuple[MovingObstacle, ...],
    dt_control: float,
    mpc,
    half_width: float,
) -> World:
    """The :class:`World` of a scenario's parts.

    Args:
        ground: the ``[terrain]`` table or None; shapes: the static obstacles;
        vehicles: the moving obstacles; dt_control: the control period [s];
        mpc: the :class:`~mjx_radar.scenario.schema.MPCConfig` (keep-out weight and
            margin, ``los``); half_width: the placement half width [m] (the cost grid's
            extent).
    """
    g = Ground(ground)
    grid = None
    if shapes and mpc.alpha_obs > 0:
        grid = sdf_mod.sdf_grid(shapes, half_width, max(64.0, 4.0 * mpc.obs_margin))
    static = StaticObstacles(shapes, grid)
    occ = g.occluding(static.occluders)
    return World(
        ground=g,
        obstacles=static,
        moving=MovingObstacles(vehicles, dt_control),
        occluders=occ,
        plan_occluders=occ if (occ is not None and mpc.los) else None,
        plan_los=bool(mpc.los),
    )
