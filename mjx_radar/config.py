"""Public alias of :mod:`mjx_radar.scenario.schema` (the facade floor).

``from mjx_radar.config import Scenario`` keeps working for users; library code imports
:mod:`mjx_radar.scenario.schema` itself.
"""

from mjx_radar.scenario.schema import *  # noqa: F403
