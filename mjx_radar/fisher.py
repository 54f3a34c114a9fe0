"""Public alias (SPEC §11) of :mod:`mjx_radar.estimation.fisher`: the Fisher information."""

from mjx_radar.estimation.fisher import *  # noqa: F403
from mjx_radar.estimation.fisher import __all__  # noqa: F401
