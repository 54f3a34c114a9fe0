"""Validation of ``[[target_motion]]`` tables: per-target motion models and presence times.

One table per target that does not fly the paper's constant-velocity model (or that
appears / leaves)::

    [[target_motion]]
    target = 0                      # index of the row in `targets`
    model = "waypoints"             # cv | waypoints | turn | track
    waypoints = [[0, 400, 60], [400, 400, 90]]
    speed = 25.0
    loop = true
    appear = 5.0                    # present for appear <= t < leave

Track CSV paths (``t, x, y, z`` per line, an optional header line) are resolved
relative to the scenario file's folder with the same policy as mesh paths
(:mod:`mjx_radar.scenario.obstacles`: absolute or outside paths need
``allow_external_paths = true``); the rows are read here, once. Every failure is one
:class:`ScenarioError` line naming the field and the allowed values.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any

from mjx_radar.io.checks import Rows, ScenarioError, check, check_table, show
from mjx_radar.scenario.schema import SCENE, Scenario, TargetMotion

MAX_TRACK_ROWS = 1_000_000
MAX_TRACK_SPEED = 1e3  # [m/s] between rows (the initial-speed bound of plausibility)
MIN_TRACK_STEP = 1e-6  # [s] between rows (smaller steps divide positions by ~0: NaN)
_FIELDS = {f.name: f for f in dataclasses.fields(TargetMotion)}
_NEEDS = {  # model -> fields it requires / the only model-specific fields it allows
    "cv": (),
    "waypoints": ("waypoints",),
    "turn": ("rate",),
    "track": ("path",),
}
_SPECIFIC = {
    "waypoints": ("waypoints", "speed", "accel_max", "capture", "loop"),
    "turn": ("rate",),
    "track": ("path",),
}
_ALLOWED = (
    "target",
    "model",
    "waypoints",
    "speed",
    "accel_max",
    "capture",
    "loop",
    "rate",
    "path",
    "sigma_w2",
    "appear",
    "leave",
)


def target_motion(i: int, raw: Any, base: Path, allow_external: bool, m: int) -> TargetMotion:
    """Validates one ``[[target_motion]]`` table (``m`` targets, paths relative to ``base``)."""
    field = f"target_motion[{i}]"
    check_table(field, raw, _ALLOWED)
    if "target" not in raw:
        raise ScenarioError(f"{field}.target: missing required field (a target index)")
    target = check(f"{field}.target", raw["target"], _FIELDS["target"].metadata["rule"])
    if target >= m:
        raise ScenarioError(
            f"{field}.target = {target}: no such target; must be an index in [0, {m - 1}] "
            f"(the scenario has {m} targets rows)"
        )
    model = check(f"{field}.model", raw.get("model", "cv"), _FIELDS["model"].metadata["rule"])
    for key in ("waypoints", "speed", "accel_max", "capture", "loop", "rate", "path"):
        if key in raw and key not in _SPECIFIC.get(model, ()):
            raise ScenarioError(f"{field}.{key}: not a field of model = {model!r}")
    for key in _NEEDS[model]:
        if key not in raw:
            raise ScenarioError(f"{field}.{key}: missing; model = {model!r} needs it")
    kwargs: dict[str, Any] = {"target": target, "model": model}
    for key in ("speed", "accel_max", "capture", "loop", "rate", "sigma_w2", "appear", "leave"):
        if key in raw:
            kwargs[key] = check(f"{field}.{key}", raw[key], _FIELDS[key].metadata["rule"])
    if "waypoints" in raw:
        kwargs["waypoints"] = _waypoints(f"{field}.waypoints", raw["waypoints"])
    if model == "track":
        from mjx_radar.scenario.obstacles import resolve_file

        path = resolve_file(f"{field}.path", raw["path"], base, allow_external, "CSV file")
        kwargs["path"] = path
        kwargs["track"] = read_track(f"{field}.path = {show(raw['path'])}", path)
    if kwargs.get("leave", math.inf) <= kwargs.get("appear", 0.0):
        raise ScenarioError(
            f"{field}.leave = {kwargs['leave']}: must be later than appear = "
            f"{kwargs.get('appear', 0.0)}"
        )
    return TargetMotion(**kwargs)


def _waypoints(field: str, raw: Any) -> tuple[tuple[float, ...], ...]:
    spec: Rows = _FIELDS["waypoints"].metadata["rule"]
    if not isinstance(raw, list) or len(raw) < 2 or len(raw) > 1000:
        raise ScenarioError(f"{field}: must be a list of at least 2 (at most 1000) [x, y, z] rows")
    out = []
    for j, row in enumerate(raw):
        if not isinstance(row, list) or len(row) != 3:
            raise ScenarioError(f"{field}[{j}] = {show(row)}: must be 3 numbers [x, y, z]")
        out.append(
            tuple(
                check(f"{field}[{j}] ({c})", v, r)
                for (c, r), v in zip(spec.columns, row, strict=True)
            )
        )
    return tuple(out)


def read_track(name: str, path: str) -> tuple[tuple[float, ...], ...]:
    """The ``(t, x, y, z)`` rows of a track CSV: >= 2 rows, t[0] = 0, t strictly increasing."""
    try:
        text = Path(path).read_text(encoding="utf-8-sig")  # a byte-order mark is no data
    except (OSError, UnicodeDecodeError) as err:
        raise ScenarioError(f"{name}: cannot read CSV file ({type(err).__name__})") from None
    rows = []
    for n, line in enumerate(text.splitlines(), 1):
        cells = [c.strip() for c in line.split("#")[0].split(",")]
        if cells == [""]:
            continue
        try:
            vals = tuple(float(c) for c in cells)
        except ValueError:
            if not rows and n == 1:  # a header line
                continue
            raise ScenarioError(f"{name}: line {n} is not 4 numbers t, x, y, z") from None
        if len(vals) != 4 or not all(math.isfinite(v) for v in vals):
            raise ScenarioError(f"{name}: line {n} must be 4 finite numbers t, x, y, z")
        t, x, y, z = vals
        if max(abs(x), abs(y)) > SCENE or not 0.0 < z <= 1e4:
            raise ScenarioError(f"{name}: line {n}: |x|, |y| <= {SCENE:g} m and 0 < z <= 1e4 m")
        if rows and t <= rows[-1][0]:
            raise ScenarioError(
                f"{name}: line {n}: times must be strictly increasing (t = {t} after {rows[-1][0]})"
            )
        if rows:
            _check_step(name, n, rows[-1], vals)
        rows.append(vals)
        if len(rows) > MAX_TRACK_ROWS:
            raise ScenarioError(f"{name}: more than {MAX_TRACK_ROWS} rows")
    if len(rows) < 2:
        raise ScenarioError(f"{name}: needs at least 2 rows t, x, y, z")
    if rows[0][0] != 0.0:
        raise ScenarioError(
            f"{name}: the first time must be 0 (the trial's start), got {rows[0][0]}"
        )
    return tuple(rows)


def _check_step(name: str, n: int, prev: tuple, row: tuple) -> None:
    """Refuses a row too soon after the previous one, or one only a > 1 km/s flight reaches."""
    dt = row[0] - prev[0]
    if dt < MIN_TRACK_STEP:
        raise ScenarioError(
            f"{name}: line {n}: time step {dt:.3g} s after t = {prev[0]} is below "
            f"{MIN_TRACK_STEP:g} s"
        )
    speed = math.dist(row[1:], prev[1:]) / dt
    if speed > MAX_TRACK_SPEED:
        raise ScenarioError(
            f"{name}: line {n}: {speed:.3g} m/s from the previous row (t = {prev[0]}); "
            f"a target flies at most {MAX_TRACK_SPEED:g} m/s"
        )


def check_motions(scenario: Scenario) -> None:
    """Cross-table checks: one table per target."""
    seen: set[int] = set()
    for i, tm in enumerate(scenario.target_motion):
        if tm.target in seen:
            raise ScenarioError(
                f"target_motion[{i}].target = {tm.target}: a second table for that target"
            )
        seen.add(tm.target)
    check_present(scenario, scenario.timing.steps, "timing.steps")


def check_present(scenario: Scenario, steps: int, label: str) -> None:
    """Refuses a run of ``steps`` filter steps in which no target is ever present (its
    errors would average over nothing: an RMSE of 0)."""
    if not scenario.target_motion:
        return
    appear = {tm.target: tm.appear for tm in scenario.target_motion}
    end = steps * scenario.timing.dt_filter
    first = min(appear.get(j, 0.0) for j in range(scenario.n_targets))
    if first <= end:  # present from appear until leave (> appear): some step sees it
        return
    raise ScenarioError(
        f"{label} = {steps}: no target is present during the run ({end:g} s; the first "
        f"appears at {first:g} s: target_motion appear); run longer or appear earlier"
    )


def to_dict(tm: TargetMotion) -> dict:
    """The TOML table of one motion (what :func:`target_motion` reads back equal)."""
    if not isinstance(tm, TargetMotion):
        return tm  # not a TargetMotion: target_motion() names the field and refuses it
    raw: dict[str, Any] = {"target": tm.target, "model": tm.model}
    if tm.model == "waypoints":
        raw |= {
            "waypoints": [list(w) for w in tm.waypoints],
            "speed": tm.speed,
            "accel_max": tm.accel_max,
            "capture": tm.capture,
            "loop": tm.loop,
        }
    elif tm.model == "turn":
        raw["rate"] = tm.rate
    elif tm.model == "track":  # a relative path from Python: against the working directory
        raw["path"] = (
            str(Path(tm.path).absolute()) if isinstance(tm.path, str) and tm.path else tm.path
        )
    for key in ("waypoints", "speed", "accel_max", "capture", "loop", "rate", "path"):
        if key not in raw and getattr(tm, key) != _FIELDS[key].default:  # refused by the reader
            raw[key] = list(getattr(tm, key)) if key == "waypoints" else getattr(tm, key)
    raw |= {"sigma_w2": tm.sigma_w2, "appear": tm.appear}
    leave = tm.leave
    if isinstance(leave, bool) or not isinstance(leave, int | float) or math.isfinite(leave):
        raw["leave"] = leave  # never (inf) is the absence of the key; junk: the reader refuses
    return raw
