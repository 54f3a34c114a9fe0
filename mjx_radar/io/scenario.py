"""Scenario files (TOML): loading and validation.

A scenario file holds every parameter of SPEC: the radar equation, limits, MPPI
and MPC settings, timing, initial targets and the placement box. Optional
tables take the SPEC defaults. Every field is checked for its type and range;
a bad file raises :class:`ScenarioError` whose message is one line naming the
field, the value and the allowed range. Example (``scenarios/smoke.toml``)::

    name = "smoke"
    n_radars = 2
    targets = [[0, 0, 55, 20, 10, 0]]   # rows x y z vx vy vz
    radars = [[300, 0, 3.14], [-300, 0, 0]]  # optional fixed start x y theta
    [timing]
    steps = 40

Without ``radars`` the radars are placed at random per trial (SPEC §3).
Obstacles (docs/obstacles.md): ``[[obstacles]]`` tables (box, cylinder, mesh) and
a generated ``[forest]`` of vertical cylinder trees::

    [forest]
    count = 40                          # trees
    region = [-300, -300, 300, 300]     # xmin ymin xmax ymax of the trunks' centres
    seed = 1                            # tree layout (independent of the trial seed)
    radius = [1.0, 2.5]                 # trunk radius range [m]
    height = [8.0, 20.0]                # tree height range [m]
    spacing = 8.0                       # min gap between trunks [m]
    clearance = 10.0                    # min gap to the fixed radar starts [m]

A scenario with obstacles must fix the radar starts (``radars``), clear of them.
"""

from __future__ import annotations

import dataclasses
import tomllib
from pathlib import Path
from typing import Any

from mjx_radar.config import (
    MPCConfig,
    MPPIConfig,
    RadarEquation,
    RadarLimits,
    Scenario,
    Timing,
)
from mjx_radar.io.checks import INF, NONNEG, POS, ScenarioError, check

# field -> (type, low, high, low_inclusive); bounds in the field's unit.
_RULES: dict[str, dict[str, tuple]] = {
    "": {
        "seed": (int, 0, 2**31 - 1, True),
        "sigma_w2": NONNEG,
        "p0": POS,
        "placement_half_width": POS,
    },
    "radar_equation": {f.name: POS for f in dataclasses.fields(RadarEquation)}
    | {"snr_db": (float, -200.0, 200.0, True)},
    "limits": {f.name: POS for f in dataclasses.fields(RadarLimits)},
    "timing": {
        "dt_filter": POS,
        "dt_control": POS,
        "steps": (int, 1, 10_000_000, True),
    },
    "mpc": {
        "horizon": (int, 1, 1000, True),
        "gamma": (float, 0.0, 1.0, False),
        "r2t": NONNEG,
        "r2r": NONNEG,
        "alpha_r2r": NONNEG,
        "alpha_r2t": NONNEG,
        "alpha_obs": NONNEG,
        "obs_margin": NONNEG,
        "los": (bool,),
        "rollout": (str, ("mjx", "analytic")),
    },
    "mppi": {
        "samples": (int, 2, 1_000_000, True),
        "iterations": (int, 1, 1000, True),
        "std_accel": POS,
        "std_alpha_deg": POS,
        "elite_threshold": (float, 0.0, 1.0, False),
        "temperature": POS,
        "weighting": (str, ("ce", "softmax")),
        "shrinkage": (str, ("ledoit-wolf", "oas", "none")),
    },
}
_TABLES = {
    "radar_equation": RadarEquation,
    "limits": RadarLimits,
    "timing": Timing,
    "mpc": MPCConfig,
    "mppi": MPPIConfig,
}
_TOP = {"name", "description", "n_radars", "targets", "radars", "obstacles", "forest"}
_TOP |= set(_RULES[""])


def _table(name: str, raw: Any) -> Any:
    cls = _TABLES[name]
    if not isinstance(raw, dict):
        raise ScenarioError(f"{name}: must be a table, got {type(raw).__name__}")
    rules = _RULES[name]
    for key in raw:
        if key not in rules:
            raise ScenarioError(f"{name}.{key}: unknown field; allowed: {', '.join(rules)}")
    return cls(**{k: check(f"{name}.{k}", v, rules[k]) for k, v in raw.items()})


def _targets(raw: Any) -> tuple[tuple[float, ...], ...]:
    if not isinstance(raw, list) or not raw:
        raise ScenarioError("targets: must be a non-empty list of [x, y, z, vx, vy, vz] rows")
    return _numeric_rows("targets", raw, "x, y, z, vx, vy, vz")


