"""The ``mjx-radar`` command line (:mod:`mjx_radar.cli.main`, one module per sub-command)."""
