"""The scene the figures draw (``viz.scene``): read once from the scenario, checked field by
field against the scenario's own tables (fixed sites, world components, routes, detection)."""

from __future__ import annotations

import dataclasses

import pytest

import mjx_radar
from mjx_radar.scenario.schema import RadarOverride, TargetMotion
from mjx_radar.viz.scene import scene_of


def test_smoke_scene_is_empty_where_the_scenario_is():
    s = mjx_radar.load_scenario("smoke")
    sc = scene_of(s)
    assert (sc.name, sc.n_radars, sc.n_targets) == (s.name, s.n_radars, s.n_targets)
    assert sc.timing is s.timing and sc.r2t == s.mpc.r2t
    assert sc.half_width == s.placement_half_width and sc.radar_init == tuple(s.radar_init)
    assert sc.fixed == (False,) * s.n_radars and sc.target_motion == ()
    assert not (sc.ground.present or sc.obstacles.present or sc.moving.present)
    assert not sc.occluded and not sc.detection_on


@pytest.mark.parametrize("name", ["town_4r4t", "hills_4r4t", "forest_4r4t"])
def test_world_components_hold_the_scenarios_tables(name):
    s = mjx_radar.load_scenario(name)
    sc = scene_of(s)
    assert sc.ground.config is s.terrain and sc.obstacles.shapes == tuple(s.obstacles)
    assert sc.moving.vehicles == tuple(s.moving_obstacles)
    assert sc.moving.dt_control == s.timing.dt_control
    assert sc.obstacles.cost_grid is None  # the figures never need the planner's grid
    occluded = bool(s.obstacles or s.terrain is not None or s.moving_obstacles)
    assert sc.occluded == occluded is True


def test_fleet_routes_and_detection_as_drawn():
    s = mjx_radar.load_scenario("smoke")
    s = s.replace(
        n_radars=3,
        radar_override=(RadarOverride(radar=2, mobile=False), RadarOverride(radar=0)),
        target_motion=(TargetMotion(target=1, appear=1.0),),
        detection=dataclasses.replace(s.detection, model="fixed", fixed_pd=0.9),
    )
    sc = scene_of(s)
    assert sc.fixed == (False, False, True)  # radar 0's override keeps it mobile
    assert sc.target_motion == s.target_motion and sc.target_init == tuple(s.target_init)
    assert sc.detection_on  # a Pd below 1 draws detections
    clutter = dataclasses.replace(s.detection, model="perfect", clutter_density=1e-6)
    per_target = dataclasses.replace(s.filter, structure="per-target")  # PDA: clutter's filter
    assert scene_of(s.replace(detection=clutter, filter=per_target)).detection_on
    every_pair = dataclasses.replace(s.detection, fixed_pd=1.0)  # the paper's program
    assert not scene_of(s.replace(detection=every_pair)).detection_on
