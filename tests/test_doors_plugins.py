"""The tracker and sensor doors: register_tracker / register_sensor check the plug-in's
contract (mjx_radar.contracts) and a tracker factory's result, in one line naming it."""

from __future__ import annotations

import dataclasses

import pytest

import mjx_radar
from mjx_radar import env as radar_env
from mjx_radar.contracts import PluginError
from mjx_radar.estimation.measurement import MeasurementModel, RangeModel


@pytest.fixture
def cleanup():
    yield
    for name in ("door_t", "door_none", "door_boom"):
        mjx_radar.unregister_tracker(name)
    for name in ("door_s",):
        mjx_radar.unregister_sensor(name)


def test_tracker_registration(cleanup):
    with pytest.raises(TypeError, match="tracker 'door_t': a class or function, not dict"):
        mjx_radar.register_tracker("door_t", {"predict": None})
    with pytest.raises(PluginError, match=r"must take \(task, params\)"):
        mjx_radar.register_tracker("door_t", lambda task: None)
    with pytest.raises(ValueError, match="reserved"):
        mjx_radar.register_tracker("auto", lambda task, params: None)
    with pytest.raises(ValueError, match="a built-in tracker"):
        mjx_radar.register_tracker("JPDA", lambda task, params: None)


def test_a_tracker_factory_returning_none_is_named(cleanup):
    mjx_radar.register_tracker("door_none", lambda task, params: None)
    s = mjx_radar.load_scenario("smoke").replace(filter={"tracker": "door_none"})
    with pytest.raises(PluginError, match="tracker 'door_none': its factory returned NoneType"):
        radar_env.make(s)


def test_a_tracker_factorys_own_exception_is_one_line(cleanup):
    def boom(task, params):
        return task.no_such_field

    mjx_radar.register_tracker("door_boom", boom)
    s = mjx_radar.load_scenario("smoke").replace(filter={"tracker": "door_boom"})
    with pytest.raises(PluginError, match=r"tracker 'door_boom': factory\(\) raised Attr") as err:
        radar_env.make(s)
    assert "test_doors_plugins.py" in err.value.frames


def test_sensor_registration(cleanup):
    @dataclasses.dataclass(frozen=True)
    class Half(MeasurementModel):  # predict only: four methods missing
        name: str = "half"
        dim: int = 1

        def predict(self, radar_pos, target_pos):
            return 0.0

    with pytest.raises(PluginError, match=r"sensor 'door_s': Half has no variance\(\).*missing"):
        mjx_radar.register_sensor("door_s", Half)

    @dataclasses.dataclass(frozen=True)
    class NoDim(RangeModel):
        dim: int = 0

    with pytest.raises(PluginError, match=r"NoDim.dim = 0: must be an integer >= 1"):
        mjx_radar.register_sensor("door_s", NoDim)
    with pytest.raises(TypeError, match="a MeasurementModel subclass"):
        mjx_radar.register_sensor("door_s", int)

    @dataclasses.dataclass(frozen=True)
    class Good(RangeModel):
        name: str = "door_s"

    mjx_radar.register_sensor("Door_S", Good)  # any case
    assert mjx_radar.load_scenario("smoke").replace(measurement={"model": "DOOR_S"})
