"""Public alias (SPEC §11) of :mod:`mjx_radar.estimation.sensing`: radar equation, ranges."""

from mjx_radar.estimation.sensing import *  # noqa: F403
from mjx_radar.estimation.sensing import __all__  # noqa: F401
