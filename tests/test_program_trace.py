"""Tracing a shape's programs (engine/program_trace.py): the loop's start traced once."""

import jax
import jax.numpy as jnp
from jax.sharding import NamedSharding

from mjx_radar.engine import program_trace, programs
from mjx_radar.engine.export_cache import SPLIT, WHOLE
from mjx_radar.engine.run_spec import run_spec
from mjx_radar.loop import closed_loop
from mjx_radar.task.method import parse_method


def test_init_traced_once_and_step_takes_its_shapes(tiny, monkeypatch):
    """``init``'s own trace gives the loop state's shapes that ``step`` takes: the loop's
    start is traced once per program (a ``jax.eval_shape`` of it first traced it twice),
    and ``step``'s carry inputs are ``init``'s outputs, leaf for leaf."""
    calls = []
    real = closed_loop.init_carry

    def counted(*a, **k):
        calls.append(1)
        return real(*a, **k)

    monkeypatch.setattr(closed_loop, "init_carry", counted)
    spec = run_spec(tiny)
    mesh = programs.device_mesh(jax.devices()[:1])
    params = spec.params(parse_method("stationary"))
    whole, split = NamedSharding(mesh, WHOLE), NamedSharding(mesh, SPLIT)
    p_specs = [
        jax.ShapeDtypeStruct(jnp.shape(x), jnp.result_type(x), sharding=whole)
        for x in jax.tree.leaves(params)
    ]
    trials = jax.ShapeDtypeStruct((2,), jnp.int32, sharding=split)
    args = (spec.shape, "none", "mppi", params, 2, 1, False, mesh, False, trials, p_specs)
    _, _, (e_init, e_step) = program_trace.trace(*args)
    assert len(calls) == 1
    carry_out = [(a.shape, a.dtype) for a in e_init.out_avals[:-1]]  # (*carry, ok)
    carry_in = [(a.shape, a.dtype) for a in e_step.in_avals[len(p_specs) :]]
    assert carry_in == carry_out and all(s[0] == 2 for s, _ in carry_in)


def test_the_period_index_is_the_one_shared_leaf(tiny):
    """The step program hands the loop's control-period index to the vmapped loop unbatched
    (a batch's trials advance together), so a ``lax.cond`` on it stays a branch; it is the
    only leaf so handed: every other leaf is per trial."""
    from mjx_radar.task.task import build

    task, params = build(tiny)
    carry, _ = jax.eval_shape(lambda: closed_loop.init_carry(task, params, 0))
    shared = program_trace._shared_leaves(carry)
    flat, _ = jax.tree_util.tree_flatten_with_path(carry)
    names = [jax.tree_util.keystr(path) for (path, _), s in zip(flat, shared, strict=True) if s]
    assert names == [program_trace.PERIOD] == [".state.info['period']"]


def test_the_mht_scan_counter_is_shared_too():
    """With the MHT its scan counter (set from the period at every step, and kept by the
    MHT's fallback; ``HypState.BATCH_SHARED``) is handed unbatched as well, so its settled
    time update and scans stay branches under ``vmap``; no other leaf is."""
    import mjx_radar
    from mjx_radar.task.task import build

    s = mjx_radar.load_scenario("clutter_3r4t").replace(
        tracker={"association": "mht", "hypotheses": 4, "branch_scans": 1}
    )
    task, params = build(s)
    carry, _ = jax.eval_shape(lambda: closed_loop.init_carry(task, params, 0))
    shared = program_trace._shared_leaves(carry)
    flat, _ = jax.tree_util.tree_flatten_with_path(carry)
    names = {jax.tree_util.keystr(path) for (path, _), s in zip(flat, shared, strict=True) if s}
    assert names == {program_trace.PERIOD, ".state.loop.modes.scans"}


def test_a_state_declares_its_shared_fields():
    """Any NamedTuple of the loop state names its batch-shared fields by ``BATCH_SHARED``,
    nested or not, whatever its fields hold (arrays, tuples, nothing); the rest of the
    state is per trial, the period index shared."""
    from typing import NamedTuple

    class Counted(NamedTuple):
        BATCH_SHARED = ("count", "clock")

        values: object
        count: object
        clock: object = ()

    class State(NamedTuple):
        info: dict

    class Carry(NamedTuple):
        state: State
        a: Counted
        b: list

    leaf = jax.ShapeDtypeStruct((3,), jnp.float32)
    carry = Carry(
        State({"period": leaf, "other": leaf}),
        Counted(leaf, (leaf, leaf)),
        [leaf, Counted((leaf,), leaf, leaf)],
    )
    shared = program_trace._shared_leaves(carry)
    flat, _ = jax.tree_util.tree_flatten_with_path(carry)
    names = [jax.tree_util.keystr(path) for (path, _), s in zip(flat, shared, strict=True) if s]
    want = [".a.count[0]", ".a.count[1]", ".b[1].count", ".b[1].clock", program_trace.PERIOD]
    assert sorted(names) == sorted(want)
    assert len(shared) == len(flat) == 9
