"""Typed range checks of scenario values, each failure one line naming the field.

A :class:`Rule` states a value's type and allowed range (numbers), ``true``/``false``
(flags), a set of choices (enumerations) or an identifier (names). Rules live next
to the parameters they govern, as field metadata of the config dataclasses::

    snr_db: float = field(default=-20.0, metadata=rule(float, -200, 200, doc="SNR at r_ref"))

and :mod:`mjx_radar.scenario.reader` derives every table's checks from them, so a new
parameter is one edit in :mod:`mjx_radar.scenario.schema`. The helpers :func:`rule`,
:func:`flag`, :func:`choice`, :func:`table` and :func:`rows` build that metadata.
Old-style tuples ``(type, low, high, low_inclusive)``, ``(bool,)`` and
``(str, choices)`` are still accepted by :func:`check`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

INF = math.inf


class ScenarioError(ValueError):
    """A scenario file or value is invalid. ``str(err)`` is one line naming the field."""


class InputError(Exception):
    """Bad user input (an option, a path, a damaged file): one line, exit code 2."""


@dataclass(frozen=True)
class Rule:
    """Allowed values of one scalar field.

    Attributes:
        kind: ``int``, ``float``, ``bool`` or ``str`` (``str`` without ``choices``
            means a non-empty ``[A-Za-z0-9_]`` identifier).
        lo, hi: closed bounds (``lo`` open if ``lo_open``), in the field's unit.
        lo_open: ``lo`` itself is excluded.
        choices: allowed strings of an enumeration.
        registry: a plug-in registry (:mod:`mjx_radar.registry`) whose names are allowed
            too (those registered from scripts at the time of the check).
        doc: one-line description (docs/scenarios.md).
        unit: the unit, e.g. ``"m"`` (``""`` for dimensionless).
    """

    kind: type
    lo: float = -INF
    hi: float = INF
    lo_open: bool = False
    choices: tuple[str, ...] = ()
    doc: str = ""
    unit: str = ""
    registry: Any = None

    def allowed(self) -> tuple[str, ...]:
        """The allowed strings: ``choices`` and the registry's names."""
        extra = tuple(self.registry.names()) if self.registry is not None else ()
        return tuple(dict.fromkeys(self.choices + extra))

    def describe(self) -> str:
        """The allowed values in words, e.g. ``"a number in (0.0, 1.0]"``."""
        if self.kind is bool:
            return "true or false"
        if self.kind is str:
            if self.allowed():
                return f"one of {', '.join(self.allowed())}"
            return "a non-empty [A-Za-z0-9_] string"
        name = {int: "an integer", float: "a number"}[self.kind]
        if self.lo == -INF and self.hi == INF:
            return f"a finite {name.split()[-1]}" if self.kind is float else name
        if self.lo == -INF:
            return f"{name} <= {self.hi}"
        if self.hi == INF:
            return f"{name} {'>' if self.lo_open else '>='} {self.lo}"
        return f"{name} in {'(' if self.lo_open else '['}{self.lo}, {self.hi}]"


@dataclass(frozen=True)
class Rows:
    """A list of numeric rows (``targets``, ``radars``), one :class:`Rule` per column.

    Attributes:
        columns: ``((name, rule), ...)``, e.g. ``(("x", Rule(float, ...)), ...)``.
        count: name of the integer field the number of rows must equal (``""``: any >= 1).
        doc: one-line description.
    """

    columns: tuple[tuple[str, Rule], ...]
    count: str = ""
    doc: str = ""

    @property
    def names(self) -> str:
        return ", ".join(name for name, _ in self.columns)


def runtime(meta: dict) -> dict:
    """Marks a field's metadata as a *runtime* number: it enters the compiled programs as
    an argument (:class:`~mjx_radar.task.params.TaskParams`), so the compiled shape
    (:func:`~mjx_radar.task.params.shape_key`) blanks it and changing it recompiles
    nothing. A table marked so is runtime in every field; rows keep their count."""
    return {**meta, "runtime": True}


def is_runtime(field_: Any) -> bool:
    """Whether a dataclass field is marked :func:`runtime`."""
    return bool(field_.metadata.get("runtime"))


def host(meta: dict) -> dict:
    """Marks a field's metadata as a *host* setting: read on the host after the run (the
    GOSPA cutoff), never an input of a compiled program, so the compiled shape blanks it
    and it is no runtime parameter either."""
    return {**meta, "host": True}


def is_host(field_: Any) -> bool:
    """Whether a dataclass field is marked :func:`host`."""
    return bool(field_.metadata.get("host"))


def _meta(value: Any, toml: str | None, **extra: Any) -> dict:
    return {"rule": value, **({"toml": toml} if toml else {}), **extra}


