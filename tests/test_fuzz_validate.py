"""Fuzzing the scenario validator: any input either loads or raises a one-line ScenarioError.

Two parts: a hypothesis property test over mutated scenario dicts and mutated TOML
bytes (200 + 150 examples), and the corpus ``tests/bad_inputs/*.toml`` (>= 60 bad
files) through ``mjx_radar.cli.main.main(["validate", FILE])`` in one process, plus
two real subprocesses: exit code 2, exactly one stderr line, no traceback, and the
``# expect: NEEDLE`` of the file's first line in the message.
"""

from __future__ import annotations

import contextlib
import io
import math
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mjx_radar.scenario.reader import ScenarioError, load_scenario, scenario_from_dict

CORPUS = sorted((Path(__file__).parent / "bad_inputs").glob("*.toml"))
GOOD = {
    "name": "fuzz",
    "n_radars": 2,
    "targets": [[0.0, 0.0, 55.0, 20.0, 10.0, 0.0], [15.0, 15.0, 70.0, 15.0, 20.0, 0.0]],
    "radars": [[300.0, 0.0, 3.14], [-300.0, 0.0, 0.0]],
    "sigma_w2": 10.0,
    "timing": {"dt_filter": 0.025, "dt_control": 0.1, "steps": 80},
    "mpc": {"horizon": 8, "r2t": 125.0, "los": False, "rollout": "analytic"},
    "mppi": {"samples": 64, "weighting": "ce", "elite_threshold": 0.9},
    "radar_equation": {"snr_db": -20.0, "power_tx": 1000.0, "fc": 1e8},
    "obstacles": [{"kind": "box", "pos": [0.0, 200.0, 5.0], "size": [5.0, 5.0, 5.0]}],
}
GOOD_TOML = """name = "fuzz"
n_radars = 2
targets = [[0, 0, 55, 20, 10, 0], [15, 15, 70, 15, 20, 0]]
radars = [[300, 0, 3.14], [-300, 0, 0]]
[timing]
dt_filter = 0.025
dt_control = 0.1
steps = 80
[mpc]
horizon = 8
[radar_equation]
snr_db = -20.0
"""

leaves = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(min_value=-(2**70), max_value=2**70),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0, -1, 1e-300, 1e300, 1e5, 1e4, 2**31, math.pi, "", "ce", "mjx", "box"]),
    st.text(max_size=12),
    st.binary(max_size=8),
)
junk = st.recursive(
    leaves,
    lambda inner: st.one_of(
        st.lists(inner, max_size=7), st.dictionaries(st.text(max_size=6), inner, max_size=4)
    ),
    max_leaves=12,
)


def _paths(d, prefix=()):
    """Every (nested) key path of a dict/list tree."""
    out = []
    items = d.items() if isinstance(d, dict) else enumerate(d) if isinstance(d, list) else []
    for k, v in items:
        out.append(prefix + (k,))
        out += _paths(v, prefix + (k,))
    return out


PATHS = _paths(GOOD)
mutation = st.one_of(
    st.tuples(st.just("set"), st.sampled_from(PATHS), junk),
    st.tuples(st.just("delete"), st.sampled_from(PATHS), st.none()),
    st.tuples(
        st.just("add"),
        st.sampled_from([(), *[p for p in PATHS if len(p) == 1]]),
        st.tuples(st.text(max_size=8), junk),
    ),  # fmt: skip
)


def _mutate(raw: dict, op: str, path: tuple, value) -> dict:
    import copy

    raw = copy.deepcopy(raw)
    node = raw
    for k in path[:-1]:
        node = node[k]
    if op == "set":
        node[path[-1]] = value
    elif op == "delete":
        del node[path[-1]]
    else:
        target = raw if not path else raw[path[0]]
        if isinstance(target, dict):
            target[value[0]] = value[1]
    return raw


def _assert_one_line(err: ScenarioError) -> None:
    msg = str(err)
    assert msg and "\n" not in msg and "\r" not in msg, repr(msg)
    assert len(msg) < 400, msg


@settings(max_examples=200, deadline=None, suppress_health_check=list(HealthCheck))
@given(st.lists(mutation, min_size=1, max_size=3))
def test_mutated_dicts_load_or_raise_one_line(mutations):
    raw = GOOD
    for op, path, value in mutations:
        try:
            raw = _mutate(raw, op, path, value)
        except (KeyError, IndexError, TypeError):
            continue  # the path vanished under an earlier mutation
    try:
        scenario_from_dict(raw)
    except ScenarioError as err:
        _assert_one_line(err)


toml_bytes = st.one_of(
    st.binary(max_size=200),
    st.tuples(st.integers(0, len(GOOD_TOML)), st.binary(min_size=1, max_size=12)).map(
        lambda t: GOOD_TOML.encode()[: t[0]] + t[1] + GOOD_TOML.encode()[t[0] :]
    ),
    st.tuples(st.integers(0, len(GOOD_TOML)), st.integers(1, 20)).map(
        lambda t: GOOD_TOML.encode()[: t[0]] + GOOD_TOML.encode()[t[0] + t[1] :]
    ),
    st.text(max_size=40).map(lambda t: (GOOD_TOML + t + "\n").encode("utf-8", "surrogatepass")),
)


@settings(max_examples=150, deadline=None, suppress_health_check=list(HealthCheck))
@given(toml_bytes)
def test_mutated_files_load_or_raise_one_line(tmp_path_factory, data):
    path = tmp_path_factory.mktemp("fuzz") / "s.toml"
    path.write_bytes(data)
    try:
        load_scenario(path)
    except ScenarioError as err:
        _assert_one_line(err)


def _expected(path: Path) -> str:
    head = path.read_bytes().split(b"\n", 1)[0]
    return head[len(b"# expect: ") :].decode() if head.startswith(b"# expect: ") else ""


def test_corpus_is_large():
    assert len(CORPUS) >= 60


def test_bad_corpus_validate_in_process():
    from mjx_radar.cli.main import main

    failures = []
    for path in CORPUS:
        err, out = io.StringIO(), io.StringIO()
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
            code = main(["validate", str(path)])
        lines = err.getvalue().strip().splitlines()
        ok = code == 2 and len(lines) == 1 and "Traceback" not in err.getvalue()
        if not ok or _expected(path) not in lines[0]:
            failures.append(f"{path.name}: exit {code}, stderr {err.getvalue()!r}")
    assert not failures, "\n".join(failures)


@pytest.mark.parametrize("name", ["random_bytes.toml", "mesh_garbage_stl.toml"])
def test_bad_corpus_validate_subprocess(name):
    path = Path(__file__).parent / "bad_inputs" / name
    cmd = [sys.executable, "-m", "mjx_radar", "validate", str(path)]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    lines = [ln for ln in proc.stderr.splitlines() if not ln.startswith("Failed to import")]
    assert proc.returncode == 2, proc.stderr
    assert len(lines) == 1 and "Traceback" not in proc.stderr, proc.stderr
    assert _expected(path) in lines[0]


def test_deep_geojson_is_refused_whatever_the_recursion_limit(monkeypatch):
    """The GeoJSON depth check does not rest on the interpreter's recursion limit (a test
    library may raise it in the same process)."""
    import sys

    from mjx_radar.cli.main import main

    path = Path(__file__).parent / "bad_inputs" / "buildings_deep_nesting.toml"
    old = sys.getrecursionlimit()
    sys.setrecursionlimit(50_000)
    try:
        err = io.StringIO()
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            code = main(["validate", str(path)])
    finally:
        sys.setrecursionlimit(old)
    assert code == 2 and "nested too deeply" in err.getvalue(), err.getvalue()
