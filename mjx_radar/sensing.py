"""Public alias (SPEC §11) of :mod:`mjx_radar.estimation.sensor.sensing`: radar equation, ranges."""

from mjx_radar.estimation.sensor.sensing import *  # noqa: F403
from mjx_radar.estimation.sensor.sensing import __all__  # noqa: F401
from mjx_radar.precision import pin_module

pin_module(globals(), __all__)  # full float32 dots when called directly (mjx_radar.precision)
