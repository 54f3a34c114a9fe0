"""The scripting API (docs/api.md): validation parity with TOML, round trips, simulate vs CLI."""

from __future__ import annotations

import dataclasses
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

import mjx_radar
from mjx_radar.errors import InputError
from mjx_radar.io.checks import Rows, Rule
from mjx_radar.scenario import bundle
from mjx_radar.scenario.edit import scenario_to_dict
from mjx_radar.scenario.reader import config_fields, load_scenario, toml_name
from mjx_radar.scenario.schema import Scenario

ROOT = Path(__file__).resolve().parents[1]


def _bad_value(r: Rule):
    """A value just outside rule ``r`` (None if every value of its type is allowed)."""
    if r.kind is bool:
        return 1  # an int is not a boolean
    if r.kind is str:
        return "no such choice" if r.choices else "has space"
    if r.hi < math.inf:
        return r.hi * 2 + 1 if r.kind is float else int(r.hi) + 1
    if r.lo > -math.inf:
        return r.lo if r.lo_open else r.lo - 1
    return None


def _leaf_cases(cls=Scenario, path=()):
    """``(attribute path, toml path, bad value)`` for every scalar field with a rule."""
    for f, typ in config_fields(cls):
        if "table" in f.metadata:
            yield from _leaf_cases(typ, (*path, (f.name, toml_name(f))))
        elif isinstance(f.metadata["rule"], Rows):
            for j, (_, r) in enumerate(f.metadata["rule"].columns):
                yield (*path, (f.name, toml_name(f))), j, _bad_value(r)
        else:
            bad = _bad_value(f.metadata["rule"])
            if bad is not None:
                yield (*path, (f.name, toml_name(f))), None, bad


CASES = list(_leaf_cases())


def _set(obj, path, column, value):
    (name, _), *rest = path
    cur = getattr(obj, name)
    if rest:
        return dataclasses.replace(obj, **{name: _set(cur, rest, column, value)})
    if column is not None:  # first row, one column
        rows = cur or ((0.0, 0.0, 0.0),) * obj.n_radars  # radar rows are optional
        row = list(rows[0])
        row[column] = value
        value = (tuple(row), *rows[1:])
    return dataclasses.replace(obj, **{name: value})


def _toml_message(raw: dict, path, column, value, tmp_path: Path) -> str:
    raw = json.loads(json.dumps(raw))
    table = raw
    for _, key in path[:-1]:
        table = table[key]
    key = path[-1][1]
    if column is not None:
        rows = table.get(key) or [[0.0, 0.0, 0.0]] * raw["n_radars"]
        rows[0][column] = value
        value = rows
    table[key] = value
    f = tmp_path / "bad.toml"
    f.write_text(bundle.dumps(raw))
    with pytest.raises(mjx_radar.ScenarioError) as err:
        load_scenario(f)
    return str(err.value)


def test_every_field_is_validated_like_toml(tmp_path):
    """One out-of-range value per field: simulate() refuses it with the file's message."""
    s = load_scenario("smoke")
    raw = scenario_to_dict(s)
    assert len(CASES) > 40
    for path, column, value in CASES:
        expected = _toml_message(raw, path, column, value, tmp_path)
        with pytest.raises(mjx_radar.ScenarioError) as err:
            mjx_radar.simulate(_set(s, path, column, value), trials=1, progress=False)
        assert str(err.value) == expected, (path, column, value)
        assert "\n" not in expected
        leaf = path[-1][1]
        assert leaf in expected, expected


def test_replace_nested_and_toml_names():
    s = load_scenario("smoke")
    t = s.replace(p0=20.0, mpc={"r2t": 150.0}, radar_equation={"snr_db": -10.0})
    assert (t.p0, t.mpc.r2t, t.radar_eq.snr_db) == (20.0, 150.0, -10.0)
    assert t.mpc.horizon == s.mpc.horizon  # untouched keys kept
    rows = s.replace(targets=[[0, 0, 50, 1, 2, 3]]).target_init
    assert rows == ((0.0, 0.0, 50.0, 1.0, 2.0, 3.0),)
    with pytest.raises(mjx_radar.ScenarioError, match=r"^mpc\.bogus: unknown field"):
        s.replace(mpc={"bogus": 1.0})
    with pytest.raises(mjx_radar.ScenarioError, match=r"^p0 = -5\.0: must be a number in"):
        s.replace(p0=-5.0)


@pytest.mark.parametrize("name", ["smoke", "paper_3r4t", "city_4r4t", "forest_4r4t"])
def test_bundled_round_trip(name, tmp_path):
    s = mjx_radar.load_scenario(name)
    path = tmp_path / "s.toml"
    s.to_toml(path)
    assert load_scenario(path) == s
    assert mjx_radar.validate(s) == s


def _numbers(r: Rule):
    lo = r.lo if r.lo > -math.inf else -1e6
    hi = r.hi if r.hi < math.inf else 1e6
    if r.kind is int:
        return st.integers(int(math.ceil(lo)) + r.lo_open, int(min(hi, 10_000)))
    return st.floats(lo, hi, exclude_min=r.lo_open, allow_nan=False, allow_infinity=False)


