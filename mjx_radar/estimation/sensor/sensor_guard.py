"""A sensor made by name, a registered one wrapped so that its own exceptions read as one line.

:func:`make` is what :func:`mjx_radar.estimation.sensor.measurement.make_model` and
:func:`mjx_radar.estimation.sensor.sensors.make_sensor` call: a built-in sensor is made as is; a
registered one as its class's :func:`guarded` subclass, whose contract methods raise, while
the loop is traced, one line naming the sensor and the method, with the user's frames
(:mod:`mjx_radar.plugin_errors`).
"""

from __future__ import annotations

import copy
import functools

import jax.numpy as jnp

from mjx_radar.contracts import METHODS
from mjx_radar.plugin_errors import guarded_call
from mjx_radar.registry import SENSORS


def make(name: str):
    """The sensor called ``name``, made (one-line ``ValueError`` for an unknown name): a
    registered class made without arguments, or a copy of a registered instance (which
    carries its own parameters), either with its contract methods guarded."""
    obj = SENSORS.get(name)
    if not (isinstance(name, str) and name.lower() in SENSORS.registered()):
        return obj() if isinstance(obj, type) else obj
    if isinstance(obj, type):
        return guarded(name.lower(), obj)()
    made = copy.copy(obj)  # the same parameters, the guarded methods
    object.__setattr__(made, "__class__", guarded(name.lower(), type(obj)))
    return made


@functools.cache
def guarded(name: str, cls: type) -> type:
    """``cls`` with each contract method wrapped by ``guarded_call`` (one class per
    registered class, so equal models, and the programs keyed on them, stay equal)."""

    def method(call):
        def fn(self, *args, **kwargs):
            inner = getattr(super(wrapped, self), call)
            out = guarded_call("sensor", name, call, inner)(*args, **kwargs)
            if call == "predict":
                _check_predict(name, self.dim, *args, out)
            return out

        return fn

    ns = {call: method(call) for call in METHODS["sensor"]}
    ns.update(__qualname__=cls.__qualname__, __module__=cls.__module__, __doc__=cls.__doc__)
    wrapped = type(cls.__name__, (cls,), ns)
    return wrapped


def _check_predict(name: str, dim: int, radar_pos, target_pos, out) -> None:
    """A registered sensor's ``predict`` must return ``[..., N, M, dim]`` (one line if not)."""
    from mjx_radar.contracts import PluginError

    n, m = jnp.shape(radar_pos)[-2], jnp.shape(target_pos)[-2]
    got = tuple(jnp.shape(out))
    if got[-3:] != (n, m, dim):
        want = [*got[:-3], n, m, dim] if len(got) > 3 else [n, m, dim]
        raise PluginError(
            f"sensor {name!r}: predict() returned shape {list(got)}; expected {want} "
            f"([..., N, M, dim] with N = {n} radars, M = {m} targets, dim = {dim})"
        )
