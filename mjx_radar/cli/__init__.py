"""The ``mjx-radar`` command line (see :mod:`mjx_radar.cli.main`)."""

from mjx_radar.cli.main import main

__all__ = ["main"]
