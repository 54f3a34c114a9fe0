"""The planner door: a plug-in planner's mistakes refused at registration or where the
loop is traced, in one line naming the planner (mjx_radar.contracts, planners.guard)."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import mjx_radar
from mjx_radar.cli import main as cli_main
from mjx_radar.contracts import PluginError
from mjx_radar.planners import PLANNERS
from mjx_radar.planners.base import Observation, Planner
from mjx_radar.planners.guard import GuardedPlanner


class _Env:  # what a planner reads of its environment here
    n_radars = 2


def _obs(n=2, m=2):
    return Observation(
        jnp.zeros((n, 6)), jnp.zeros(6 * m), jnp.eye(6 * m), jnp.ones(m),
        jnp.zeros((n, m), bool), jnp.zeros(()), jnp.zeros((), jnp.int32),
    )  # fmt: skip


@pytest.fixture
def registered():
    names = []

    def add(name, obj):
        names.append(name)
        return mjx_radar.register_planner(name, obj)

    yield add
    for name in names:
        mjx_radar.unregister_planner(name)


def test_an_instance_is_refused(registered):
    class Mine(Planner):
        def plan(self, carry, obs, key):
            return jnp.zeros((2, 2)), carry

    with pytest.raises(PluginError, match="register the class .* not an instance of Mine"):
        registered("mine", Mine(None))


def test_a_misspelt_plan_is_refused_by_name(registered):
    class Typo(Planner):
        def plann(self, carry, obs, key):
            return jnp.zeros((2, 2)), carry

    with pytest.raises(PluginError, match=r"planner 'typo': Typo has no plan\(\)"):
        registered("typo", Typo)


def test_init_without_env_and_plan_of_wrong_arity_are_refused(registered):
    class NoEnv(Planner):
        def __init__(self):
            pass

        def plan(self, carry, obs, key):
            return jnp.zeros((2, 2)), carry

    with pytest.raises(PluginError, match=r"__init__\(self, env\)"):
        registered("noenv", NoEnv)

    class TwoArgs(Planner):
        def plan(self, carry, obs):
            return jnp.zeros((2, 2)), carry

    with pytest.raises(PluginError, match=r"TwoArgs.plan.* must take \(self, x, x, x\)"):
        registered("twoargs", TwoArgs)


def test_reserved_and_builtin_names_in_any_case(registered):
    class Ok(Planner):
        def plan(self, carry, obs, key):
            return jnp.zeros((2, 2)), carry

    with pytest.raises(ValueError, match="reserved"):
        registered("auto", Ok)
    with pytest.raises(ValueError, match="a built-in planner"):
        registered("MPPI", Ok)
    registered("Mixed_Case", Ok)  # names are case-insensitive, as method names
    assert PLANNERS.get("mixed_case") is Ok and PLANNERS.get("MIXED_CASE") is Ok
    assert "Mixed_Case" in PLANNERS


def test_policy_needs_its_folder():
    with pytest.raises(ValueError, match="give policy:DIR"):
        PLANNERS.get("policy")


def _guard(planner_cls, name="p"):
    return GuardedPlanner(name, planner_cls(_Env()), _Env(), True)


def test_wrong_action_shape_and_missing_carry_are_named():
    class Wide(Planner):
        def plan(self, carry, obs, key):
            return jnp.zeros((2, 3)), carry

    g = _guard(Wide, "wide")
    with pytest.raises(PluginError, match=r"planner 'wide': .*shape \[2, 3\]; expected \[2, 2\]"):
        g.plan(g.init(), _obs(), jax.random.PRNGKey(0))

    class NoCarry(Planner):
        def plan(self, carry, obs, key):
            return jnp.zeros((2, 2))

    g = _guard(NoCarry, "nocarry")
    with pytest.raises(PluginError, match=r"must return \(action, carry\), got one array"):
        g.plan(g.init(), _obs(), jax.random.PRNGKey(0))


def test_a_carry_that_changes_shape_is_named():
    class Grows(Planner):
        def init(self):
            return jnp.zeros(3)

        def plan(self, carry, obs, key):
            return jnp.zeros((2, 2)), jnp.zeros(4)

    g = _guard(Grows, "grows")
    with pytest.raises(PluginError, match=r"carry of float32\[4\]; expected init\(\)'s"):
        g.plan(g.init(), _obs(), jax.random.PRNGKey(0))


def test_a_plugins_own_exception_names_the_call_and_lists_the_fields():
    class Reads(Planner):
        def plan(self, carry, obs, key):
            return obs.radar_states[:, :2], carry

    g = _guard(Reads, "reads")
    with pytest.raises(PluginError) as err:
        g.plan(g.init(), _obs(), jax.random.PRNGKey(0))
    line = str(err.value)
    assert line.startswith("planner 'reads': plan() raised AttributeError") and "\n" not in line
    assert "it has: radar_state, mean, cov" in line
    assert "test_doors_planner.py" in err.value.frames  # the user's own frame only
    assert "mjx_radar" not in err.value.frames.replace("test_doors_planner", "")


def test_cli_run_of_a_broken_plugin_is_one_error_line_and_no_run_dir(tmp_path, capsys):
    plugin = tmp_path / "shape.py"
    plugin.write_text(
        "import jax.numpy as jnp\nfrom mjx_radar import Planner, register_planner\n"
        "@register_planner('doorshape')\nclass P(Planner):\n"
        "    def plan(self, carry, obs, key):\n        return jnp.zeros((2, 3)), carry\n"
    )
    out = tmp_path / "run"
    argv = ["run", "smoke", "--steps", "4", "--rollouts", "analytic", "--plugin", str(plugin)]
    try:
        code = cli_main.main([*argv, "--planner", "doorshape", "--out", str(out)])
    finally:
        mjx_radar.unregister_planner("doorshape")
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and not out.exists()
    assert err[-1].startswith("error: planner 'doorshape': plan() returned an action of shape")
    assert "Traceback" not in "\n".join(err)


def test_a_plugin_file_calling_sys_exit_is_refused(tmp_path):
    from mjx_radar.api.run_case import load_plugins

    f = tmp_path / "quits.py"
    f.write_text("import sys\nsys.exit(0)\n")
    with pytest.raises(mjx_radar.ScenarioError, match=r"called sys.exit\(0\)"):
        load_plugins([f])
    with pytest.raises(mjx_radar.ScenarioError, match="quits.py"):  # one path, not letters
        load_plugins(str(f))


def test_a_registered_planners_nan_controls_are_refused_by_name(registered):
    from mjx_radar.planners.guard import check_controls

    class Nan(Planner):
        def plan(self, carry, obs, key):
            return jnp.full((2, 2), jnp.nan), carry

    registered("door_nan", Nan)
    u = np.zeros((3, 4, 2, 2))
    check_controls("ddr-sfim+door_nan", u, np.arange(3))  # finite: nothing to say
    u[1, 2, 0, 1] = np.inf
    with pytest.raises(PluginError, match=r"planner 'door_nan': plan\(\) returned NaN or inf "
                       r"controls \(first at trial 11, control period 2\)"):  # fmt: skip
        check_controls("ddr-sfim+door_nan", u, np.arange(10, 13))
    check_controls("ddr-sfim+cem", u, np.arange(3))  # a built-in's divergence is reported
