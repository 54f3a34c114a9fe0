"""Errors that mean "bad user input" and the command line's exit codes.

The CLI reports an :class:`InputError` or a ``ScenarioError`` on one line with exit
code 2, before any result file is written.
"""

from mjx_radar.io.checks import InputError, ScenarioError

EXIT_OK = 0  # success
EXIT_FAILURE = 1  # the run failed or some trials diverged (results written, see the line)
EXIT_INPUT = 2  # bad input, an unusable --out or a run too large for the machine
EXIT_INTERRUPTED = 130  # Ctrl-C (128 + SIGINT)


__all__ = [
    "EXIT_FAILURE",
    "EXIT_INPUT",
    "EXIT_INTERRUPTED",
    "EXIT_OK",
    "InputError",
    "ScenarioError",
]
