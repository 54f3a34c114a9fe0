"""Deterministic GPU kernels (mjx_radar.engine.determinism): the XLA flag, who sets it and
when, and the answer where it can no longer be set."""

import types

import pytest

from mjx_radar.engine import determinism
from mjx_radar.errors import InputError, ScenarioError

FLAG = "--xla_gpu_deterministic_ops"


@pytest.mark.parametrize("flags, value", [
    ("", None),
    ("--xla_force_host_platform_device_count=8", None),
    (f"{FLAG}_level=2", None),  # a longer name that begins the same way is another flag
    (FLAG, True),  # a bare flag is on
    (f"{FLAG}=true", True),
    (f"{FLAG}=TRUE", True),
    (f"{FLAG}=1", True),
    (f"{FLAG}=false", False),
    (f"{FLAG}=0", False),
    (f"{FLAG}=true --xla_gpu_autotune_level=0 {FLAG}=false", False),  # the last one counts
    (f"{FLAG}=false {FLAG}=true", True),
])  # fmt: skip
def test_flag_in_env_reads_what_xla_will_read(monkeypatch, flags, value):
    monkeypatch.setenv("XLA_FLAGS", flags)
    assert determinism.flag_in_env() is value


@pytest.mark.parametrize("flags, value", [
    ("", True),
    ("--xla_cpu_use_thunk_runtime=false", True),  # other flags kept
    (f"{FLAG}=false", True),  # --deterministic overrides a false given before
    (f"{FLAG}=true", True),
])  # fmt: skip
def test_request_in_env(monkeypatch, flags, value):
    monkeypatch.setenv("XLA_FLAGS", flags)
    determinism.request_in_env()
    assert determinism.flag_in_env() is value
    assert flags in determinism.os.environ["XLA_FLAGS"]  # nothing of the user's removed


def _backend(monkeypatch, started: bool, platform: str = "cpu"):
    monkeypatch.setattr(determinism, "_backend_started", lambda: started)
    import jax

    monkeypatch.setattr(jax, "devices", lambda: [types.SimpleNamespace(platform=platform)])


def test_apply_sets_the_flag_before_the_backend_starts(monkeypatch):
    monkeypatch.setenv("XLA_FLAGS", "")
    _backend(monkeypatch, started=False)
    assert determinism.apply(False) is False and determinism.flag_in_env() is None
    assert determinism.apply(True) is True and determinism.flag_in_env() is True
    assert determinism.apply(False) is True  # set in this process: every run has it


def test_apply_after_the_backend_started(monkeypatch):
    monkeypatch.setenv("XLA_FLAGS", "")
    _backend(monkeypatch, started=True, platform="cpu")
    assert determinism.apply(True) is True  # CPU kernels are deterministic anyway
    assert determinism.flag_in_env() is None  # the cache key of later programs unchanged
    _backend(monkeypatch, started=True, platform="gpu")
    assert determinism.apply(False) is False
    with pytest.raises(InputError, match=r"^deterministic = True: JAX has started") as err:
        determinism.apply(True)
    assert "\n" not in str(err.value)
    monkeypatch.setenv("XLA_FLAGS", f"{FLAG}=true")  # set before the backend started
    assert determinism.apply(True) is True


def test_bad_values_are_one_line_naming_the_option(tmp_path):
    import mjx_radar

    with pytest.raises(ScenarioError, match=r"^deterministic = 'yes': must be True or False$"):
        mjx_radar.simulate("smoke", deterministic="yes")
    with pytest.raises(ScenarioError, match=r"^deterministic = 1: must be True or False$"):
        mjx_radar.run_study("smoke", trials=2, chunk=2, out=tmp_path / "s", deterministic=1)
    assert not (tmp_path / "s").exists()


def test_command_line_option():
    from mjx_radar.cli.main import build_parser

    parse = build_parser().parse_args
    for cmd in (["run", "smoke"], ["study", "smoke", "--out", "x"]):
        assert parse(cmd).deterministic is False
        assert parse([*cmd, "--deterministic"]).deterministic is True


def test_asking_starts_no_backend_in_a_fresh_process():
    """Where JAX has not started, ``apply`` sets the flag without starting a backend (the
    old check called ``jax.devices()``, which started the GPU backend it then refused)."""
    import subprocess
    import sys

    code = (
        "import os; os.environ.pop('XLA_FLAGS', None)\n"
        "import jax\n"
        "from jax._src import xla_bridge\n"
        "from mjx_radar.engine import determinism\n"
        "assert determinism.apply(True) is True\n"
        "assert not xla_bridge.backends_are_initialized()\n"
        "assert '--xla_gpu_deterministic_ops=true' in os.environ['XLA_FLAGS']\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-1000:]
