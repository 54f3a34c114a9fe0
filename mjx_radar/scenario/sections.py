"""The optional tables of a scenario file, listed once: read, checked, written, documented.

Every optional table is one :class:`Section` of :data:`SECTIONS` (``[[obstacles]]`` and
``[forest]``, the map tables, ``[[radar_override]]``, ``[[target_motion]]``,
``[terrain]``, ``[[moving_obstacles]]``), iterated in that order by the reader
(:func:`read_sections` fills the :class:`~mjx_radar.scenario.schema.Scenario`'s keyword
arguments; :func:`check_sections` runs each set section's cross-field check, those
marked ``first`` before the plausibility of the whole, :mod:`.plausibility`), by
:mod:`mjx_radar.scenario.edit` (:func:`write_sections` gives the TOML tables back;
``replace`` merges a dict given for a table into its ``dataclass``) and by the
reference generator :mod:`mjx_radar.scenario.doc` (each section's ``title``). A new
optional table is one :class:`Section` here and its module.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path
from typing import Any, NamedTuple

from mjx_radar.io.checks import ScenarioError, show
from mjx_radar.scenario import fleet, maps, motion, moving, obstacles, plausibility, terrain
from mjx_radar.scenario.schema import MovingObstacle, Obstacle, RadarOverride, TargetMotion
from mjx_radar.scenario.schema import Terrain as TerrainTable

MAX_ROWS = 1000  # targets / radars rows at most


class Section(NamedTuple):
    """One optional table.

    Attributes:
        keys: the top-level TOML keys it reads.
        field: the :class:`~mjx_radar.scenario.schema.Scenario` field it fills.
        dataclass: the type of its rows (``rows``) or of its table.
        read: ``read(raw, kwargs, base, external)``: checks ``raw``'s table(s) and sets
            the Scenario's keyword arguments in ``kwargs``; nothing if absent.
        check: ``check(scenario)``: its cross-field rules, run where the field is set
            (None: none).
        write: ``write(value) -> dict``: the TOML keys of the field's value (``{}`` when
            empty; paths absolute), for a scenario made in Python (None: another section
            writes the field).
        rows: an array of tables (``[[key]]``: a tuple field), else one table.
        first: its check runs before the plausibility of the whole (which uses it).
        title: the heading of its field table in ``docs/scenarios.md`` (None: none there).
        doc_rows: rows of that table for keys that are no dataclass field (``path``).
    """

    keys: tuple[str, ...]
    field: str
    dataclass: type
    read: Callable[[dict, dict, Path, bool], None]
    check: Callable[[Any], None] | None = None
    write: Callable[[Any], dict] | None = None
    rows: bool = True
    first: bool = False
    title: str | None = None
    doc_rows: tuple[str, ...] = ()


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


def plain(value: Any) -> Any:
    """``value`` with tuples / numpy arrays as lists and numpy scalars as Python scalars."""
    if hasattr(value, "tolist") and not isinstance(value, str):  # numpy arrays and scalars
        return value.tolist()
    if isinstance(value, tuple | list):
        return [plain(v) for v in value]
    return value


def obstacle_dict(o: Any) -> Any:
    """One ``[[obstacles]]`` row of an :class:`~mjx_radar.scenario.schema.Obstacle` (else
    ``o`` as given: the reader refuses it)."""
    if not isinstance(o, Obstacle):
        return o
    raw: dict[str, Any] = {"kind": o.kind, "pos": plain(o.pos)}
    if o.kind == "mesh":
        raw |= {"path": o.path, "scale": plain(o.scale)}
    else:
        raw["size"] = plain(o.size)
    raw["yaw"] = plain(o.yaw)
    return raw


def terrain_dict(t: Any) -> Any:
    """The ``[terrain]`` table of a :class:`~mjx_radar.scenario.schema.Terrain` or a dict
    (path made absolute against the working directory, as Python callers give it)."""
    raw = t
    if isinstance(t, TerrainTable):
        raw = {"path": t.path}
        for f in dataclasses.fields(t):
            if "rule" in f.metadata:
                raw[f.metadata.get("toml", f.name)] = plain(getattr(t, f.name))
    if isinstance(raw, dict) and isinstance(raw.get("path"), str) and raw["path"]:
        raw = {**raw, "path": str(Path(raw["path"]).absolute())}
    return raw


def rows_of(name: str, value: Any, kind: str) -> tuple:
    """``value`` of a row section as given (a tuple or list), else one line naming it."""
    if not isinstance(value, tuple | list):
        raise ScenarioError(f"{name} = {show(value)}: must be a tuple of {kind}")
    return tuple(value)


def write_obstacles(value: Any) -> dict:
    """``[[obstacles]]`` rows (mesh paths are absolute in a Scenario)."""
    found = rows_of("obstacles", value, "Obstacle")
    if not found:
        return {}
    raw: dict[str, Any] = {"obstacles": [obstacle_dict(o) for o in found]}
    if any(isinstance(o, Obstacle) and o.kind == "mesh" for o in found):
        raw["allow_external_paths"] = True
    return raw


def write_fleet(value: Any) -> dict:
    """``[[radar_override]]`` rows."""
    found = rows_of("radar_override", value, "RadarOverride")
    return {"radar_override": [fleet.to_dict(o) for o in found]} if found else {}


def write_motion(value: Any) -> dict:
    """``[[target_motion]]`` rows (track paths are absolute in a Scenario)."""
    found = rows_of("target_motion", value, "TargetMotion")
    if not found:
        return {}
    raw: dict[str, Any] = {"target_motion": [motion.to_dict(t) for t in found]}
    if any(getattr(t, "model", "") == "track" for t in found):
        raw["allow_external_paths"] = True
    return raw


def write_terrain(value: Any) -> dict:
    """The ``[terrain]`` table (its height-field path made absolute)."""
    if value is None:
        return {}
    return {"terrain": terrain_dict(value), "allow_external_paths": True}


def write_moving(value: Any) -> dict:
    """``[[moving_obstacles]]`` rows (anything else as given: the reader refuses it)."""
    if not value:
        return {}
    found = [moving.to_dict(m) for m in value] if isinstance(value, tuple | list) else value
    return {"moving_obstacles": found}


#: the optional tables in reading order
SECTIONS = (
    Section(
        ("obstacles", "forest"),
        "obstacles",
        Obstacle,
        read_obstacles,
        obstacles.check_radar_clearance,
        write_obstacles,
    ),
    Section(("buildings", "occupancy"), "obstacles", Obstacle, read_maps),
    Section(
        ("radar_override",),
        "radar_override",
        RadarOverride,
        read_fleet,
        fleet.check_fleet,
        write_fleet,
        first=True,
        title="### `[[radar_override]]` — one radar of a mixed fleet (sub-tables "
        "`radar_equation`: any `[radar_equation]` field; `limits`: `accel`, `alpha`)",
    ),
    Section(
        ("target_motion",),
        "target_motion",
        TargetMotion,
        read_motion,
        motion.check_motions,
        write_motion,
        first=True,
        title="### `[[target_motion]]` — per-target motion and presence (one table per "
        "target; `path`: a CSV of `t, x, y, z`)",
    ),
    Section(
        ("terrain",),
        "terrain",
        TerrainTable,
        read_terrain,
        terrain.check_targets,
        write_terrain,
        rows=False,
        title="### `[terrain]` — height field the radars drive on (docs/terrain.md)",
        doc_rows=(
            "| `path` | required | - | an existing .npy or .png file, relative to "
            "the scenario file | height field (float/integer array, or grayscale PNG) |",
        ),
    ),
    Section(
        ("moving_obstacles",),
        "moving_obstacles",
        MovingObstacle,
        read_moving,
        moving.check_scene,
        write_moving,
        title="### `[[moving_obstacles]]` — a vehicle on a path (docs/maps.md; `size`: "
        "box `[half length, half width]`, cylinder `[radius]`)",
    ),
)
#: the section filling each Scenario field (the first, where two fill one)
BY_FIELD = {s.field: s for s in reversed(SECTIONS)}


def read_sections(raw: dict, kwargs: dict, base: Path, external: bool) -> None:
    """Every optional table of ``raw`` into ``kwargs``, in :data:`SECTIONS` order."""
    for section in SECTIONS:
        section.read(raw, kwargs, base, external)


def check_sections(scenario) -> None:
    """The checks of a built scenario (``ScenarioError`` at the first failure): those of
    the set sections marked ``first``, the plausibility of the whole, the others."""
    checked = [s for s in SECTIONS if s.check is not None]
    for section in [s for s in checked if s.first]:
        _check(section, scenario)
    plausibility.check_scenario(scenario)
    for section in [s for s in checked if not s.first]:
        _check(section, scenario)


def _check(section: Section, scenario) -> None:
    value = getattr(scenario, section.field)
    if value is not None and value != ():
        section.check(scenario)


def write_sections(scenario) -> dict:
    """The TOML tables of a scenario's optional sections, in :data:`SECTIONS` order."""
    raw: dict[str, Any] = {}
    for section in SECTIONS:
        if section.write is not None:
            raw |= section.write(getattr(scenario, section.field, None))
    return raw
