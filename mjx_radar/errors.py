"""Errors that mean "bad user input": the CLI reports them on one line with exit code 2."""

from mjx_radar.io.checks import ScenarioError


class InputError(Exception):
    """Bad user input (an option, a path, a damaged file): one line, exit code 2."""


__all__ = ["InputError", "ScenarioError"]
