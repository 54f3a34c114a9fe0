"""Scenario validation: rules from config metadata, reading errors, plausibility, paths, docs."""

from __future__ import annotations

import dataclasses
import math
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from mjx_radar.io.checks import ScenarioError, choice, flag, rule, table
from mjx_radar.scenario import doc as scenario_doc
from mjx_radar.scenario import plausibility
from mjx_radar.scenario.reader import _read, load_scenario, scenario_from_dict
from mjx_radar.scenario.schema import RadarEquation, Scenario

ROOT = Path(__file__).resolve().parent.parent
GOOD = {"name": "t", "n_radars": 2, "targets": [[0.0, 0.0, 55.0, 20.0, 10.0, 0.0]]}
BUNDLED = [
    "smoke",
    "paper_3r4t",
    "paper_4r4t",
    "paper_6r3t",
    "city_4r4t",
    "forest_4r4t",
    "clutter_3r4t",
    "clutter_spread_3r4t",
    "clutter_apart_3r4t",
    "clutter_az_3r4t",
]


def _err(raw, base=Path(".")) -> str:
    with pytest.raises(ScenarioError) as err:
        scenario_from_dict(raw, base)
    msg = str(err.value)
    assert "\n" not in msg
    return msg


@pytest.mark.parametrize("name", BUNDLED)
def test_bundled_scenarios_stay_valid(name):
    assert load_scenario(ROOT / "scenarios" / f"{name}.toml").name == name


