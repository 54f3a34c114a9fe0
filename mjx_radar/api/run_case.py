"""The one run use case under ``mjx-radar run`` and ``mjx_radar.simulate``.

Both take the same options with the same defaults (:data:`RUN_DEFAULTS`), checked by
the same code (:func:`request`, its stages in :mod:`mjx_radar.api.run_checks`: one line
naming the option and its allowed range, a ``ScenarioError``, before anything is
compiled), and run through the same
:func:`execute` (compilation cache, precision, memory check, then the runner, whose
trials' initial conditions refuse radars that cannot be placed before the first step).
The command line adds only what belongs to a terminal (``--out``, ``--force``,
``--video``, ``--keep-diverged``, Ctrl-C); the API returns a :class:`~mjx_radar.api.run.Run`.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import os
import runpy
from pathlib import Path

import numpy as np

from mjx_radar.api import run_checks as checks
from mjx_radar.io.checks import InputError, ScenarioError

#: every option of a run and its default, for the command line and the API alike
RUN_DEFAULTS = {
    "method": "ddr-sfim",
    "planner": None,
    "trials": 1,
    "steps": None,
    "seed": None,
    "rollouts": None,
    "association": None,
    "precision": "float32",
    "deterministic": None,  # None: on where a GPU backend may start (engine.determinism)
    "cache": True,
    "cache_dir": None,
    "plugins": (),
    "gospa_cutoff": None,  # None: the scenario's [metrics] (docs/tracking_metrics.md)
    "gospa_order": None,
    "masks": False,
}
MAX_TRIALS = 100_000


@dataclasses.dataclass(frozen=True)
class RunRequest:
    """A checked run: the scenario (``rollouts`` applied), method, trials, steps, seed."""

    scenario: object
    method: object  # mjx_radar.task.method.Method
    trials: np.ndarray
    steps: int
    seed: int
    precision: str = "float32"
    deterministic: bool | None = None
    cache: bool = True
    cache_dir: str | None = None
    masks: bool = False

    @functools.cached_property
    def spec(self):
        """The scenario as the engine takes it (:class:`~mjx_radar.engine.run_spec.RunSpec`),
        read once."""
        from mjx_radar.engine.run_spec import run_spec

        return run_spec(self.scenario)


def run_header(scenario):
    """What a run directory records of ``scenario``
    (:class:`~mjx_radar.rundir.writer.RunHeader`), read once for its writer."""
    from mjx_radar.estimation.sensor.sensing import noise_constant
    from mjx_radar.rundir.writer import RunHeader

    s, each = scenario, None
    if any(ov.radar_eq for ov in s.radar_override):  # a mixed fleet: C of each radar
        from mjx_radar.scenario.fleet import radar_equation

        each = tuple(noise_constant(radar_equation(s, i), s.n_targets) for i in range(s.n_radars))
    return RunHeader(
        name=s.name,
        dt_filter=s.timing.dt_filter,
        dt_control=s.timing.dt_control,
        n_radars=s.n_radars,
        n_targets=s.n_targets,
        r2t=s.mpc.r2t,
        r2r=s.mpc.r2r,
        rollout=s.mpc.rollout,
        noise_constant=noise_constant(s.radar_eq, s.n_targets),
        noise_constants=each,
        gospa_cutoff=s.metrics.gospa_cutoff,
        gospa_order=s.metrics.gospa_order,
    )


def load_plugins(paths) -> None:
    """Runs each plug-in file (a script that registers planners, cost terms, ...).

    Raises:
        ScenarioError: a missing file, or one that raises (one line naming it).
    """
    if isinstance(paths, str | os.PathLike):  # one file given as a string: one item
        paths = [paths]
    for path in paths or ():
        if not isinstance(path, str | os.PathLike):
            raise ScenarioError(
                f"plugin = {path!r}: must be a file path, not {type(path).__name__}"
            )
        p = Path(path)
        if not p.is_file():
            what = "a folder, not a Python file" if p.is_dir() else "no such file"
            raise ScenarioError(f"plugin = {str(path)!r}: {what}")
        try:
            runpy.run_path(str(p), run_name=f"mjx_radar_plugin_{p.stem}")
        except SystemExit as err:  # the file ends the process: refused, nothing is run
            raise ScenarioError(
                f"plugin = {str(path)!r}: called sys.exit({err.code!r}); a plug-in file only "
                "registers plug-ins"
            ) from None
        except InputError as err:  # a plug-in refused at registration: its own line
            raise ScenarioError(f"plugin = {str(path)!r}: {err}") from None
        except Exception as err:  # noqa: BLE001 -- a user's file: one line, no traceback
            raise ScenarioError(f"plugin = {str(path)!r}: {type(err).__name__}: {err}") from None


def trial_ids(trials) -> np.ndarray:
    """``[T]`` trial indices of a count (``0..T-1``) or an explicit list."""
    if isinstance(trials, bool):
        raise ScenarioError(f"trials = {trials!r}: must be a count >= 1 or a list of indices")
    if isinstance(trials, int | np.integer):
        if not 1 <= int(trials) <= MAX_TRIALS:
            raise ScenarioError(f"trials = {int(trials)}: must be a count in [1, {MAX_TRIALS}]")
        return np.arange(int(trials))
    ids = np.asarray(trials)
    if ids.ndim != 1 or ids.size == 0 or ids.dtype.kind not in "iu" or (ids < 0).any():
        raise ScenarioError(
            f"trials = {trials!r}: must be a count >= 1 or a non-empty list of indices >= 0"
        )
    if ids.max() >= 2**31:
        raise ScenarioError(f"trials: index {int(ids.max())} must be < 2^31")
    return ids.astype(np.int64)


def request(scenario, *, cli: bool = False, **options) -> RunRequest:
    """Checks a run's options (:data:`RUN_DEFAULTS` for those not given).

    Args:
        scenario: a :class:`~mjx_radar.Scenario`, a bundled scenario name or a TOML path.
        cli: name the options in messages as the command line does (``--steps``).
        **options: ``method``, ``planner``, ``trials``, ``steps``, ``seed``, ``rollouts``,
            ``association`` (``[tracker] association``: pda, jpda, gnn, mht), ``precision``,
            ``deterministic``, ``cache``, ``cache_dir``, ``plugins``, ``masks``,
            ``gospa_cutoff``, ``gospa_order`` (override the scenario's ``[metrics]``).

    Raises:
        ScenarioError: one line naming the option and its allowed values.
    """
    unknown = sorted(set(options) - set(RUN_DEFAULTS))
    if unknown:
        raise ScenarioError(f"{unknown[0]}: not an option of a run ({', '.join(RUN_DEFAULTS)})")
    o = {**RUN_DEFAULTS, **options}

    def label(name: str) -> str:
        return f"--{name.replace('_', '-')}" if cli else name

    load_plugins(o["plugins"])
    s = checks.scenario_of(scenario, o, label)
    method = checks.method_of(o, label)
    ids = trial_ids(o["trials"])
    steps, seed = checks.steps_and_seed(s, o, label)
    checks.check_flags(o, label)
    cache_dir = None if o["cache_dir"] is None else str(o["cache_dir"])
    return RunRequest(
        s,
        method,
        ids,
        steps,
        seed,
        o["precision"],
        o["deterministic"],
        o["cache"],
        cache_dir,
        o["masks"],
    )


def process_options(req: RunRequest) -> bool:
    """The process-wide settings a run asks for: deterministic GPU kernels (XLA's flag must
    be set before JAX starts its backend: :mod:`mjx_radar.engine.determinism`) and the
    persistent compilation cache. Returns whether the kernels are deterministic."""
    from mjx_radar.engine import compile_cache, determinism

    deterministic = determinism.apply(req.deterministic)  # before anything starts JAX
    if req.cache and not compile_cache.enabled():
        compile_cache.enable(req.cache_dir)
    return deterministic


def precision_scope(req: RunRequest):
    """A context in which the run is traced at its precision (float64: x64 mode)."""
    import jax

    if req.precision == "float64" and not jax.config.jax_enable_x64:
        return jax.enable_x64(True)
    return contextlib.nullcontext()


def start_programs(req: RunRequest, live=None):
    """The run's programs, compiled or loaded in a background thread from now on
    (:func:`mjx_radar.engine.runner.start_programs`) while the caller imports the
    writers; pass them to :func:`execute`. Call it after the process-wide
    settings (:func:`process_options`, or the command line's own)."""
    from mjx_radar.engine import runner

    with precision_scope(req):  # the background thread traces in the run's x64 mode
        periods = None if live is None else live.runner_options()["periods"]
        args = (req.spec, req.method, req.trials, req.steps)
        return runner.start_programs(*args, periods=periods, masks=req.masks)


def execute(
    req: RunRequest, progress=None, phase=None, live=None, checks: bool = True, programs=None
) -> dict:
    """Checks memory (unless ``checks`` is False: the caller did), then runs the trials
    (:func:`runner.run_trials`, which refuses radars that cannot be placed before the
    first step, from the trials' own initial conditions). The programs (``programs``,
    from :func:`start_programs`, or started here after the memory check) are compiled
    or loaded in the background.

    Raises:
        InputError: the radars cannot be placed or the run does not fit in memory.
        PluginError: a registered planner returned NaN or inf controls.
    """
    from mjx_radar.engine import resources, runner
    from mjx_radar.planners import guard

    deterministic = process_options(req)
    with precision_scope(req):
        if checks:
            resources.check(req.spec, len(req.trials), req.steps, kind=req.method.kind)
        programs = programs or start_programs(req, live)
        view = {} if live is None else live.runner_options()
        res = runner.run_trials(
            req.spec,
            req.method,
            req.seed,
            req.trials,
            req.steps,
            progress=progress,
            phase=phase,
            masks=req.masks,
            programs=programs,
            **view,
        )
        guard.check_controls(req.method.name, res.get("control"), req.trials)
        return res | {"deterministic": deterministic}
