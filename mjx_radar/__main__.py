"""``python -m mjx_radar`` = ``mjx-radar``."""

import sys

from mjx_radar.cli.main import main

sys.exit(main())
