"""Sensors (measurement models) by name: the built-ins and those registered from scripts.

A scenario's ``[measurement] model`` names one (:data:`mjx_radar.registry.SENSORS`):
``"range"`` (the paper's round-trip range) or ``"range-azimuth"`` (monopulse azimuth
too, docs/measurement.md) or a :class:`~mjx_radar.estimation.sensor.measurement.MeasurementModel`
subclass given to :func:`register_sensor`. The truth sampler, the trackers, the
planner's information and the PCRLB all go through the model.
"""

from __future__ import annotations

from mjx_radar.estimation.sensor import sensor_guard
from mjx_radar.estimation.sensor.measurement import MeasurementModel, RangeAzimuthModel, RangeModel
from mjx_radar.registry import SENSORS

#: the built-in sensors
MODELS = {"range": RangeModel, "range-azimuth": RangeAzimuthModel}


def register_sensor(name: str, model=None):
    """Registers a sensor: a :class:`MeasurementModel` subclass (usable as a decorator),
    or an instance of one that carries its own parameters (a frozen dataclass).

    Select it in a scenario with ``[measurement] model = "name"``. Its code, and an
    instance's parameters, are part of the program cache key.

    Example:
        >>> import dataclasses
        >>> @dataclasses.dataclass(frozen=True)
        ... class Ranging(RangeModel):
        ...     bias_m: float = 0.0  # a parameter of the sensor's own
        >>> register_sensor("ranging-2m", Ranging(bias_m=2.0))  # doctest: +SKIP

    Raises:
        TypeError: ``model`` is neither a MeasurementModel subclass nor an instance of one.
    """

    def add(obj):
        is_class = isinstance(obj, type) and issubclass(obj, MeasurementModel)
        if not (is_class or isinstance(obj, MeasurementModel)):
            raise TypeError(
                f"sensor {name!r}: a MeasurementModel subclass or instance, not {obj!r}"
            )
        return SENSORS.register(name, obj)

    return add if model is None else add(model)


def unregister_sensor(name: str) -> None:
    """Removes a registered sensor (built-ins stay)."""
    SENSORS.unregister(name)


def make_sensor(name: str) -> MeasurementModel:
    """The sensor called ``name``, made (one-line ``ValueError`` for an unknown name); a
    registered one raises its own exceptions as one line (:mod:`.sensor_guard`)."""
    return sensor_guard.make(name)
