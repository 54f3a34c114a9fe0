"""Public alias (SPEC §11) of :mod:`mjx_radar.estimation.ckf`: the cubature Kalman filter."""

from mjx_radar.estimation.ckf import *  # noqa: F403
from mjx_radar.estimation.ckf import __all__  # noqa: F401
