"""A registered sensor that carries its own parameters: an instance of a frozen
MeasurementModel dataclass, selected by name from a scenario, its parameters in the
program cache key, its own exceptions one line (as a registered class's)."""

from __future__ import annotations

import dataclasses

import jax.numpy as jnp
import numpy as np
import pytest

import mjx_radar
from mjx_radar.contracts import PluginError
from mjx_radar.estimation.sensor import sensor_guard
from mjx_radar.estimation.sensor.measurement import RangeModel
from mjx_radar.registry import SENSORS


@dataclasses.dataclass(frozen=True)
class BiasedRange(RangeModel):
    """Round-trip range with a constant bias of its own [m]."""

    name: str = "biased"
    bias_m: float = 0.0

    def predict(self, radar_pos, target_pos):
        return super().predict(radar_pos, target_pos) + self.bias_m


class Loose(RangeModel):  # an instance with a mutable attribute: not hashable
    __hash__ = None


@pytest.fixture
def cleanup():
    yield
    for name in ("biased-2m", "biased-5m", "loose"):
        mjx_radar.unregister_sensor(name)


def test_an_instance_carries_its_parameters(cleanup):
    mjx_radar.register_sensor("biased-2m", BiasedRange(bias_m=2.0))
    mjx_radar.register_sensor("biased-5m", BiasedRange(bias_m=5.0))
    radar = jnp.array([[0.0, 0.0, 0.0]])
    target = jnp.array([[30.0, 40.0, 0.0], [0.0, 0.0, 10.0]])
    want = 2.0 * np.array([50.0, 10.0])  # closed form: round trip of |d|
    for name, bias in (("biased-2m", 2.0), ("biased-5m", 5.0)):
        made = sensor_guard.make(name)
        assert made.bias_m == bias and made == sensor_guard.make(name)  # equal copies
        np.testing.assert_allclose(made.predict(radar, target)[0, :, 0], want + bias)
    keys = dict(SENSORS.key())
    assert keys["biased-2m"] != keys["biased-5m"]  # parameters in the cache key
    s = mjx_radar.load_scenario("smoke").replace(measurement={"model": "biased-5m"})
    assert s.measurement.model == "biased-5m"


def test_instance_contract(cleanup):
    with pytest.raises(PluginError, match="Loose instance is not hashable; make the class"):
        mjx_radar.register_sensor("loose", Loose())
    with pytest.raises(PluginError, match=r"BiasedRange.dim = 0: must be an integer >= 1"):
        mjx_radar.register_sensor("loose", BiasedRange(dim=0))
    with pytest.raises(TypeError, match="a MeasurementModel subclass or instance"):
        mjx_radar.register_sensor("loose", 3.0)


def test_an_instances_own_exception_is_one_line(cleanup):
    mjx_radar.register_sensor("biased-2m", BiasedRange(bias_m="2"))  # str + array
    made = sensor_guard.make("biased-2m")
    with pytest.raises(PluginError, match="sensor 'biased-2m': predict\\(\\) raised TypeError"):
        made.predict(jnp.zeros((1, 3)), jnp.ones((1, 3)))


def test_predict_of_the_wrong_shape_is_refused(cleanup):
    @dataclasses.dataclass(frozen=True)
    class Flat(BiasedRange):  # [N, M] though dim = 1
        def predict(self, radar_pos, target_pos):
            return super().predict(radar_pos, target_pos)[..., 0]

    mjx_radar.register_sensor("biased-2m", Flat())
    made = sensor_guard.make("biased-2m")
    with pytest.raises(PluginError, match=r"returned shape \[2, 3\]; expected \[2, 3, 1\]"):
        made.predict(jnp.zeros((2, 3)), jnp.ones((3, 3)))
