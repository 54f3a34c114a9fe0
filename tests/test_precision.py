"""Every dot product of the traced programs is pinned to full float32 (issue 26).

A GPU computes a float32 dot left at JAX's default precision in TF32, which made 34
of 128 CKF trials diverge on an H100 (``mjx_radar.precision``). These tests read the
StableHLO of the programs the runner executes and fail if any dot lost its pin.
"""

from __future__ import annotations

import collections
import re

import jax
import jax.numpy as jnp
import pytest
from jax.sharding import NamedSharding

import mjx_radar.ckf
import mjx_radar.fisher
from mjx_radar import precision
from mjx_radar.engine import program_trace, programs
from mjx_radar.loop import closed_loop
from mjx_radar.scenario.reader import load_scenario
from mjx_radar.task import objective
from mjx_radar.task.method import parse_method
from mjx_radar.task.params import shape_key, task_params
from mjx_radar.task.task import make_task

_DOT = re.compile(r"stablehlo\.dot(?:_general)?\b[^\n]*")
_PREC = re.compile(r"precision = \[(\w+), (\w+)\]")


def dot_precisions(text: str) -> collections.Counter:
    """``{precision: count}`` of the dots of a StableHLO text (``"unset"``: no attribute)."""
    out = collections.Counter()
    for line in _DOT.findall(text):
        m = _PREC.search(line)
        out["unset" if m is None else "/".join(sorted({m[1], m[2]}))] += 1
    return out


@pytest.fixture(scope="module")
def smoke():
    sc = load_scenario("smoke")
    return sc, make_task(shape_key(sc)), task_params(sc, parse_method("ccr-sfim"))


def test_estimation_precision_is_highest():
    assert precision.ESTIMATION == "highest", "the CKF diverges in TF32 on GPUs (issue 26)"
    assert precision.PLANNER in ("highest", "high", "default", "float32", "tensorfloat32")


def test_closed_loop_step_program_pins_every_dot(smoke):
    """The exported step program (what the runner compiles and caches) of the closed loop."""
    sc, task, params = smoke
    p_leaves, tree = jax.tree.flatten(params)
    mesh = programs.device_mesh(jax.devices()[:1])
    split, whole = NamedSharding(mesh, programs.SPLIT), NamedSharding(mesh, programs.WHOLE)
    carry = jax.eval_shape(
        lambda t, p: closed_loop.init_carry(task, p, t)[0],
        jax.ShapeDtypeStruct((), jnp.int32), params,
    )  # fmt: skip
    _, step = program_trace.flat_programs(task, 1, False, mesh, len(p_leaves), tree, carry)
    c_specs = [jax.ShapeDtypeStruct((1, *x.shape), x.dtype, sharding=split)
               for x in jax.tree.leaves(carry) if x.size > 0]  # fmt: skip
    p_specs = [jax.ShapeDtypeStruct(jnp.shape(x), jnp.result_type(x), sharding=whole)
               for x in p_leaves]  # fmt: skip
    text = jax.export.export(step)(*p_specs, *c_specs).mlir_module()
    found = dot_precisions(text)
    allowed = {precision.ESTIMATION.upper(), precision.PLANNER.upper()}
    # filter, information, PCRLB, objective, MPPI; the factorisations are jitted functions
    # listed once per shape, on the CPU loops that list each dot once (36 dots;
    # estimation/linalg.py), elsewhere unrolled (more)
    floor = 30
    assert found["HIGHEST"] > floor, found
    assert set(found) <= allowed, f"unpinned dots in the closed loop: {found}"


def test_objective_pins_estimation_apart_from_the_rollout(smoke, monkeypatch):
    """With the planner relaxed, only the rollout's dots follow it; the cost terms stay."""
    sc, task, params = smoke
    monkeypatch.setattr(precision, "PLANNER", "high")
    cost = objective.make_objective(task)
    state = jnp.zeros((sc.n_radars, 6))
    mean, cov = jnp.zeros(6 * sc.n_targets), jnp.eye(6 * sc.n_targets)
    u = jnp.zeros((sc.mpc.horizon, 2 * sc.n_radars))

    def f(u, state, mean, cov):
        return cost(u, objective.plan_context(task, state, mean, cov), params)[0]

    found = dot_precisions(jax.jit(f).lower(u, state, mean, cov).as_text())

    def rollout(state, u):
        with precision.scope("planner"):
            return task.rollout(state, u.reshape(-1, sc.n_radars, 2))

    n_rollout = sum(dot_precisions(jax.jit(rollout).lower(state, u).as_text()).values())
    assert found["HIGHEST"] > 0 and set(found) <= {"HIGH", "HIGHEST"}, found
    assert found["HIGH"] == n_rollout, (found, n_rollout)


def test_public_estimation_functions_are_pinned():
    """``mjx_radar.ckf`` / ``mjx_radar.fisher`` (SPEC §11) pin themselves, eager or jitted."""
    a = jnp.eye(6) + 0.01

    def step(mean, cov, z):
        mean, cov = mjx_radar.ckf.predict(mean, cov, lambda x: a @ x, 0.01 * jnp.eye(6))
        h = lambda x: jnp.stack([jnp.linalg.norm(x[:3]), x[:3] @ x[3:]])  # noqa: E731
        return mjx_radar.ckf.update(mean, cov, z, h, jnp.eye(2))

    found = dot_precisions(
        jax.jit(step).lower(jnp.ones(6), jnp.eye(6), jnp.ones(2)).as_text()
    )  # fmt: skip
    found += dot_precisions(
        jax.jit(lambda s: mjx_radar.fisher.pfim_step(s, a, s, s)).lower(jnp.eye(6)).as_text()
    )  # fmt: skip
    assert found["HIGHEST"] > 0 and set(found) == {"HIGHEST"}, found


def test_scope_sets_the_precision_of_dots_traced_inside():
    def f(x):
        with precision.scope():
            y = x @ x
        return y @ x  # outside the scope: JAX's default

    with jax.default_matmul_precision("default"):  # whatever the environment says
        found = dot_precisions(jax.jit(f).lower(jnp.eye(3)).as_text())
    assert found["HIGHEST"] == 1 and sum(found.values()) == 2, found
