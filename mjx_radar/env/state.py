"""The environment's state, in brax / mujoco_playground conventions (pytrees).

:class:`Observation` is what the radars know at a control instant (what a planner sees).
:class:`State` is what ``env.reset`` returns and ``env.step`` advances: the simulator's
own state (``loop``: the physics and the tracker), what the radars know (``obs``),
the reward of the last control period, whether the episode is over, per-period
metrics and bookkeeping (``info``). Every field is an array or a pytree of arrays, so
states vmap over trials and scan over time.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import jax


class Observation(NamedTuple):
    """What the radars know at a control instant (a pytree of arrays).

    Attributes:
        radar_state: ``[N, 6]`` the radars' own states ``[x, y, z, θ, v, ω]``.
        mean: ``[6M]`` the track estimate to plan from: at the radars' instant
            (``mpc.aligned``) or, as in the paper's code, predicted one filter step ahead.
        cov: ``[6M, 6M]`` its covariance P.
        target_weight: ``[M]`` 1 for targets present at this instant, else 0.
        detections: ``[N, M]`` bool, the pairs detected at the last scan (line of sight
            and detection; all False before the first scan).
        time: ``[]`` the control instant [s].
        period: ``[]`` int32, the control period index j (time = j * dt_control).
        nonfinite_action: ``[]`` bool, the last period's action held NaN or inf (inside
            ``jit`` each such control is applied as 0; outside it ``step`` refuses it);
            None in an observation made by hand.
    """

    radar_state: jax.Array
    mean: jax.Array
    cov: jax.Array
    target_weight: jax.Array
    detections: jax.Array
    time: jax.Array
    period: jax.Array
    nonfinite_action: jax.Array | None = None


class LoopState(NamedTuple):
    """The simulator's state between filter steps (brax's ``pipeline_state``).

    Attributes:
        data: ``mjx.Data`` of the truth plant (radars, drones, moving obstacles).
        mean: ``[6M]`` the tracker's posterior mean.
        cov: ``[6M, 6M]`` its covariance P, or its factor S (``filter.form = "sqrt"``).
        pfim: ``[M, 6, 6]`` the PFIM along the true trajectory (the PCRLB).
        health: the lost-track detector's state.
        modes: the IMM's mode-conditioned state (``()`` for the CV filters).
    """

    data: Any
    mean: jax.Array
    cov: jax.Array
    pfim: jax.Array
    health: Any
    modes: Any = ()


class State(NamedTuple):
    """One environment state (brax's ``State``; use ``state._replace(...)``).

    Attributes:
        loop: :class:`LoopState`, the physics and the tracker (never shown to planners).
        obs: :class:`Observation`, what the radars know.
        reward: ``[]`` reward of the last control period (``RadarEnv.step``'s docstring).
        done: ``[]`` bool, the episode's last control period has been simulated.
        metrics: ``{name: []}`` the last filter step's errors and counts (``rmse_pos``,
            ``rmse_state``, ``nees``, ``crlb_pos``, ``lost``, ``diverged``, ...).
        info: ``{"key": trial key, "period": [] int32 control periods done,
            "placement_ok": [] bool}``.
    """

    loop: LoopState
    obs: Observation
    reward: jax.Array
    done: jax.Array
    metrics: dict
    info: dict