def _radars(raw: Any, n: int) -> tuple[tuple[float, ...], ...]:
    if not isinstance(raw, list) or len(raw) != n:
        raise ScenarioError(f"radars: must be a list of n_radars = {n} rows [x, y, theta]")
    return _numeric_rows("radars", raw, "x, y, theta")


def _numeric_rows(field: str, raw: list, columns: str) -> tuple[tuple[float, ...], ...]:
    """Rows of finite numbers named by ``columns`` (e.g. ``"x, y, theta"``)."""
    width = len(columns.split(","))
    rows = []
    for i, row in enumerate(raw):
        if not isinstance(row, list) or len(row) != width:
            raise ScenarioError(f"{field}[{i}] = {row!r}: must be {width} numbers [{columns}]")
        rows.append(tuple(check(f"{field}[{i}]", v, (float, -INF, INF, True)) for v in row))
    return tuple(rows)


def scenario_from_dict(raw: dict, base: Path = Path(".")) -> Scenario:
    """Validates a parsed scenario table and builds the :class:`Scenario`."""
    for key in raw:
        if key not in _TOP and key not in _TABLES:
            raise ScenarioError(f"{key}: unknown field")
    for key in ("name", "n_radars", "targets"):
        if key not in raw:
            raise ScenarioError(f"{key}: missing required field")
    name = raw["name"]
    if not isinstance(name, str) or not name or not name.replace("_", "").isalnum():
        raise ScenarioError(f"name = {name!r}: must be a non-empty [A-Za-z0-9_] string")
    kwargs: dict[str, Any] = {
        "name": name,
        "n_radars": check("n_radars", raw["n_radars"], (int, 1, 1000, True)),
        "target_init": _targets(raw["targets"]),
    }
    for key, rule in _RULES[""].items():
        if key in raw:
            kwargs[key] = check(key, raw[key], rule)
    for key in _TABLES:
        if key in raw:
            kwargs[{"radar_equation": "radar_eq"}.get(key, key)] = _table(key, raw[key])
    if "radars" in raw:
        kwargs["radar_init"] = _radars(raw["radars"], kwargs["n_radars"])
    obstacles = raw.get("obstacles", [])
    if not isinstance(obstacles, list):
        raise ScenarioError("obstacles: must be an array of tables")
    from mjx_radar.io import scenario_obstacles as so  # imports this module's helpers

    kwargs["obstacles"] = tuple(so.obstacle(i, o, base) for i, o in enumerate(obstacles))
    if "forest" in raw:
        kwargs["obstacles"] += so.forest(raw["forest"], kwargs.get("radar_init", ()))
    scenario = Scenario(**kwargs)
    _check_consistency(scenario)
    return scenario


def _check_consistency(s: Scenario) -> None:
    from mjx_radar.io import scenario_obstacles

    scenario_obstacles.check_radar_clearance(s)
    t = s.timing
    ratio = t.dt_control / t.dt_filter
    if ratio < 1 - 1e-9 or abs(ratio - round(ratio)) > 1e-6:
        raise ScenarioError(
            f"timing.dt_control = {t.dt_control}: must be an integer multiple (>= 1) of "
            f"timing.dt_filter = {t.dt_filter}"
        )
    if t.steps % t.control_every:
        raise ScenarioError(
            f"timing.steps = {t.steps}: must be a multiple of dt_control/dt_filter = "
            f"{t.control_every}"
        )
    if s.mppi.samples * (1 - s.mppi.elite_threshold) < 1 and s.mppi.weighting == "ce":
        raise ScenarioError(
            f"mppi.elite_threshold = {s.mppi.elite_threshold}: leaves no elite sample out of "
            f"mppi.samples = {s.mppi.samples}; need samples * (1 - threshold) >= 1"
        )


def load_scenario(path: str | Path) -> Scenario:
    """Loads and validates a TOML scenario file.

    Args:
        path: file path, or the bare name of a bundled scenario (``"smoke"``).

    Raises:
        ScenarioError: unreadable file, malformed TOML or any invalid field.
    """
    p = resolve_path(path)
    try:
        raw = tomllib.loads(p.read_text())
    except OSError as err:
        raise ScenarioError(f"{path}: cannot read scenario file ({err.strerror})") from None
    except tomllib.TOMLDecodeError as err:
        raise ScenarioError(f"{path}: malformed TOML ({err})") from None
    return scenario_from_dict(raw, p.parent)


def resolve_path(path: str | Path) -> Path:
    """A file path as given, else ``scenarios/<name>.toml`` of the repository."""
    p = Path(path)
    if p.exists() or p.suffix:
        return p
    bundled = Path(__file__).resolve().parent.parent / "scenarios" / f"{p.name}.toml"
    return bundled if bundled.exists() else p
