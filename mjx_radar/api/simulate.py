"""``mjx_radar.simulate``: the closed loop from a Python script (``mjx-radar run``'s checks
and compiled program; a fixed seed gives the same numbers from either), as a
:class:`~mjx_radar.api.run.Run`."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from mjx_radar.api.run import Run
from mjx_radar.errors import InputError
from mjx_radar.io.checks import ScenarioError


def trial_ids(trials) -> np.ndarray:
    if isinstance(trials, bool):
        raise ScenarioError(f"trials = {trials!r}: must be a count >= 1 or a list of indices")
    if isinstance(trials, int | np.integer):
        if not 1 <= int(trials) <= 100_000:
            raise ScenarioError(f"trials = {int(trials)}: must be a count in [1, 100000]")
        return np.arange(int(trials))
    ids = np.asarray(trials)
    if ids.ndim != 1 or ids.size == 0 or ids.dtype.kind not in "iu" or (ids < 0).any():
        raise ScenarioError(
            f"trials = {trials!r}: must be a count >= 1 or a non-empty list of indices >= 0"
        )
    return ids.astype(np.int64)


def simulate(
    scenario,
    method: str = "ddr-sfim",
    trials=8,
    steps: int | None = None,
    seed: int | None = None,
    progress: bool = True,
    cache: bool = True,
    view: bool = False,
    view_port: int | None = None,
) -> Run:
    """Runs the closed loop (``mjx-radar run``) and returns the :class:`Run`.

    Args:
        scenario: a :class:`~mjx_radar.Scenario`, a bundled scenario name or a TOML path.
        method: ``"stationary"``, ``"ccr-sfim"``, ``"ccr-pfim"``, ``"ddr-sfim"`` or
            ``"ddr-pfim"`` (case-insensitive).
        trials: a count T (trials ``0..T-1``) or explicit trial indices (common random
            numbers: trial i is the same world for every method).
        steps: filter steps (default the scenario's ``timing.steps``); a multiple of
            ``dt_control / dt_filter``.
        seed: base seed (default the scenario's).
        progress: show a progress bar on stderr.
        cache: use the persistent compilation cache (as the command line does).
        view: a live 3-D view while it simulates (``run --view``, docs/viewer.md): URL on
            stderr; the server stops when this returns (the page keeps the last state).
        view_port: its port on 127.0.0.1 (default 8765; 0: any free one; implies ``view``).

    Returns:
        The run (not saved; :meth:`Run.save` writes it).

    Raises:
        ScenarioError: an invalid scenario, method, trial list, step count or seed (one
            line, the same message a TOML file or the command line gives); nothing is
            compiled.
        InputError: the radars cannot be placed, the run does not fit in memory, or a bad
            or busy ``view_port``.

    Example:
        >>> import mjx_radar
        >>> run = mjx_radar.simulate("smoke", trials=2, steps=40)  # doctest: +SKIP
        >>> run.metrics.groupby("step")["rmse_pos"].mean().tail(1)  # doctest: +SKIP
    """
    from mjx_radar.scenario.edit import validate
    from mjx_radar.scenario.reader import load_scenario
    from mjx_radar.task.method import METHODS

    s = validate(load_scenario(scenario) if isinstance(scenario, str | Path) else scenario)
    name = method.strip().lower() if isinstance(method, str) else method
    if name not in METHODS:
        raise ScenarioError(f"method = {method!r}: must be one of {', '.join(METHODS)}")
    ids = trial_ids(trials)
    steps = s.timing.steps if steps is None else steps
    if isinstance(steps, bool) or not isinstance(steps, int | np.integer) or steps < 1:
        raise ScenarioError(f"steps = {steps!r}: must be an integer >= 1")
    if steps % s.timing.control_every:
        raise ScenarioError(
            f"steps = {steps}: must be a multiple of dt_control/dt_filter = "
            f"{s.timing.control_every} (scenario {s.name})"
        )
    seed = s.seed if seed is None else seed
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or not 0 <= seed < 2**31:
        raise ScenarioError(f"seed = {seed!r}: must be an integer in [0, 2^31 - 1]")
    view = (view or view_port is not None, view_port)
    return run_simulation(s, name, ids, int(steps), int(seed), progress, cache, view)


def run_simulation(
    s,
    method: str,
    ids: np.ndarray,
    steps: int,
    seed: int,
    progress: bool,
    cache: bool,
    view=(False, None),
) -> Run:
    import jax

    from mjx_radar.engine import compile_cache, resources, runner
    from mjx_radar.env.placement import check_placeable
    from mjx_radar.rundir import results
    from mjx_radar.rundir.writer import TRAJECTORY_KEYS, run_meta

    if cache and not compile_cache.enabled():
        compile_cache.enable()
    resources.check(s, len(ids), steps)
    try:
        check_placeable(s, seed, int(ids.max()) + 1)
    except ValueError as err:
        raise InputError(str(err)) from None
    from tqdm import tqdm

    from mjx_radar.viz import live as live_view

    live = live_view.start(s, ids, steps, view[1], "view_port") if view[0] else None
    try:
        with tqdm(
            total=steps, unit="step", desc="closed loop", file=sys.stderr, disable=not progress
        ) as bar:
            res = runner.run_trials(
                s,
                method,
                seed,
                ids,
                steps,
                progress=bar.update,
                phase=bar.set_description_str,
                **({} if live is None else live.runner_options()),
            )
    finally:
        if live is not None:
            live.linger(False)
    time_s = s.timing.dt_filter * np.arange(1, steps + 1)
    frame = results.metrics_frame(s.name, method, ids, time_s, res)
    arrays = {k: np.asarray(res[k]) for k in TRAJECTORY_KEYS if k in res}
    arrays["time_s"] = time_s
    precision = "float64" if jax.config.jax_enable_x64 else "float32"
    meta = run_meta(s, method, seed, ids, steps, res, precision=precision)
    return Run(s, method, seed, ids, steps, frame, arrays, meta, None, res)
