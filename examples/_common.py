"""Shared command line of the examples: ``--small`` (what CI runs) and ``--out``."""

import argparse
import os
from pathlib import Path


def parse(description: str, name: str) -> argparse.Namespace:
    """``--small`` (or ``MJX_RADAR_SMALL=1``): a tiny, fast version; ``--out`` folder."""
    p = argparse.ArgumentParser(description=description)
    p.add_argument("--small", action="store_true", help="tiny version (CI)")
    p.add_argument("--out", type=Path, default=Path("out") / "examples" / name)
    args = p.parse_args()
    args.small = args.small or os.environ.get("MJX_RADAR_SMALL") == "1"
    args.out.mkdir(parents=True, exist_ok=True)
    return args
