"""The environment's inputs checked at its doors: ``make``, ``reset``, ``step``.

Each check is one line naming the argument and what it must be
(:class:`~mjx_radar.ScenarioError`, a ``ValueError``). Shapes and dtypes are static
under ``jit``/``vmap``, so the shape checks run once, when the call is traced, and
cost nothing in the compiled loop; the finiteness of an action is checked only for a
concrete array (a call outside ``jit``: a host value, never a device round trip inside
a traced loop); inside ``jit`` :func:`finite_controls` applies each NaN or inf control
as 0 and says so (``Observation.nonfinite_action``). An action is never reshaped except
``[2N]`` to ``[N, 2]``.
"""

from __future__ import annotations

import os

import jax
import jax.numpy as jnp
import numpy as np

from mjx_radar.io.checks import ScenarioError, show

MAX_SEED = 2**31 - 1


def check_scenario(scenario):
    """``scenario`` read (a bundled name or a TOML path) and validated (one line)."""
    from mjx_radar.scenario.edit import validate
    from mjx_radar.scenario.reader import load_scenario
    from mjx_radar.scenario.schema import Scenario

    if isinstance(scenario, str | os.PathLike):
        return load_scenario(scenario)
    if not isinstance(scenario, Scenario):
        raise ScenarioError(
            f"scenario = {show(scenario)}: must be a Scenario, a bundled scenario name or a "
            f"TOML path, not {type(scenario).__name__}"
        )
    return validate(scenario)


def check_seed(seed) -> int | None:
    """``seed``: None (the scenario's) or an integer in ``[0, 2^31 - 1]``."""
    if seed is None:
        return None
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer):
        raise ScenarioError(f"seed = {show(seed)}: must be an integer in [0, 2^31 - 1]")
    if not 0 <= int(seed) <= MAX_SEED:
        raise ScenarioError(f"seed = {int(seed)}: must be an integer in [0, 2^31 - 1]")
    return int(seed)


def check_steps(steps, every: int) -> int | None:
    """``steps``: None (the scenario's) or filter steps >= 1, a multiple of ``every``."""
    if steps is None:
        return None
    if isinstance(steps, bool) or not isinstance(steps, int | np.integer) or steps < 1:
        raise ScenarioError(f"steps = {show(steps)}: must be an integer >= 1")
    if steps % every:
        raise ScenarioError(
            f"steps = {int(steps)}: must be a multiple of dt_control/dt_filter = {every}"
        )
    return int(steps)


def check_key(key) -> None:
    """``key``: a PRNG key (``env.trial_key(seed, trial)``, ``jax.random.PRNGKey(s)``)."""
    shape, dtype = jnp.shape(key), getattr(key, "dtype", None)
    typed = dtype is not None and jnp.issubdtype(dtype, jax.dtypes.prng_key)
    if (typed and shape == ()) or (dtype == jnp.uint32 and shape == (2,)):
        return
    what = f"an array {dtype}{list(shape)}" if dtype is not None else type(key).__name__
    raise ScenarioError(
        f"reset: key = {show(key, 40)}: must be a PRNG key (env.trial_key(seed, trial) or "
        f"jax.random.PRNGKey(s)), not {what}"
    )


def check_state(state, state_type) -> None:
    """``state``: what ``reset`` or ``step`` returned."""
    if not isinstance(state, state_type):
        raise ScenarioError(
            f"step: state = {show(state, 40)}: must be the State that reset() or step() "
            f"returned, not {type(state).__name__}"
        )


def check_action(action, n: int, where: str = "step") -> jax.Array:
    """``action`` as ``[N, 2]``: given ``[N, 2]`` or ``[2N]``, floating point, finite
    when concrete. Anything else is refused, never reshaped."""
    try:
        a = action if isinstance(action, jax.Array) else np.asarray(action)
        if a.dtype.kind in "OSUV":  # text or objects: jnp would warn before refusing
            raise TypeError
        a = jnp.asarray(a)
    except (TypeError, ValueError):
        raise ScenarioError(
            f"{where}: action = {show(action, 40)}: must be an array [{n}, 2] of "
            f"[a, alpha] per radar, not {type(action).__name__}"
        ) from None
    if a.shape not in ((n, 2), (2 * n,)):
        raise ScenarioError(
            f"{where}: action of shape {list(a.shape)}: must be [{n}, 2] ([a, alpha] per "
            f"radar, {n} radar(s)) or [{2 * n}]"
        )
    if not (jnp.issubdtype(a.dtype, jnp.floating) or jnp.issubdtype(a.dtype, jnp.integer)):
        raise ScenarioError(f"{where}: action of dtype {a.dtype}: must be real numbers")
    if not isinstance(a, jax.core.Tracer) and not bool(np.isfinite(np.asarray(a)).all()):
        raise ScenarioError(f"{where}: action holds NaN or inf: every control must be finite")
    return a.reshape(n, 2)


def finite_controls(a: jax.Array) -> tuple[jax.Array, jax.Array]:
    """``(a, flag)``: ``a`` with each NaN or inf control replaced by 0 (no acceleration)
    and ``flag`` (``[]`` bool) whether any was. Finite controls are unchanged (bit for
    bit); under ``jit`` this is how ``env.step`` treats a non-finite action."""
    ok = jnp.isfinite(a)
    return jnp.where(ok, a, jnp.zeros_like(a)), ~jnp.all(ok)
