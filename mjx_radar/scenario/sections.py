"""The optional tables of a scenario file, listed once: how each is read and checked.

:func:`mjx_radar.scenario.reader.scenario_from_dict` reads the fields every scenario has
from the schema's metadata, then each optional table of :data:`SECTIONS` in order
(``[[obstacles]]`` and ``[forest]``, the map tables, ``[[target_motion]]``,
``[[radar_override]]``, ``[terrain]``, ``[[moving_obstacles]]``) into the
:class:`~mjx_radar.scenario.schema.Scenario`'s keyword arguments. Once the scenario is
built, :data:`CHECKS` run in order: each table's cross-field check where the table is
set, and the physical plausibility of the whole (:mod:`mjx_radar.scenario.plausibility`).
A new optional table is one reader and one check here, and its module.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any, NamedTuple

from mjx_radar.io.checks import ScenarioError
from mjx_radar.scenario import fleet, maps, motion, moving, obstacles, plausibility, terrain

MAX_ROWS = 1000  # targets / radars rows at most


class Section(NamedTuple):
    """One optional table: its TOML keys and its reader.

    Attributes:
        keys: the top-level TOML keys it reads.
        read: ``read(raw, kwargs, base, external)``: checks ``raw``'s table(s) and sets
            the Scenario's keyword arguments in ``kwargs``; nothing if absent.
    """

    keys: tuple[str, ...]
    read: Callable[[dict, dict, Path, bool], None]


def read_obstacles(raw: dict, kwargs: dict, base: Path, external: bool) -> None:
    """``[[obstacles]]`` and ``[forest]`` (:mod:`mjx_radar.scenario.obstacles`)."""
    found = raw.get("obstacles", [])
    if not isinstance(found, list) or len(found) > 10_000:
        raise ScenarioError("obstacles: must be an array of tables (at most 10000)")
    if found or "forest" in raw:
        kwargs["obstacles"] = tuple(
            obstacles.obstacle(i, o, base, external) for i, o in enumerate(found)
        )
        if "forest" in raw:
            kwargs["obstacles"] += obstacles.forest(raw["forest"], kwargs.get("radar_init", ()))


def read_maps(raw: dict, kwargs: dict, base: Path, external: bool) -> None:
    """``[buildings]`` and ``[occupancy]``, expanded into obstacles (:mod:`.maps`)."""
    if "buildings" in raw or "occupancy" in raw:
        found = kwargs.get("obstacles", ())
        if "buildings" in raw:
            found += maps.buildings(raw["buildings"], base, external)
        if "occupancy" in raw:
            found += maps.occupancy(raw["occupancy"], base, external)
        kwargs["obstacles"] = found


def read_motion(raw: dict, kwargs: dict, base: Path, external: bool) -> None:
    """``[[target_motion]]`` (:mod:`mjx_radar.scenario.motion`)."""
    found = raw.get("target_motion", [])
    if not isinstance(found, list) or len(found) > MAX_ROWS:
        raise ScenarioError(f"target_motion: must be an array of tables (at most {MAX_ROWS})")
    if found:
        m = len(kwargs.get("target_init", ()))
        kwargs["target_motion"] = tuple(
            motion.target_motion(i, t, base, external, m) for i, t in enumerate(found)
        )


def read_fleet(raw: dict, kwargs: dict, base: Path, external: bool) -> None:
    """``[[radar_override]]`` (:mod:`mjx_radar.scenario.fleet`)."""
    found = raw.get("radar_override", [])
    if not isinstance(found, list) or len(found) > MAX_ROWS:
        raise ScenarioError(f"radar_override: must be an array of tables (at most {MAX_ROWS})")
    if found:
        n = kwargs.get("n_radars", 0)
        kwargs["radar_override"] = tuple(fleet.radar_override(i, t, n) for i, t in enumerate(found))


def read_terrain(raw: dict, kwargs: dict, base: Path, external: bool) -> None:
    """``[terrain]`` (:mod:`mjx_radar.scenario.terrain`)."""
    if "terrain" in raw:
        kwargs["terrain"] = terrain.terrain(raw["terrain"], base, external)


def read_moving(raw: dict, kwargs: dict, base: Path, external: bool) -> None:
    """``[[moving_obstacles]]`` (:mod:`mjx_radar.scenario.moving`)."""
    if "moving_obstacles" in raw:
        kwargs["moving_obstacles"] = moving.moving_obstacles(raw["moving_obstacles"])


#: the optional tables in reading order
SECTIONS = (
    Section(("obstacles", "forest"), read_obstacles),
    Section(("buildings", "occupancy"), read_maps),
    Section(("target_motion",), read_motion),
    Section(("radar_override",), read_fleet),
    Section(("terrain",), read_terrain),
    Section(("moving_obstacles",), read_moving),
)

#: the checks of a built scenario in order: ``(field, check)``, run where the field is set
#: (``None``: always)
CHECKS: tuple[tuple[str | None, Callable[[Any], None]], ...] = (
    ("radar_override", fleet.check_fleet),
    ("target_motion", motion.check_motions),
    (None, plausibility.check_scenario),
    ("obstacles", obstacles.check_radar_clearance),
    ("terrain", terrain.check_targets),
    ("moving_obstacles", moving.check_scene),
)


def read_sections(raw: dict, kwargs: dict, base: Path, external: bool) -> None:
    """Every optional table of ``raw`` into ``kwargs``, in :data:`SECTIONS` order."""
    for section in SECTIONS:
        section.read(raw, kwargs, base, external)


def check_sections(scenario) -> None:
    """The :data:`CHECKS` of a built scenario (``ScenarioError`` at the first failure)."""
    for name, check in CHECKS:
        value = None if name is None else getattr(scenario, name)
        if name is None or (value is not None and value != ()):
            check(scenario)
