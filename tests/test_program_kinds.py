"""Program kinds: a run compiles only the planner information its method needs (issue 27)."""

import dataclasses

import jax
import pytest

from mjx_radar.engine import runner
from mjx_radar.engine.run_spec import run_spec
from mjx_radar.loop import closed_loop
from mjx_radar.scenario.reader import load_scenario
from mjx_radar.task.method import METHODS, SWITCH, parse_method, runs, shared_programs
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
    kinds = {"none": "stationary", "sfim": "ddr-sfim", "pfim": "ddr-pfim", "all": "ddr-sfim",
             "sfim+none": "stationary", SWITCH: "ddr-pfim"}  # fmt: skip
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
    assert cases["sfim+none"] == cases["sfim"] + 1  # plan or hold; SFIM only
    # a study's one program: a switch of hold and both whole planners, none inside them
    assert cases[SWITCH] == cases["sfim"] + 1
    # no planner at all without one (MPPI's iteration and sampling loops are gone)
    assert loops["none"] < loops["sfim"] == loops["sfim+none"] <= loops["pfim"] == loops["all"]
    # both planners (PFIM's and SFIM's loops), the fixed loop once (shared functions once)
    assert loops["pfim"] < loops[SWITCH] <= loops["sfim"] + loops["pfim"] - loops["none"]
    size = {k: len(t) for k, t in hlo.items()}
    assert size["none"] < size["sfim"] < size["sfim+none"] < size["pfim"] < size["all"]
    assert size["pfim"] < size[SWITCH] < size["sfim"] + size["pfim"] - size["none"]


def test_precompile_compiles_one_program_per_shape(tiny, monkeypatch):
    seen = []

    def fake(spec, batch, periods, full, devices, kind="all", planner="mppi"):
        seen.append((spec.shape, kind))
        return []

    monkeypatch.setattr(runner, "device_programs", fake)
    other = dataclasses.replace(tiny, name="other", seed=5)  # same shape
    bigger = dataclasses.replace(tiny, mpc=dataclasses.replace(tiny.mpc, horizon=4))
    specs = [run_spec(s) for s in (tiny, other, bigger)]
    names = [(0, "ddr-sfim"), (0, "ccr-sfim"), (1, "ddr-pfim"), (2, "stationary")]
    jobs = [(specs[i], m) for i, m in names]
    runner.precompile(jobs, 2, 8)
    # one program per shape: a renamed copy is the same shape; stationary alone keeps its own
    assert sorted(k for _, k in seen) == ["none", SWITCH]
    assert {k for s, k in seen if s == shape_key(tiny)} == {SWITCH}
    assert {k for s, k in seen if s == shape_key(bigger)} == {"none"}
    seen.clear()
    runner.precompile([specs[0]], 2, 8)  # a scenario alone: every method, one program
    assert [k for _, k in seen] == [SWITCH]


def test_stationary_rides_along_in_a_planning_program():
    """A study's programs per shape: the built-in methods share one (the switch of
    whole planners for both informations); a registered planner, or a method alone,
    keeps its own."""
    assert shared_programs(METHODS) == dict.fromkeys(METHODS, (SWITCH, "mppi"))
    assert shared_programs(["ccr-sfim", "ddr-pfim"])["ccr-sfim"] == (SWITCH, "mppi")
    assert shared_programs(["stationary", "ccr-pfim"])["stationary"] == ("pfim+none", "mppi")
    assert shared_programs(["ddr-sfim", "stationary"])["stationary"] == ("sfim+none", "mppi")
    assert shared_programs(["stationary"]) == {"stationary": ("none", "hold")}
    assert shared_programs(["ddr-sfim", "ccr-sfim"])["ddr-sfim"] == ("sfim", "mppi")
    alone = shared_programs(["stationary", "ddr-sfim+cem"])
    assert alone == {"stationary": ("none", "hold"), "ddr-sfim+cem": ("sfim", "cem")}
    # which programs run which methods (run_trials refuses the others)
    stationary, sfim, pfim = (parse_method(m) for m in ("stationary", "ddr-sfim", "ddr-pfim"))
    assert runs(("sfim+none", "mppi"), stationary) and runs(("sfim+none", "mppi"), sfim)
    assert runs(("all", "mppi"), pfim) and runs(("none", "hold"), stationary)
    assert not runs(("sfim", "mppi"), stationary) and not runs(("sfim+none", "mppi"), pfim)
    assert not runs(("sfim+none", "cem"), sfim) and not runs(("bogus", "mppi"), sfim)
    assert all(runs((SWITCH, "mppi"), m) for m in METHODS.values())


def test_run_trials_refuses_a_program_that_does_not_run_the_method(tiny):
    with pytest.raises(ValueError, match="does not run the method ddr-pfim"):
        runner.run_trials(run_spec(tiny), "ddr-pfim", 0, [0], 4, program=("sfim+none", "mppi"))
