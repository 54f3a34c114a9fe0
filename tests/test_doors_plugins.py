"""The tracker, sensor and cost-term doors: register_tracker / register_sensor check the
plug-in's contract (mjx_radar.contracts) and a tracker factory's result, in one line
naming it; a plug-in's own exception while the loop is traced is one line naming the
plug-in and the call, with the user's frames only (mjx_radar.plugin_errors)."""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import pytest

import mjx_radar
from mjx_radar import env as radar_env
from mjx_radar.contracts import PluginError
from mjx_radar.estimation.sensor.measurement import MeasurementModel, RangeModel


@pytest.fixture
def cleanup():
    yield
    for name in ("door_t", "door_none", "door_boom", "door_update"):
        mjx_radar.unregister_tracker(name)
    for name in ("door_s", "door_cli_s"):
        mjx_radar.unregister_sensor(name)
    for name in ("door_cost", "door_enabled"):
        mjx_radar.unregister_cost_term(name)


def test_tracker_registration(cleanup):
    with pytest.raises(TypeError, match="tracker 'door_t': a class or function, not dict"):
        mjx_radar.register_tracker("door_t", {"predict": None})
    with pytest.raises(PluginError, match=r"must take \(task, params\)"):
        mjx_radar.register_tracker("door_t", lambda task: None)
    with pytest.raises(ValueError, match="reserved"):
        mjx_radar.register_tracker("auto", lambda task, params: None)
    with pytest.raises(ValueError, match="a built-in tracker"):
        mjx_radar.register_tracker("JPDA", lambda task, params: None)


def test_a_tracker_factory_returning_none_is_named(cleanup):
    mjx_radar.register_tracker("door_none", lambda task, params: None)
    s = mjx_radar.load_scenario("smoke").replace(filter={"tracker": "door_none"})
    with pytest.raises(PluginError, match="tracker 'door_none': its factory returned NoneType"):
        radar_env.make(s)


def test_a_tracker_factorys_own_exception_is_one_line(cleanup):
    def boom(task, params):
        return task.no_such_field

    mjx_radar.register_tracker("door_boom", boom)
    s = mjx_radar.load_scenario("smoke").replace(filter={"tracker": "door_boom"})
    with pytest.raises(PluginError, match=r"tracker 'door_boom': factory\(\) raised Attr") as err:
        radar_env.make(s)
    assert "test_doors_plugins.py" in err.value.frames


def test_sensor_registration(cleanup):
    @dataclasses.dataclass(frozen=True)
    class Half(MeasurementModel):  # predict only: four methods missing
        name: str = "half"
        dim: int = 1

        def predict(self, radar_pos, target_pos):
            return 0.0

    with pytest.raises(PluginError, match=r"sensor 'door_s': Half has no variance\(\).*missing"):
        mjx_radar.register_sensor("door_s", Half)

    @dataclasses.dataclass(frozen=True)
    class NoDim(RangeModel):
        dim: int = 0

    with pytest.raises(PluginError, match=r"NoDim.dim = 0: must be an integer >= 1"):
        mjx_radar.register_sensor("door_s", NoDim)
    with pytest.raises(TypeError, match="a MeasurementModel subclass"):
        mjx_radar.register_sensor("door_s", int)

    @dataclasses.dataclass(frozen=True)
    class Good(RangeModel):
        name: str = "door_s"

    mjx_radar.register_sensor("Door_S", Good)  # any case
    assert mjx_radar.load_scenario("smoke").replace(measurement={"model": "DOOR_S"})


def _only_user_frames(err) -> None:
    assert "test_doors_plugins.py" in err.frames or "door_sensor.py" in err.frames
    assert "/mjx_radar/" not in err.frames and "/jax/" not in err.frames


def test_a_tracker_functions_own_exception_is_one_line(cleanup):
    from mjx_radar.env.filter_ops import joint_ckf

    def update(mean, cov, modes, z, radar_pos, scan, los=None):
        raise ValueError(f"no update for {z.shape}")

    mjx_radar.register_tracker("door_update", lambda t, p: joint_ckf(t, p)._replace(update=update))
    s = mjx_radar.load_scenario("smoke").replace(filter={"tracker": "door_update"})
    env = radar_env.make(s)
    state = jax.eval_shape(env.reset, env.trial_key(0, 0))
    with pytest.raises(PluginError) as err:
        jax.eval_shape(env.step, state, jnp.zeros((2, 2)))
    line = str(err.value)
    assert line.startswith("tracker 'door_update': update() raised ValueError: no update for")
    assert "\n" not in line
    _only_user_frames(err.value)


