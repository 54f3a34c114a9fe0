"""``python -m mjx_radar`` = ``mjx-radar``."""

from mjx_radar.cli.main import entry

entry()
