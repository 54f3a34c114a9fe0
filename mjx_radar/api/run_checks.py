"""The checks of a run's options, in the order :func:`mjx_radar.api.run_case.request` runs them.

Each stage checks one group of options and returns what it settles: the scenario with
the options that change it (:func:`scenario_of`: rollouts, association, GOSPA settings),
the method and planner (:func:`method_of`), the steps and the seed
(:func:`steps_and_seed`) and the plain flags (:func:`check_flags`). A failure is one
``ScenarioError`` line naming the option as ``label`` spells it (``--steps`` on the
command line, ``steps`` in Python).
"""

from __future__ import annotations

import dataclasses
import os

import numpy as np

from mjx_radar.io.checks import ScenarioError

PRECISIONS = ("float32", "float64")
ROLLOUTS = ("mjx", "analytic")


def scenario_of(scenario, o: dict, label):
    """The validated scenario with ``rollouts``, ``association`` and the GOSPA options."""
    from mjx_radar.scenario.edit import validate
    from mjx_radar.scenario.reader import load_scenario
    from mjx_radar.scenario.schema import Scenario

    if not isinstance(scenario, str | os.PathLike | Scenario):
        raise ScenarioError(
            f"scenario = {scenario!r:.60}: must be a Scenario, a bundled scenario name or a "
            f"TOML path, not {type(scenario).__name__}"
        )
    s = validate(load_scenario(scenario) if not isinstance(scenario, Scenario) else scenario)
    if o["rollouts"] is not None:
        if o["rollouts"] not in ROLLOUTS:
            raise ScenarioError(
                f"{label('rollouts')} = {o['rollouts']!r}: must be one of mjx, analytic"
            )
        s = dataclasses.replace(s, mpc=dataclasses.replace(s.mpc, rollout=o["rollouts"]))
    if o["association"] is not None:  # the [tracker] table's rules and messages
        try:
            s = s.replace(tracker={"association": o["association"]})
        except ScenarioError as err:
            raise ScenarioError(f"{label('association')}: {err}") from None
    return with_metrics(s, o, label)


def with_metrics(s, o: dict, label):
    """``s`` with the run's GOSPA cutoff / order, checked by the ``[metrics]`` rules."""
    given = {k: o[k] for k in ("gospa_cutoff", "gospa_order") if o[k] is not None}
    try:
        return s.replace(metrics=given) if given else s
    except ScenarioError as err:
        msg = str(err)
        for k in given:
            msg = msg.replace(f"metrics.{k}", label(k))
        raise ScenarioError(msg) from None


def method_of(o: dict, label):
    """The :class:`~mjx_radar.task.method.Method` of ``method`` (any case) and ``planner``."""
    from mjx_radar.planners import PLANNERS
    from mjx_radar.task.method import METHODS, Method, parse_method

    name = o["method"].strip() if isinstance(o["method"], str) else o["method"]
    if isinstance(name, str):
        base, plus, own = name.partition("+")
        name = base.lower() + plus + own
    if not isinstance(name, Method) and (
        not isinstance(name, str) or name.partition("+")[0] not in METHODS
    ):
        raise ScenarioError(
            f"{label('method')} = {o['method']!r}: must be one of {', '.join(METHODS)}"
            " (or METHOD+PLANNER)"
        )
    try:
        method = parse_method(name, o["planner"])
        PLANNERS.get(method.planner)
        PLANNERS.key((method.planner,))  # "policy:DIR": DIR checked before compiling
    except ValueError as err:
        raise ScenarioError(str(err)) from None
    return method


def steps_and_seed(s, o: dict, label) -> tuple[int, int]:
    """``(steps, seed)``: the scenario's unless given; whole control periods, a valid seed."""
    from mjx_radar.scenario.motion import check_present

    steps = s.timing.steps if o["steps"] is None else o["steps"]
    if isinstance(steps, bool) or not isinstance(steps, int | np.integer) or steps < 1:
        raise ScenarioError(f"{label('steps')} = {steps!r}: must be an integer >= 1")
    if steps % s.timing.control_every:
        raise ScenarioError(
            f"{label('steps')} = {steps}: must be a multiple of dt_control/dt_filter = "
            f"{s.timing.control_every} (scenario {s.name})"
        )
    check_present(s, int(steps), label("steps"))
    seed = s.seed if o["seed"] is None else o["seed"]
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or not 0 <= seed < 2**31:
        raise ScenarioError(f"{label('seed')} = {seed!r}: must be an integer in [0, 2^31 - 1]")
    return int(steps), int(seed)


def check_flags(o: dict, label) -> None:
    """``precision``, ``cache``, ``masks`` and ``deterministic``."""
    if o["precision"] not in PRECISIONS:
        raise ScenarioError(
            f"{label('precision')} = {o['precision']!r}: must be one of float32, float64"
        )
    for flag in ("cache", "masks"):
        if not isinstance(o[flag], bool):
            raise ScenarioError(f"{label(flag)} = {o[flag]!r}: must be True or False")
    if o["deterministic"] is not None and not isinstance(o["deterministic"], bool):
        raise ScenarioError(
            f"{label('deterministic')} = {o['deterministic']!r}: must be True, False or None"
        )