def test_a_cost_terms_own_exception_lists_the_horizons_fields(cleanup):
    def door_cost(h, task, params):
        return h.radars[..., 0].sum(-1)  # the field is h.radar

    mjx_radar.register_cost_term("door_cost", door_cost)
    env = radar_env.make("smoke", steps=8)
    obs = jax.eval_shape(env.reset, env.trial_key(0, 0)).obs  # shapes only: nothing compiles
    u = jnp.zeros((env.task.mpc.horizon, 2 * env.n_radars))
    with pytest.raises(PluginError) as err:
        jax.eval_shape(lambda obs, u: env.objective(obs)(u), obs, u)
    line = str(err.value)
    assert line.startswith("cost term 'door_cost': door_cost() raised AttributeError")
    assert "it has: controls, radar, target_points, info0" in line and "\n" not in line
    _only_user_frames(err.value)
    mjx_radar.register_cost_term("door_enabled", door_cost, enabled=lambda sc: sc.nope)
    with pytest.raises(PluginError, match=r"cost term 'door_enabled': enabled\(\) raised Attr"):
        radar_env.make("smoke", steps=8)


SENSOR = """
import dataclasses
from mjx_radar import register_sensor
from mjx_radar.estimation.sensor.measurement import RangeModel

@register_sensor("door_cli_s")
@dataclasses.dataclass(frozen=True)
class Gain(RangeModel):
    name: str = "door_cli_s"

    def predict(self, radar_pos, target_pos):
        return self.gain * super().predict(radar_pos, target_pos)  # no such field
"""


def test_a_sensors_own_exception_at_the_cli_is_one_line_and_no_run_dir(cleanup, tmp_path, capsys):
    from mjx_radar.cli import main as cli_main

    (tmp_path / "door_sensor.py").write_text(SENSOR)
    scenario = tmp_path / "s.toml"
    scenario.write_text(_smoke_toml() + '\n[measurement]\nmodel = "door_cli_s"\n')
    out = tmp_path / "run"
    code = cli_main.main(
        ["run", str(scenario), "--steps", "4", "--rollouts", "analytic", "--out", str(out),
         "--plugin", str(tmp_path / "door_sensor.py")]
    )  # fmt: skip
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and not out.exists()
    assert err[-1].startswith("error: sensor 'door_cli_s': predict() raised AttributeError")
    assert "Traceback" not in "\n".join(err)
    assert any("door_sensor.py" in e for e in err[:-1])  # the user's own frame
    assert not any("/mjx_radar/" in e or "/jax/" in e for e in err)


def _smoke_toml() -> str:
    from pathlib import Path

    return (Path(__file__).resolve().parents[1] / "scenarios" / "smoke.toml").read_text()


def test_a_tracker_returning_two_values_is_named(cleanup):
    from mjx_radar.env.filter_ops import joint_ckf

    def factory(task, params):
        ops = joint_ckf(task, params)
        return ops._replace(update=lambda m, c, modes, *a: ops.update(m, c, modes, *a)[:2])

    mjx_radar.register_tracker("door_update", factory)
    s = mjx_radar.load_scenario("smoke").replace(filter={"tracker": "door_update"})
    env = radar_env.make(s)
    state = jax.eval_shape(env.reset, env.trial_key(0, 0))
    with pytest.raises(PluginError, match=r"'door_update': update\(\) returned 2 values; exp"):
        jax.eval_shape(env.step, state, jnp.zeros((2, 2)))


def test_a_cost_terms_shape_and_arguments_are_checked(cleanup):
    with pytest.raises(PluginError, match=r"cost term 'door_cost': <lambda>\(\) must take \(h"):
        mjx_radar.register_cost_term("door_cost", lambda h, task: 0.0)
    with pytest.raises(PluginError, match=r"<lambda>\(\) must take \(scenario\)"):
        mjx_radar.register_cost_term("door_cost", lambda h, t, p: 0.0, enabled=lambda: True)
    mjx_radar.register_cost_term("door_cost", lambda h, task, params: h.radar[..., 0])
    env = radar_env.make("smoke", steps=8)
    obs = env.reset(env.trial_key(0, 0)).obs
    u = jnp.zeros((env.task.mpc.horizon, 2 * env.n_radars))
    with pytest.raises(PluginError, match=r"returned shape \[8, 2\]; expected \[8\] \(one cost"):
        jax.eval_shape(env.objective(obs), u)
