"""Python and TOML share one validator (issue 36): every bundled scenario's tables, and a
few bad variants of each, give the same verdict and the same one-line message both ways.

The TOML side is the bundled file's own table (``tomllib``) with one value changed, read
by :func:`~mjx_radar.scenario.reader.scenario_from_dict` against the bundled folder (its
relative mesh, map and terrain paths); the Python side is the loaded ``Scenario`` with the
same value set on its dataclass and :func:`mjx_radar.validate`.
"""

from __future__ import annotations

import dataclasses
import tomllib

import pytest

import mjx_radar
from mjx_radar.io.checks import Rule, ScenarioError
from mjx_radar.scenario.reader import (
    bundled_dir,
    bundled_scenarios,
    config_fields,
    scenario_from_dict,
    toml_name,
)

NAMES = bundled_scenarios()
LIST_TABLES = ("obstacles", "target_motion", "radar_override", "moving_obstacles")


def _bad_values(r: Rule) -> list:
    """Out of range (when the rule has a bound or choices) and of the wrong type."""
    out = []
    if r.kind is str and r.choices:
        out.append("no such choice")
    elif r.kind in (int, float) and r.hi < float("inf"):
        out.append(r.hi * 2 + 1 if r.kind is float else int(r.hi) + 1)
    elif r.kind in (int, float) and r.lo > -float("inf"):
        out.append(r.lo if r.lo_open else r.lo - 1)
    out.append({bool: 1, str: 3}.get(r.kind, "abc"))  # an int is not a boolean
    return out


def _leaves(obj, raw_table: dict | None = None):
    """``(field name, toml key, bad value)`` of ``obj``'s scalar fields with a rule (those
    its raw table holds, when given)."""
    for f in dataclasses.fields(obj):
        r = f.metadata.get("rule")
        if not isinstance(r, Rule) or (raw_table is not None and toml_name(f) not in raw_table):
            continue
        for bad in _bad_values(r):
            yield f.name, toml_name(f), bad


def _verdict(fn):
    """``None`` (accepted) or the refusal's message."""
    try:
        fn()
    except ScenarioError as err:
        return str(err)
    return None


def _cases(s, raw):
    """``(label, python scenario, raw table)`` per bad variant of every table of ``s``."""
    for f, _ in config_fields(type(s)):
        if "table" not in f.metadata:
            continue
        key, table = toml_name(f), getattr(s, f.name)
        for name, leaf, bad in _leaves(table):
            t = {**raw.get(key, {}), leaf: bad}
            py = dataclasses.replace(s, **{f.name: dataclasses.replace(table, **{name: bad})})
            yield f"{key}.{leaf}={bad!r}", py, raw | {key: t}
    for attr in LIST_TABLES:
        rows = getattr(s, attr)
        if not rows or not isinstance(raw.get(attr), list):
            continue  # absent, or made from another table ([forest], [buildings])
        for name, leaf, bad in _leaves(rows[0], raw[attr][0]):
            first = dataclasses.replace(rows[0], **{name: bad})
            py = dataclasses.replace(s, **{attr: (first, *rows[1:])})
            yield f"{attr}[0].{leaf}={bad!r}", py, raw | {attr: [{**raw[attr][0], leaf: bad}]}
    if s.terrain is not None and isinstance(raw.get("terrain"), dict):
        for name, leaf, bad in _leaves(s.terrain, raw["terrain"]):
            py = dataclasses.replace(s, terrain=dataclasses.replace(s.terrain, **{name: bad}))
            yield f"terrain.{leaf}={bad!r}", py, raw | {"terrain": {**raw["terrain"], leaf: bad}}


@pytest.mark.parametrize("name", NAMES)
def test_bundled_tables_same_verdict_from_python_and_toml(name):
    path = bundled_dir() / f"{name}.toml"
    raw = tomllib.loads(path.read_text())
    s = mjx_radar.load_scenario(name)
    assert mjx_radar.validate(s) == s == scenario_from_dict(raw, bundled_dir())
    n = 0
    for label, py, bad_raw in _cases(s, raw):
        from_toml = _verdict(lambda r=bad_raw: scenario_from_dict(r, bundled_dir()))
        from_python = _verdict(lambda p=py: mjx_radar.validate(p))
        assert from_python == from_toml, label
        assert from_toml is not None and "\n" not in from_toml, label
        n += 1
    assert n >= 40, n  # every config table, several values each
    for key in ("mpc", "detection"):  # an unknown key of a table
        raw_bad = raw | {key: {**raw.get(key, {}), "bogus": 1.0}}
        from_toml = _verdict(lambda r=raw_bad: scenario_from_dict(r, bundled_dir()))
        from_python = _verdict(lambda k=key: s.replace(**{k: {"bogus": 1.0}}))
        assert from_python == from_toml and from_toml.startswith(f"{key}.bogus"), from_toml