def test_bundled_name_resolves_from_any_folder(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert load_scenario("smoke").name == "smoke"


def test_new_table_needs_only_a_dataclass():
    # A config with a new table and fields is validated without touching scenario.reader.
    @dataclass(frozen=True)
    class Filter:
        q: float = field(default=1.0, metadata=rule(float, 0.0, 10.0, lo_open=True))
        on: bool = field(default=True, metadata=flag())
        kind: str = field(default="ckf", metadata=choice("ckf", "ekf"))

    @dataclass(frozen=True)
    class Outer:
        filt: Filter = field(default_factory=Filter, metadata=table(toml="filter"))

    kw = _read(Outer, {"filter": {"q": 2.5, "kind": "ekf"}}, "")
    assert kw["filt"] == Filter(q=2.5, kind="ekf")
    for raw, needle in [
        ({"filter": {"q": 0.0}}, "filter.q = 0.0: must be a number in (0.0, 10.0]"),
        ({"filter": {"on": 1}}, "filter.on = 1: must be true or false"),
        ({"filter": {"kind": "ukf"}}, "filter.kind = 'ukf': must be one of ckf, ekf"),
        ({"filter": {"x": 1}}, "filter.x: unknown field; allowed: q, on, kind"),
        ({"filter": 3}, "filter: must be a table, got int"),
    ]:
        with pytest.raises(ScenarioError) as err:
            _read(Outer, raw, "")
        assert str(err.value) == needle


def test_every_table_of_scenario_is_read():
    raw = GOOD | {"radar_equation": {"snr_db": -10.0}, "limits": {"speed": 40.0}}
    raw |= {"timing": {"steps": 40}, "mpc": {"gamma": 0.9}, "mppi": {"samples": 50}}
    s = scenario_from_dict(raw)
    assert (s.radar_eq.snr_db, s.limits.speed, s.timing.steps) == (-10.0, 40.0, 40)
    assert (s.mpc.gamma, s.mppi.samples) == (0.9, 50)


def test_reading_errors_are_one_line(tmp_path):
    p = tmp_path / "s.toml"
    p.write_bytes(b'name = "t"\nn_radars = \xff\n')
    with pytest.raises(ScenarioError, match=r"s\.toml: not valid UTF-8 at byte offset 22"):
        load_scenario(p)
    p.write_text('name = "t"\nn_radars = [\nseed = 1\n')
    with pytest.raises(ScenarioError, match=r"s\.toml: malformed TOML .*line"):
        load_scenario(p)
    with pytest.raises(ScenarioError, match="cannot read scenario file"):
        load_scenario(tmp_path / "nope.toml")
    with pytest.raises(ScenarioError, match="cannot read scenario file"):
        load_scenario(tmp_path)  # a folder


def test_non_finite_target_names_column():
    msg = _err(GOOD | {"targets": [[0.0, 0.0, math.inf, 1.0, 1.0, 1.0]]})
    assert msg == "targets[0][2] (z) = inf: must be a number in (0.0, 10000.0]"


def test_coincident_fixed_radars_name_both_not_placement():
    msg = _err(GOOD | {"radars": [[300.0, 0.0, 0.0], [300.0, 0.0, 1.0]]})
    assert "radars[0] and radars[1]" in msg and "placement_half_width" not in msg


def test_target_on_fixed_radar_and_zero_keep_out():
    raw = GOOD | {"targets": [[300.0, 0.0, 0.5, 0, 0, 0]], "mpc": {"r2t": 0.0}}
    msg = _err(raw | {"radars": [[300.0, 0.0, 0.0], [-300.0, 0.0, 0.0]]})
    assert "targets[0] starts 0.5 m from radars[0]" in msg
    assert _err(raw).startswith("mpc.r2t = 0.0: with random radar placement")
    scenario_from_dict(raw | {"mpc": {"r2t": 1.0}})  # random placement keeps 1 m


def test_noise_std_matches_sensing_noise_constant():
    from mjx_radar.estimation.sensor.sensing import noise_constant

    for eq, m in [(RadarEquation(), 4), (RadarEquation(fc=3e9, snr_db=10.0, r_ref=2e3), 3)]:
        s = Scenario(name="t", n_radars=1, target_init=((0, 0, 50, 0, 0, 0),) * m, radar_eq=eq)
        want = math.sqrt(noise_constant(eq, m)) * eq.r_ref**2
        assert plausibility.noise_std_at_r_ref(s) == pytest.approx(want, rel=1e-12)
    assert plausibility.noise_std_at_r_ref(
        Scenario(name="t", n_radars=1, target_init=((0, 0, 50, 0, 0, 0),) * 4)
    ) == pytest.approx(6.7477, abs=1e-4)  # c sqrt(4) / (2 sqrt(2) pi 1e8 10^-1)


def test_noise_constant_bounds():
    assert "range noise std" in _err(GOOD | {"radar_equation": {"snr_db": 150.0}})
    assert "range noise std" in _err(GOOD | {"radar_equation": {"snr_db": -150.0}})
    big = {"power_tx": 1e300, "gain_tx": 1e300}
    assert "radar constant K" in _err(GOOD | {"radar_equation": big})


def test_filter_step_must_resolve_motion():
    raw = GOOD | {"targets": [[0, 0, 55, 300.0, 0, 0]]}
    scenario_from_dict(raw)  # 300 m/s * 0.025 s = 7.5 m per step
    slow = {"dt_filter": 0.5, "dt_control": 0.5, "steps": 10}
    assert "per filter step" in _err(raw | {"timing": slow})


def _mesh_scenario(path: str, external: bool = False) -> dict:
    raw = GOOD | {"radars": [[300.0, 0.0, 0.0], [-300.0, 0.0, 0.0]],
                  "obstacles": [{"kind": "mesh", "path": path}]}  # fmt: skip
    return raw | ({"allow_external_paths": True} if external else {})


def test_mesh_path_policy(tmp_path):
    tower = ROOT / "scenarios" / "meshes" / "tower.obj"
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "t.obj").write_bytes(tower.read_bytes())
    base = tmp_path / "sub"
    assert scenario_from_dict(_mesh_scenario("t.obj"), base).obstacles[0].path == str(
        (base / "t.obj").resolve()
    )
    for given in (str(tower), "../sub/../../x.obj", f"../{tmp_path.name}/sub/t.obj"):
        assert "allow_external_paths = true" in _err(_mesh_scenario(given), base)
    s = scenario_from_dict(_mesh_scenario(str(tower), external=True), base)
    assert s.obstacles[0].path == str(tower)


def test_garbage_binary_stl_names_file(tmp_path):
    (tmp_path / "junk.stl").write_bytes(bytes(range(256)) * 2)
    msg = _err(_mesh_scenario("junk.stl"), tmp_path)
    assert "junk.stl" in msg and "STL" in msg and "charset" not in msg


def test_docs_field_table_in_sync(tmp_path):
    doc = ROOT / "docs" / "scenarios.md"
    copy = tmp_path / "scenarios.md"
    copy.write_text(doc.read_text())
    assert not scenario_doc.sync(copy), "run: python -m mjx_radar.scenario.doc docs/scenarios.md"
    for f in dataclasses.fields(Scenario):
        if f.metadata:
            assert f.metadata.get("toml", f.name) in doc.read_text()


def test_pure_validation_imports_no_jax():
    mods = "('jax', 'mujoco', 'numpy', 'trimesh')"
    code = (
        "import sys; from mjx_radar.scenario.reader import load_scenario; "
        "load_scenario('scenarios/paper_4r4t.toml'); "
        f"print(sorted(m for m in {mods} if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"