def rule(
    kind: type,
    lo: float = -INF,
    hi: float = INF,
    *,
    lo_open: bool = False,
    doc: str = "",
    unit: str = "",
    toml: str | None = None,
) -> dict:
    """Field metadata for a number (``kind`` int or float) in ``[lo, hi]`` (``(lo, hi]``)."""
    return _meta(Rule(kind, lo, hi, lo_open, (), doc, unit), toml)


def flag(doc: str = "", toml: str | None = None) -> dict:
    """Field metadata for a boolean."""
    return _meta(Rule(bool, doc=doc), toml)


def choice(*choices: str, doc: str = "", toml: str | None = None, registry: Any = None) -> dict:
    """Field metadata for an enumeration of strings (and a registry's names, if given)."""
    return _meta(Rule(str, choices=tuple(choices), doc=doc, registry=registry), toml)


def name_rule(doc: str = "") -> dict:
    """Field metadata for an identifier string ``[A-Za-z0-9_]+``."""
    return _meta(Rule(str, doc=doc), None)


def table(doc: str = "", toml: str | None = None) -> dict:
    """Field metadata for a nested config dataclass, read from TOML table ``[toml]``."""
    return {"table": doc, **({"toml": toml} if toml else {})}


def rows(
    columns: tuple[tuple[str, Rule], ...],
    *,
    count: str = "",
    doc: str = "",
    toml: str | None = None,
) -> dict:
    """Field metadata for a list of numeric rows (see :class:`Rows`)."""
    return _meta(Rows(columns, count, doc), toml)


def col(lo: float, hi: float, unit: str = "", lo_open: bool = False) -> Rule:
    """A float column rule for :func:`rows`."""
    return Rule(float, lo, hi, lo_open, unit=unit)


def as_rule(rule_: Rule | tuple) -> Rule:
    """A :class:`Rule` from a rule or an old-style tuple."""
    if isinstance(rule_, Rule):
        return rule_
    if rule_[0] is bool:
        return Rule(bool)
    if rule_[0] is str:
        return Rule(str, choices=tuple(rule_[1]))
    typ, lo, hi, incl = rule_
    return Rule(typ, lo, hi, not incl)


POS = Rule(float, 0.0, INF, lo_open=True)
NONNEG = Rule(float, 0.0, INF)
FINITE = Rule(float)


def show(value: Any, limit: int = 60) -> str:
    """``repr(value)`` on one line, cut to ``limit`` characters."""
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def key_name(key: Any) -> str:
    """A table key for a message: as is if short and printable, else its cut ``repr``."""
    ok = isinstance(key, str) and key.isprintable() and 0 < len(key) <= 40
    return key if ok else show(key, 40)


def check_table(field: str, raw: Any, allowed) -> dict:
    """``raw`` if it is a table whose keys are all in ``allowed``, else a one-line
    :class:`ScenarioError` (not a table; the first unknown key and the allowed ones)."""
    if not isinstance(raw, dict):
        raise ScenarioError(f"{field}: must be a table")
    for key in raw:
        if key not in allowed:
            raise ScenarioError(
                f"{field}.{key_name(key)}: unknown field; allowed: {', '.join(allowed)}"
            )
    return raw


def fmt_range(rule_: Rule | tuple) -> str:
    return as_rule(rule_).describe()


def check(field: str, value: Any, rule_: Rule | tuple) -> Any:
    """Returns ``value`` (as the rule's type) or raises a one-line :class:`ScenarioError`."""
    r = as_rule(rule_)
    bad = ScenarioError(f"{field} = {show(value)}: must be {r.describe()}")
    if r.kind is bool:
        if not isinstance(value, bool):
            raise bad
        return value
    if r.kind is str:
        allowed = r.allowed()
        if allowed and isinstance(value, str) and value not in allowed:  # names: any case
            value = {a.lower(): a for a in allowed}.get(value.lower(), value)
        ok = isinstance(value, str) and (
            value in allowed if allowed else bool(value) and value.replace("_", "").isalnum()
        )
        if not ok or (not allowed and not value.isascii()):
            raise bad
        return value
    ok_type = isinstance(value, int | float) and not isinstance(value, bool)
    if r.kind is int:
        ok_type = isinstance(value, int) and not isinstance(value, bool)
    if not ok_type:
        raise bad
    try:
        v = r.kind(value)
    except OverflowError:  # an int too large for a float
        raise bad from None
    if not math.isfinite(v) or v > r.hi or v < r.lo or (v == r.lo and r.lo_open):
        raise bad
    return v


def check_path(field: str, value: Any) -> Any:
    """``value`` if it is a path (``str`` or ``os.PathLike``), else a one-line ScenarioError."""
    import os

    if not isinstance(value, str | os.PathLike):
        raise ScenarioError(
            f"{field} = {show(value)}: must be a file path or a bundled scenario name, "
            f"not {type(value).__name__}"
        )
    return value
