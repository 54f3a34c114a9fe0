"""Program kinds: a run compiles only the planner information its method needs (issue 27)."""

import dataclasses

import jax
import pytest

from mjx_radar.engine import runner
from mjx_radar.env import closed_loop
from mjx_radar.scenario.reader import load_scenario
from mjx_radar.task.method import METHODS, parse_method
from mjx_radar.task.params import shape_key, task_params
from mjx_radar.task.task import make_task


def _lowered(scenario, kind: str, method: str) -> str:
    """StableHLO text of one control period of one trial, for a program kind."""
    task = make_task(shape_key(scenario), kind)
    params = task_params(scenario, parse_method(method))
    carry = jax.eval_shape(lambda p: closed_loop.init_carry(task, p, 0)[0], params)
    fn = jax.jit(lambda p, c: closed_loop.advance(task, p, c, 1))
    return fn.lower(params, carry).as_text()


@pytest.fixture(scope="module")
def hlo(tiny):
    kinds = {"none": "stationary", "sfim": "ddr-sfim", "pfim": "ddr-pfim", "all": "ddr-sfim"}
    return {k: _lowered(tiny, k, m) for k, m in kinds.items()}


def test_method_kinds():
    assert {m: METHODS[m].kind for m in METHODS} == {
        "stationary": "none", "ccr-sfim": "sfim", "ccr-pfim": "pfim",
        "ddr-sfim": "sfim", "ddr-pfim": "pfim",
    }  # fmt: skip
    with pytest.raises(ValueError, match="program kind"):
        make_task(shape_key(load_scenario("smoke")), "bogus")


def test_single_kind_programs_leave_out_the_other_branches(hlo):
    cases = {k: t.count("stablehlo.case") for k, t in hlo.items()}
    loops = {k: t.count("stablehlo.while") for k, t in hlo.items()}
    # "all" joins plan / idle and SFIM / PFIM by two runtime conds; a kind has neither
    assert cases["all"] == cases["sfim"] + 2 == cases["pfim"] + 2
    assert cases["none"] == cases["sfim"]
    # no planner at all without one (MPPI's iteration and sampling loops are gone)
    assert loops["none"] < loops["sfim"] <= loops["pfim"] == loops["all"]
    size = {k: len(t) for k, t in hlo.items()}
    assert size["none"] < size["sfim"] < size["pfim"] < size["all"]


def test_precompile_compiles_one_program_per_shape_and_kind(tiny, monkeypatch):
    seen = []

    def fake(scenario, batch, periods, full, devices, kind="all", planner="mppi"):
        seen.append((shape_key(scenario), kind))
        return []

    monkeypatch.setattr(runner, "device_programs", fake)
    other = dataclasses.replace(tiny, name="other", seed=5)  # same shape
    bigger = dataclasses.replace(tiny, mpc=dataclasses.replace(tiny.mpc, horizon=4))
    jobs = [(tiny, "ddr-sfim"), (tiny, "ccr-sfim"), (other, "ddr-pfim"), (bigger, "stationary")]
    runner.precompile(jobs, 2, 8)
    assert sorted(k for _, k in seen) == ["none", "pfim", "sfim"]  # each program once
    assert {k for s, k in seen if s == shape_key(tiny)} == {"sfim", "pfim"}
    assert {k for s, k in seen if s == shape_key(bigger)} == {"none"}
    seen.clear()
    runner.precompile([tiny], 2, 8)  # a scenario alone: every method's kind
    assert sorted(k for _, k in seen) == ["none", "pfim", "sfim"]
