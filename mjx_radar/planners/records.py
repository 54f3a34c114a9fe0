"""What a planner records of its plan: the samples a sampling planner kept, for the run files.

The environment's :class:`~mjx_radar.env.records.ControlRecord` holds the applied control,
the planned radar positions and the planner's own record (``ControlRecord.plan``). The
built-in planners put a :class:`SampleRecord` there (the best sampled sequences of MPPI,
predictive sampling, CEM, the evolution strategies; zeros for a planner that draws
none), so every run directory holds the same ``sample_*`` arrays.
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp

from mjx_radar.env.records import ControlRecord

N_KEEP_SAMPLES = 32  # sampled sequences kept per control step for plots and video (at most)


class SampleRecord(NamedTuple):
    """The sampled sequences a planner kept at one control step (``ControlRecord.plan``)."""

    sample_xy: jax.Array  # [S_keep, H, N, 2] sampled radar trajectories
    sample_weight: jax.Array  # [S_keep] their weights
    sample_cost: jax.Array  # [S_keep] their costs


def kept_samples(samples: int) -> int:
    """Samples recorded per control step of a planner drawing ``samples``: at most 32."""
    return min(N_KEEP_SAMPLES, samples)


def plan_record(control, plan_xy, sample_xy, sample_weight, sample_cost) -> ControlRecord:
    """A control step's record with the planner's kept samples."""
    return ControlRecord(control, plan_xy, SampleRecord(sample_xy, sample_weight, sample_cost))


def idle_record(control, horizon: int, kept: int) -> ControlRecord:
    """The record of a control step without a plan to show: zeros of ``horizon`` steps
    and ``kept`` samples (``control`` [N, 2])."""
    n, h, s = control.shape[0], horizon, kept
    return plan_record(
        control,
        jnp.zeros((h, n, 2)),
        jnp.zeros((s, h, n, 2)),
        jnp.zeros(s),
        jnp.zeros(s),
    )


def complete(record: ControlRecord, horizon: int, kept: int) -> ControlRecord:
    """``record`` with zero samples where its planner kept none (``plan`` not a
    :class:`SampleRecord`): every control step then has the run files' layout."""
    if isinstance(record.plan, SampleRecord):
        return record
    return idle_record(record.control, horizon, kept)._replace(plan_xy=record.plan_xy)


def record_shape(mpc, mppi) -> tuple[int, int]:
    """``(horizon, kept samples)`` of the records, from the ``[mpc]`` and ``[mppi]`` tables."""
    return mpc.horizon, kept_samples(mppi.samples)


#: a record's layout (leaf values are placeholders): the programs' output template
TEMPLATE = plan_record(0, 0, 0, 0, 0)
