"""Validation of ``[[radar_override]]`` tables: a mixed radar fleet.

One table per radar that differs from the fleet's ``[radar_equation]`` / ``[limits]``,
or that is a fixed site::

    [[radar_override]]
    radar = 0                 # index (0-based) of the radar
    mobile = false            # a fixed site: never moves, the planner draws no controls
    [radar_override.radar_equation]
    power_tx = 20000.0        # any [radar_equation] field; the rest are the fleet's
    gain_tx = 1000.0
    [radar_override.limits]
    accel = 10.0              # accel / alpha at most the fleet's [limits]

Each value is checked by its field's rule in :mod:`mjx_radar.scenario.schema`; the radar's own
range noise is checked for plausibility like the fleet's (:mod:`mjx_radar.scenario.plausibility`).
Per-radar ``speed`` / ``omega`` limits are not supported (the plant's velocity servos
are built with the fleet's): refused with one line. Helpers here resolve a radar's
equation and the per-radar arrays the programs use.
"""

from __future__ import annotations

import dataclasses
from typing import Any

from mjx_radar.io.checks import Rule, ScenarioError, check, check_table, key_name
from mjx_radar.scenario.schema import RadarEquation, RadarLimits, RadarOverride, Scenario

_ALLOWED = ("radar", "mobile", "radar_equation", "limits")
_EQ = {f.name: f.metadata["rule"] for f in dataclasses.fields(RadarEquation)}
_LIM = {f.name: f.metadata["rule"] for f in dataclasses.fields(RadarLimits)}
_LIM_PER_RADAR = ("accel", "alpha")


def radar_override(i: int, raw: Any, n: int) -> RadarOverride:
    """Validates one ``[[radar_override]]`` table of a fleet of ``n`` radars."""
    field = f"radar_override[{i}]"
    check_table(field, raw, _ALLOWED)
    if "radar" not in raw:
        raise ScenarioError(f"{field}.radar: missing required field (a radar index)")
    radar = check(f"{field}.radar", raw["radar"], Rule(int, 0, 999))
    if radar >= n:
        raise ScenarioError(
            f"{field}.radar = {radar}: no such radar; must be an index in "
            f"[0, {n - 1}] (n_radars = {n})"
        )
    mobile = check(f"{field}.mobile", raw.get("mobile", True), Rule(bool))
    eq = _pairs(f"{field}.radar_equation", raw.get("radar_equation", {}), _EQ, tuple(_EQ))
    lim = _pairs(f"{field}.limits", raw.get("limits", {}), _LIM, _LIM_PER_RADAR)
    if lim and not mobile:
        raise ScenarioError(
            f"{field}.limits: a fixed site (mobile = false) never moves; remove its limits"
        )
    return RadarOverride(radar=radar, mobile=mobile, radar_eq=eq, limits=lim)


def _pairs(field: str, raw: Any, rules: dict, allowed: tuple) -> tuple:
    if not isinstance(raw, dict):
        raise ScenarioError(f"{field}: must be a table")
    out = []
    for key, value in raw.items():
        if key in rules and key not in allowed:
            raise ScenarioError(
                f"{field}.{key}: a per-radar {key} limit is not supported "
                f"(only {', '.join(allowed)}); set it in [limits]"
            )
        if key not in rules:
            raise ScenarioError(
                f"{field}.{key_name(key)}: unknown field; allowed: {', '.join(allowed)}"
            )
        out.append((key, check(f"{field}.{key}", value, rules[key])))
    return tuple(sorted(out))


def check_fleet(scenario: Scenario) -> None:
    """Cross checks: one table per radar, limits within the fleet's, plausible noise."""
    from mjx_radar.scenario import plausibility

    seen: set[int] = set()
    for i, ov in enumerate(scenario.radar_override):
        field = f"radar_override[{i}]"
        if ov.radar in seen:
            raise ScenarioError(f"{field}.radar = {ov.radar}: a second table for that radar")
        seen.add(ov.radar)
        for key, value in ov.limits:
            fleet = getattr(scenario.limits, key)
            if value > fleet:
                raise ScenarioError(
                    f"{field}.limits.{key} = {value}: must be <= the fleet's "
                    f"limits.{key} = {fleet} (the plant's bound)"
                )
        if ov.radar_eq:
            try:
                plausibility.check_scenario(
                    dataclasses.replace(scenario, radar_eq=radar_equation(scenario, ov.radar))
                )
            except ScenarioError as err:
                raise ScenarioError(f"{field}.radar_equation: {err}") from None


def to_dict(ov: RadarOverride) -> dict:
    """The TOML table of one override (what :func:`radar_override` reads back equal)."""
    if not isinstance(ov, RadarOverride):
        return ov
    raw: dict[str, Any] = {"radar": ov.radar, "mobile": ov.mobile}
    if ov.radar_eq:
        raw["radar_equation"] = dict(ov.radar_eq)
    if ov.limits:
        raw["limits"] = dict(ov.limits)
    return raw


def radar_equation(scenario: Scenario, radar: int) -> RadarEquation:
    """The radar equation of radar ``radar`` (the fleet's with its overrides)."""
    for ov in scenario.radar_override:
        if ov.radar == radar:
            return dataclasses.replace(scenario.radar_eq, **dict(ov.radar_eq))
    return scenario.radar_eq


def per_radar_noise(scenario: Scenario) -> bool:
    """Whether some radar has its own radar equation (noise constants become [N] arrays)."""
    return any(ov.radar_eq for ov in scenario.radar_override)


def control_bounds(scenario: Scenario) -> tuple[list[float], list[float]]:
    """Per-radar ``|a|`` and ``|alpha|`` bounds ``[N]`` each (0 for fixed sites)."""
    n, lim = scenario.n_radars, scenario.limits
    accel, alpha = [lim.accel] * n, [lim.alpha] * n
    for ov in scenario.radar_override:
        own = dict(ov.limits)
        accel[ov.radar] = own.get("accel", lim.accel) if ov.mobile else 0.0
        alpha[ov.radar] = own.get("alpha", lim.alpha) if ov.mobile else 0.0
    return accel, alpha
