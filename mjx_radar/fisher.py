"""Public alias (SPEC §11) of :mod:`mjx_radar.estimation.information.fisher`: the Fisher
information."""

from mjx_radar.estimation.information.fisher import *  # noqa: F403
from mjx_radar.estimation.information.fisher import __all__  # noqa: F401
from mjx_radar.precision import pin_module

pin_module(globals(), __all__)  # full float32 dots when called directly (mjx_radar.precision)
