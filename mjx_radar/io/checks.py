"""Typed range checks of scenario values, each failure one line naming the field.

A rule is ``(type, low, high, low_inclusive)`` for numbers, ``(bool,)`` for flags and
``(str, choices)`` for enumerations; bounds are in the field's unit.
"""

from __future__ import annotations

import math
from typing import Any

INF = math.inf


class ScenarioError(ValueError):
    """A scenario file or value is invalid. ``str(err)`` is one line naming the field."""


POS = (float, 0.0, INF, False)
NONNEG = (float, 0.0, INF, True)


def fmt_range(rule: tuple) -> str:
    typ, lo, hi, incl = rule
    name = {int: "an integer", float: "a number"}[typ]
    left = ">=" if incl else ">"
    if hi == INF:
        return f"{name} {left} {lo}"
    return f"{name} in {'[' if incl else '('}{lo}, {hi}]"


def check(field: str, value: Any, rule: tuple) -> Any:
    if rule[0] is bool:
        if not isinstance(value, bool):
            raise ScenarioError(f"{field} = {value!r}: must be true or false")
        return value
    if rule[0] is str:
        if value not in rule[1]:
            raise ScenarioError(f"{field} = {value!r}: must be one of {', '.join(rule[1])}")
        return value
    typ, lo, hi, incl = rule
    ok_type = isinstance(value, int | float) and not isinstance(value, bool)
    if typ is int:
        ok_type = isinstance(value, int) and not isinstance(value, bool)
    if not ok_type:
        raise ScenarioError(f"{field} = {value!r}: must be {fmt_range(rule)}")
    v = typ(value)
    if not math.isfinite(v) or v > hi or v < lo or (v == lo and not incl):
        raise ScenarioError(f"{field} = {value!r}: must be {fmt_range(rule)}")
    return v
