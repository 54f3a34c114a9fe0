"""Argument types and shared checks of the ``mjx-radar`` sub-commands."""

from __future__ import annotations

import argparse

from mjx_radar.scenario.reader import load_scenario, load_with_overrides  # noqa: F401
from mjx_radar.task.method import METHODS


def positive_int(name: str, hi: int = 10**9):
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} = {text!r}: must be an integer") from None
        if not 1 <= value <= hi:
            raise argparse.ArgumentTypeError(f"{name} = {value}: must be in [1, {hi}]")
        return value

    return parse


def method_name(text: str) -> str:
    """The canonical name of a method, case-insensitive (``DDR-SFIM`` -> ``ddr-sfim``).

    Raises:
        argparse.ArgumentTypeError: not a method name (one line listing the names).
    """
    base, plus, planner = text.strip().partition("+")
    name = base.lower()
    if name not in METHODS:
        raise argparse.ArgumentTypeError(f"{text!r} is not one of {', '.join(METHODS)}")
    return f"{name}+{planner}" if plus else name


def method_list(text: str) -> list[str]:
    """Comma-separated method names: canonical, case-insensitive, each once.

    A name given twice (``stationary,stationary``, ``ddr-sfim,DDR-SFIM``) counts once,
    in the order of its first appearance: a study runs every method once.

    Raises:
        argparse.ArgumentTypeError: an unknown name or an empty list.
    """
    methods = [method_name(m) for m in text.split(",") if m.strip()]
    if not methods:
        raise argparse.ArgumentTypeError("empty list")
    return list(dict.fromkeys(methods))


def seed(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"--seed = {text!r}: must be an integer") from None
    if not 0 <= value < 2**31:
        raise argparse.ArgumentTypeError(f"--seed = {value}: must be in [0, 2^31 - 1]")
    return value


def check_placement(scenario, seed: int, trials: int) -> None:
    from mjx_radar.engine.placement_cache import check_placeable  # JAX: only when checking
    from mjx_radar.engine.run_spec import run_spec

    check_placeable(run_spec(scenario), seed, trials)


def linger(text: str) -> float:
    """``--view-linger``: seconds >= 0 the live view stays after the run."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"--view-linger = {text!r}: must be a number") from None
    if not value >= 0 or value == float("inf"):
        raise argparse.ArgumentTypeError(f"--view-linger = {value}: must be finite and >= 0")
    return value


def port(text: str) -> int:
    """``--view-port``: a TCP port in [0, 65535] (0: any free port)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"--view-port = {text!r}: must be an integer") from None
    if not 0 <= value <= 65535:
        raise argparse.ArgumentTypeError(f"--view-port = {value}: must be in [0, 65535]")
    return value
