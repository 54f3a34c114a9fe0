"""Static vs runtime is declared once, in the field metadata (issue 32).

Every field the schema marks ``runtime`` (``io.checks.runtime``) is found by walking the
metadata; changing it must leave the compiled shape (``shape_key``) unchanged *and* reach
the runtime parameters (``task_params``): a runtime field that ``task_params`` forgot
would be silently ignored by the compiled program, one that ``shape_key`` forgot would
recompile. Changing a static field must change the shape.
"""

from __future__ import annotations

import dataclasses

import jax
import numpy as np
import pytest

from mjx_radar.io.checks import is_runtime
from mjx_radar.scenario.reader import load_scenario
from mjx_radar.scenario.schema import MovingObstacle
from mjx_radar.task.method import parse_method
from mjx_radar.task.params import shape_key, task_params

#: radar-equation factors of K = Pt Gt Gr lambda^2 sigma / ((4 pi)^3 L) that cancel: the noise
#: is set by the SNR at r_ref (sigma_a^2 = M K / r_ref^4 / 10^(snr/10)), so C = c^2 sigma_a^2 /
#: (8 pi^2 fc^2 K) and the detection SNR P_r(d) / sigma_a^2 do not depend on them (SPEC 1)
CANCEL_IN_K = {("radar_eq", n) for n in ("loss", "gain_tx", "gain_rx", "rcs", "power_tx")}


def _perturb(value):
    """A different value of the same kind (numbers scaled, rows shifted)."""
    if isinstance(value, bool):
        return not value
    if isinstance(value, int):
        return value + 1
    if isinstance(value, float):
        return value * 0.9 if value else 0.5
    if isinstance(value, tuple) and value:  # rows: move the first row's first column
        first = (value[0][0] + 1.0, *value[0][1:])
        return (first, *value[1:])
    return None


def _runtime_paths(obj, prefix=()):
    """``(path, value)`` of every runtime leaf of a config dataclass (a runtime table: each
    of its fields; a tuple of tables: its first element)."""
    for f in dataclasses.fields(obj):
        value, path = getattr(obj, f.name), (*prefix, f.name)
        if is_runtime(f) and dataclasses.is_dataclass(value):
            yield from (
                (path + (g.name,), getattr(value, g.name)) for g in dataclasses.fields(value)
            )
        elif is_runtime(f):
            yield path, value
        elif dataclasses.is_dataclass(value):
            yield from _runtime_paths(value, path)
        elif isinstance(value, tuple) and value and dataclasses.is_dataclass(value[0]):
            yield from _runtime_paths(value[0], (*path, 0))


def _replace(obj, path, value):
    head, rest = path[0], path[1:]
    if isinstance(obj, tuple):
        return (_replace(obj[head], rest, value), *obj[1:]) if rest else (value, *obj[1:])
    inner = value if not rest else _replace(getattr(obj, head), rest, value)
    return dataclasses.replace(obj, **{head: inner})


def _leaves(params):
    return [np.asarray(x) for x in jax.tree.leaves(params)]


def _scenarios():
    car = MovingObstacle(kind="box", size=(3.0, 1.5), height=3.0,
                         path=((0.0, -200.0), (0.0, 200.0)), speed=10.0)  # fmt: skip
    smoke = load_scenario("smoke")
    yield "smoke", smoke
    yield "clutter_3r4t", load_scenario("clutter_3r4t")  # detection and clutter numbers
    yield "mixed_6r4t", load_scenario("mixed_6r4t")  # fixed radar starts
    yield "moving", dataclasses.replace(smoke, moving_obstacles=(car,))


@pytest.mark.parametrize(
    "name,scenario", list(_scenarios()), ids=lambda x: x if isinstance(x, str) else ""
)
def test_runtime_fields_reach_the_params_and_not_the_shape(name, scenario):
    method = parse_method("ddr-sfim")
    shape, params = shape_key(scenario), _leaves(task_params(scenario, method))
    checked = []
    for path, value in _runtime_paths(scenario):
        if path == ("placement_half_width",) and scenario.obstacles:
            continue  # obstacle scenes keep it in the shape (it sizes the SDF grid)
        changed = _perturb(value)
        if changed is None:  # "" names, empty rows: nothing to change
            continue
        other = _replace(scenario, path, changed)
        assert shape_key(other) == shape, f"{name}: {'.'.join(map(str, path))} changes the shape"
        if isinstance(value, str):
            continue  # the name: not a number of the program
        new = _leaves(task_params(other, method))
        reached = any(not np.array_equal(a, b) for a, b in zip(params, new, strict=True))
        where = ".".join(map(str, path))
        assert reached != (path in CANCEL_IN_K), f"{name}: {where} reached TaskParams: {reached}"
        checked.append(path)
    assert len(checked) >= 10 or name == "moving", checked


@pytest.mark.parametrize("path,value", [
    (("mpc", "horizon"), 5), (("mppi", "samples"), 77), (("timing", "dt_control"), 0.05),
    (("n_radars",), 3), (("filter", "structure"), "per-target"), (("mpc", "alpha_effort"), 1.0),
])  # fmt: skip
def test_static_fields_change_the_shape(path, value):
    s = load_scenario("smoke")
    assert shape_key(_replace(s, path, value)) != shape_key(s)