def _table_strategy(cls):
    fields = {}
    for f, _ in config_fields(cls):
        r = f.metadata.get("rule")
        if isinstance(r, Rule) and r.kind in (int, float):
            fields[f.name] = _numbers(r)
        elif isinstance(r, Rule) and r.kind is bool:
            fields[f.name] = st.booleans()
        elif isinstance(r, Rule) and r.choices:
            fields[f.name] = st.sampled_from(r.choices)
    return st.fixed_dictionaries({}, optional=fields)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    mpc=_table_strategy(mjx_radar.MPCConfig),
    mppi=_table_strategy(mjx_radar.MPPIConfig),
    radar_eq=_table_strategy(mjx_radar.RadarEquation),
    p0=st.floats(1e-6, 1e6),
    sigma_w2=st.floats(0.0, 1e4),
)
def test_round_trip_property(tmp_path_factory, mpc, mppi, radar_eq, p0, sigma_w2):
    """Any valid scenario written by to_toml loads back equal (floats exactly)."""
    s = load_scenario("smoke")
    try:
        s = s.replace(mpc=mpc, mppi=mppi, radar_eq=radar_eq, p0=p0, sigma_w2=sigma_w2)
    except mjx_radar.ScenarioError:
        assume(False)
    path = tmp_path_factory.mktemp("rt") / "s.toml"
    s.to_toml(path)
    assert load_scenario(path) == s


def test_simulate_refuses_bad_arguments():
    for kwargs, pattern in [
        ({"method": "nope"}, r"^method = 'nope': must be one of"),
        ({"trials": 0}, r"^trials = 0: must be a count in"),
        ({"trials": [1.5]}, r"^trials = \[1\.5\]: must be"),
        ({"steps": 3}, r"^steps = 3: must be a multiple of"),
        ({"seed": -1}, r"^seed = -1: must be an integer"),
    ]:
        with pytest.raises(mjx_radar.ScenarioError, match=pattern):
            mjx_radar.simulate("smoke", progress=False, **kwargs)


def test_bundled_scenarios_ship_in_the_package():
    names = mjx_radar.bundled_scenarios()
    assert {"smoke", "paper_3r4t", "paper_4r4t", "paper_6r3t", "city_4r4t", "hills_4r4t"} <= set(
        names
    )
    import tomllib

    text = (ROOT / "pyproject.toml").read_text()
    data = tomllib.loads(text)["tool"]["setuptools"]
    assert data["package-dir"]["mjx_radar.scenarios"] == "scenarios"
    assert "*.toml" in data["package-data"]["mjx_radar.scenarios"]
    assert "meshes/*.obj" in data["package-data"]["mjx_radar.scenarios"]
    assert "terrain/*.png" in data["package-data"]["mjx_radar.scenarios"]


def test_simulate_equals_cli(tmp_path, session_cache):
    """The same scenario, method, seed and trials: identical metrics from both entry points.
    (Analytic planner rollouts: the same comparison, a program that compiles ~3x faster.)"""
    out = tmp_path / "cli"
    cmd = [sys.executable, "-m", "mjx_radar", "run", "smoke", "--trials", "2", "--steps", "16",
           "--seed", "3", "--method", "ccr-sfim", "--out", str(out), "--rollouts", "analytic",
           "--cache-dir", str(session_cache)]  # fmt: skip
    subprocess.run(cmd, check=True, capture_output=True, cwd=tmp_path)
    # this process reads the same persistent cache (tests/conftest.py): the CLI's programs
    run = mjx_radar.simulate("smoke", method="CCR-SFIM", trials=2, steps=16, seed=3,
                             rollouts="analytic", progress=False)  # fmt: skip
    cli = pd.read_parquet(out / "metrics.parquet")
    pd.testing.assert_frame_equal(run.metrics, cli, check_exact=True)
    saved = run.save(tmp_path / "api")
    pd.testing.assert_frame_equal(pd.read_parquet(saved / "metrics.parquet"), cli, check_exact=True)
    with np.load(out / "trajectories.npz") as a, np.load(saved / "trajectories.npz") as b:
        assert sorted(a.files) == sorted(b.files)
        for k in a.files:
            np.testing.assert_array_equal(a[k], b[k], err_msg=k)
    loaded = mjx_radar.Run.load(saved)
    assert loaded.scenario == run.scenario and loaded.method == "ccr-sfim"
    assert loaded.summary()["rmse_pos"] == run.summary()["rmse_pos"]
    ds = loaded.trajectories
    assert ds["estimate"].dims == ("trial", "step", "target", "state")
    assert ds["estimate"].attrs["units"].startswith("m")
    err = ds["estimate"] - ds["truth"]
    rmse = np.sqrt((err.sel(state=["x", "y", "z"]) ** 2).sum("state").mean("target"))
    np.testing.assert_allclose(rmse.values.ravel(), run.metrics["rmse_pos"], rtol=1e-5)
    with pytest.raises(InputError, match="holds a complete run"):
        run.save(saved)
