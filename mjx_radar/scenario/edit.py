"""Scenarios made or changed in Python: validation, nested replace and TOML output.

A :class:`~mjx_radar.scenario.schema.Scenario` built or changed in Python is checked by the
*same* rules, in the same order and with the same one-line messages as a TOML file:
:func:`validate` writes the scenario as the table a TOML file would parse to
(:func:`scenario_to_dict`) and reads it back through
:func:`mjx_radar.scenario.reader.scenario_from_dict`. So ``p0 = -5.0`` set in Python fails
with ``p0 = -5.0: must be a number in [1e-06, 1000000.0]``, exactly as in a file, and
every field path is the TOML one (``radar_equation.snr_db``, ``targets[0][2] (z)``).

:func:`replace` is ``dataclasses.replace`` that also takes nested tables as dicts
(``replace(s, p0=20.0, mpc={"r2t": 150.0})``) and the TOML names of fields
(``targets``, ``radars``, ``radar_equation``), and validates the result.
:func:`to_toml` writes a file that :func:`~mjx_radar.scenario.reader.load_scenario` loads
back equal (every field written, defaults included, so a saved scenario keeps its
meaning if defaults change; mesh paths are absolute, with ``allow_external_paths``).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

from mjx_radar.io.checks import ScenarioError, key_name, show
from mjx_radar.scenario.schema import Scenario

__all__ = ["replace", "scenario_to_dict", "to_toml", "validate"]


def _table(obj: Any) -> dict:
    """A config dataclass as its TOML table (every field that carries a rule or table)."""
    from mjx_radar.scenario.reader import config_fields, toml_name
    from mjx_radar.scenario.sections import plain

    if not dataclasses.is_dataclass(obj):
        return obj  # not a config: scenario_from_dict names the field and refuses it
    out: dict[str, Any] = {}
    for f, _ in config_fields(type(obj)):
        value = getattr(obj, f.name)
        if "table" in f.metadata:
            out[toml_name(f)] = _table(value)
        elif not (f.name == "radar_init" and len(value) == 0):  # optional rows
            out[toml_name(f)] = plain(value)
    return out


def scenario_to_dict(s: Scenario) -> dict:
    """The TOML table of scenario ``s`` (what ``tomllib`` would parse from its file).

    Values are written as given (no checking, no conversion beyond tuples and numpy
    to lists), so that :func:`validate` reports an invalid value as a file would.
    """
    if not isinstance(s, Scenario):
        raise ScenarioError(f"scenario = {show(s)}: must be a mjx_radar.Scenario")
    from mjx_radar.scenario.sections import write_sections

    return _table(s) | write_sections(s)


def sections_by_field() -> dict:
    """The optional sections by the Scenario field they fill
    (:data:`mjx_radar.scenario.sections.BY_FIELD`)."""
    from mjx_radar.scenario.sections import BY_FIELD

    return BY_FIELD


def validate(s: Scenario) -> Scenario:
    """Checks a scenario made in Python by the rules of a TOML file.

    Args:
        s: the scenario.

    Returns:
        The validated scenario (numbers normalised as a file's would be: an ``int``
        given for a float field becomes a ``float``); equal to ``s`` otherwise.

    Raises:
        ScenarioError: one line naming the field path, the value and the allowed range,
            the same message the TOML file of ``s`` would give.

    Example:
        >>> import dataclasses, mjx_radar
        >>> s = mjx_radar.load_scenario("smoke")
        >>> mjx_radar.validate(dataclasses.replace(s, p0=-5.0))
        Traceback (most recent call last):
        ...
        mjx_radar.io.checks.ScenarioError: p0 = -5.0: must be a number in [1e-06, 1000000.0]
    """
    from mjx_radar.scenario.reader import scenario_from_dict

    return scenario_from_dict(scenario_to_dict(s), Path("/"))


def _field_names(cls: type) -> dict[str, dataclasses.Field]:
    """Field name and TOML name -> field, for every field of ``cls``."""
    out = {}
    for f in dataclasses.fields(cls):
        out[f.name] = f
        if "toml" in f.metadata:
            out[f.metadata["toml"]] = f
    return out


def _allowed(obj: Any, prefix: str) -> str:
    """The reader's tail of an unknown-field message: its keys in the file's order (none
    at the top level, as the reader)."""
    from mjx_radar.scenario.reader import config_fields, toml_name

    if not prefix:
        return ""
    names = [toml_name(f) for f, _ in config_fields(type(obj))]
    return "; allowed: " + ", ".join(names or sorted(x.name for x in dataclasses.fields(obj)))


def _merge(obj: Any, changes: dict, prefix: str) -> Any:
    """``obj`` (a config dataclass) with ``changes``; nested dicts merge into tables."""
    names = _field_names(type(obj))
    kwargs = {}
    for key, value in changes.items():
        f = names.get(key)
        if f is None or (f.name not in [x.name for x in dataclasses.fields(obj)]):
            raise ScenarioError(f"{prefix}{key_name(key)}: unknown field{_allowed(obj, prefix)}")
        current, section = getattr(obj, f.name), sections_by_field().get(f.name)
        if isinstance(value, dict) and dataclasses.is_dataclass(current):
            value = _merge(current, value, f"{prefix}{key}.")
        elif section is not None and not section.rows and isinstance(value, dict):
            value = _merge(section.dataclass(), value, f"{prefix}{key}.")  # a new [terrain]
        elif section is not None and section.rows:
            junk = isinstance(value, str | bytes | dict) or not hasattr(value, "__iter__")
            value = () if value is None else value if junk else tuple(value)  # junk: refused
        kwargs[f.name] = value
    return dataclasses.replace(obj, **kwargs)


def replace(s: Scenario, /, **changes: Any) -> Scenario:
    """A validated copy of ``s`` with ``changes``; tables may be given as dicts.

    Args:
        s: the scenario.
        **changes: field -> value. A field is named by its Python name
            (``target_init``, ``radar_eq``) or its TOML name (``targets``,
            ``radar_equation``); a dict for a table field changes only the keys it
            names (``mpc={"r2t": 150.0}``).

    Raises:
        ScenarioError: an unknown field, or the result is invalid (one line naming
            the field path, value and allowed range).

    Example:
        >>> import mjx_radar
        >>> s = mjx_radar.load_scenario("smoke").replace(p0=20.0, mpc={"r2t": 150.0})
        >>> s.p0, s.mpc.r2t
        (20.0, 150.0)
    """
    return validate(_merge(s, changes, ""))


def to_toml(s: Scenario, path: str | Path | None = None) -> str:
    """The TOML text of scenario ``s`` (every field); also written to ``path`` if given.

    ``load_scenario`` of the written file returns a scenario equal to ``s``. Mesh
    paths are absolute (``allow_external_paths = true``); ``mjx-radar run`` and
    :meth:`mjx_radar.Run.save` copy the meshes next to the file they bundle.

    Raises:
        ScenarioError: ``s`` is invalid (checked first).
    """
    from mjx_radar.io.atomic import atomic_write
    from mjx_radar.scenario import bundle

    raw = scenario_to_dict(validate(s))
    body = bundle.dumps(raw)
    text = f"# scenario {s.name}, written by mjx_radar (Scenario.to_toml)\n{body}"
    if path is not None:
        atomic_write(Path(path), lambda tmp: Path(tmp).write_text(text))
    return text
