"""Sensors (measurement models) by name: the built-ins and those registered from scripts.

A scenario's ``[measurement] model`` names one (:data:`mjx_radar.registry.SENSORS`):
``"range"`` (the paper's round-trip range) or ``"range-azimuth"`` (monopulse azimuth
too, docs/measurement.md) or a :class:`~mjx_radar.estimation.measurement.MeasurementModel`
subclass given to :func:`register_sensor`. The truth sampler, the trackers, the
planner's information and the PCRLB all go through the model.
"""

from __future__ import annotations

import functools

from mjx_radar.contracts import METHODS
from mjx_radar.estimation.measurement import MeasurementModel, RangeAzimuthModel, RangeModel
from mjx_radar.plugin_errors import guarded_call
from mjx_radar.registry import SENSORS

#: the built-in sensors
MODELS = {"range": RangeModel, "range-azimuth": RangeAzimuthModel}


def register_sensor(name: str, model=None):
    """Registers a sensor: a :class:`MeasurementModel` subclass (usable as a decorator).

    Select it in a scenario with ``[measurement] model = "name"``. Its code is part of
    the program cache key.

    Raises:
        TypeError: ``model`` is not a MeasurementModel subclass.
    """

    def add(cls):
        if not (isinstance(cls, type) and issubclass(cls, MeasurementModel)):
            raise TypeError(f"sensor {name!r}: a MeasurementModel subclass, not {cls!r}")
        return SENSORS.register(name, cls)

    return add if model is None else add(model)


def unregister_sensor(name: str) -> None:
    """Removes a registered sensor (built-ins stay)."""
    SENSORS.unregister(name)


def make_sensor(name: str) -> MeasurementModel:
    """The sensor called ``name``, made (one-line ``ValueError`` for an unknown name).

    A registered sensor is made as its class's :func:`_guarded` subclass: an exception
    of one of its methods while the loop is traced becomes one line naming the sensor
    and the method, with the user's frames (:mod:`mjx_radar.plugin_errors`)."""
    cls = SENSORS.get(name)
    if isinstance(name, str) and name.lower() in SENSORS.registered():
        cls = _guarded(name.lower(), cls)
    return cls()


@functools.cache
def _guarded(name: str, cls: type) -> type:
    """``cls`` with each contract method wrapped by ``guarded_call`` (one class per
    registered class, so equal models, and the programs keyed on them, stay equal)."""

    def method(call):
        def fn(self, *args, **kwargs):
            inner = getattr(super(guarded, self), call)
            return guarded_call("sensor", name, call, inner)(*args, **kwargs)

        return fn

    ns = {call: method(call) for call in METHODS["sensor"]}
    ns.update(__qualname__=cls.__qualname__, __module__=cls.__module__, __doc__=cls.__doc__)
    guarded = type(cls.__name__, (cls,), ns)
    return guarded
