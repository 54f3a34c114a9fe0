"""Older input corpora's last cases: refused in one line, with no warning printed."""

from __future__ import annotations

import warnings

import pytest

import mjx_radar
from mjx_radar import ScenarioError

SCENE = """name = "t"
n_radars = 2
targets = [[0, 0, 55, 20, 10, 0]]
radars = [[300, 0, 0], [-300, 0, 0]]
"""


def _refused(path, message):
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a RuntimeWarning fails the test
        with pytest.raises(ScenarioError, match=message) as err:
            mjx_radar.validate(mjx_radar.load_scenario(path))
    assert "\n" not in str(err.value)


def test_a_nan_geojson_coordinate(tmp_path):
    (tmp_path / "nan.geojson").write_text(
        '{"type":"FeatureCollection","features":[{"type":"Feature","properties":'
        '{"height":10},"geometry":{"type":"Polygon","coordinates":'
        "[[[0,0],[NaN,0],[10,10],[0,10],[0,0]]]}}]}"
    )
    f = tmp_path / "b.toml"
    f.write_text(SCENE + '[buildings]\npath = "nan.geojson"\ncrs = "local"\n')
    _refused(f, "feature 0: empty or non-finite coordinates")


def test_a_moving_loop_repeating_its_first_point(tmp_path):
    f = tmp_path / "m.toml"
    f.write_text(
        SCENE + '[[moving_obstacles]]\nkind = "box"\nsize = [2.5, 1.0]\n'
        "path = [[-200, -200], [200, -200], [200, 200], [-200, -200]]\nspeed = 8.0\n"
    )
    _refused(f, r"moving_obstacles\[0\].path\[3\] = \[-200.0, -200.0\]: repeats path\[0\]")
    f.write_text(f.read_text() + 'end = "stop"\n')  # a path that stops may come back
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert mjx_radar.load_scenario(f).moving_obstacles[0].end == "stop"
