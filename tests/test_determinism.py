"""Deterministic GPU kernels (mjx_radar.engine.determinism): the XLA flag, who sets it and
when, and the answer where it can no longer be set."""

import pkgutil
import types

import pytest

from mjx_radar.engine import determinism
from mjx_radar.errors import InputError, ScenarioError

FLAG = "--xla_gpu_deterministic_ops"
pkgutil_iter = pkgutil.iter_modules


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


@pytest.fixture
def gpu(monkeypatch):
    """A process that may start a GPU backend (this CPU machine pretends to have a plugin)."""
    monkeypatch.setattr(determinism, "gpu_possible", lambda: True)


@pytest.mark.parametrize("flags, asked, value", [
    ("", True, True),
    ("", None, True),  # the default: on
    ("", False, None),  # XLA's default (off) left as it is
    ("--xla_cpu_use_thunk_runtime=false", True, True),  # other flags kept
    (f"{FLAG}=false", True, True),  # --deterministic overrides a false given before
    (f"{FLAG}=false", None, False),  # the default respects the user's XLA_FLAGS
    (f"{FLAG}=true", True, True),
    (f"{FLAG}=true", None, True),
    (f"{FLAG}=true", False, False),  # --no-deterministic overrides a true given before
])  # fmt: skip
def test_request_in_env(monkeypatch, gpu, flags, asked, value):
    monkeypatch.setenv("XLA_FLAGS", flags)
    determinism.request_in_env(asked)
    assert determinism.flag_in_env() is value
    assert flags in determinism.os.environ["XLA_FLAGS"]  # nothing of the user's removed


def test_nothing_is_set_where_no_gpu_can_start(monkeypatch):
    """A CPU-only process keeps XLA_FLAGS as it is (part of the compilation cache's key:
    in-process and command-line runs share their programs) and its kernels count as
    deterministic."""
    monkeypatch.setenv("XLA_FLAGS", "")
    monkeypatch.setattr(determinism, "_gpu_plugin_installed", lambda: False)
    for asked in (None, True, False):
        determinism.request_in_env(asked)
        assert determinism.flag_in_env() is None
    monkeypatch.setattr(determinism, "_backend_started", lambda: False)
    assert determinism.apply(None) is True and determinism.flag_in_env() is None


def test_gpu_plugin_detection_finds_installed_plugins_only(monkeypatch, tmp_path):
    """Plugins are found where JAX looks (entry points of group ``jax_plugins``, the
    ``jax_plugins`` namespace package), and only installed CUDA / ROCm ones count."""
    import sys
    from importlib import metadata

    before = determinism.gpu_possible()
    (tmp_path / "fake_cuda99_plugin").mkdir()
    (tmp_path / "fake_cuda99_plugin" / "__init__.py").write_text("")
    (tmp_path / "jax_plugins" / "xla_rocm99").mkdir(parents=True)
    (tmp_path / "jax_plugins" / "xla_rocm99" / "__init__.py").write_text("")
    monkeypatch.syspath_prepend(str(tmp_path))

    def eps(value):
        ep = [metadata.EntryPoint("p", value, "jax_plugins")] if value else []
        return lambda group: ep if group == "jax_plugins" else []

    try:
        for value, namespace, found in [
            ("json", False, False),  # installed, not a GPU plugin
            ("jax_cuda12_plugin_not_installed", False, False),  # a GPU name, not importable
            ("fake_cuda99_plugin:initialize", False, True),  # installed CUDA plugin
            ("", True, True),  # a ROCm plugin in the namespace package
            ("", False, False),
        ]:
            monkeypatch.setattr(metadata, "entry_points", eps(value))
            monkeypatch.setattr(
                determinism.pkgutil,
                "iter_modules",
                lambda path, ns=namespace: [
                    m for m in pkgutil_iter(path) if ns or m.name != "xla_rocm99"
                ],
            )
            determinism._gpu_plugin_installed.cache_clear()
            assert determinism._gpu_plugin_installed() is found, (value, namespace)
    finally:
        # the namespace package imported here keeps the temporary path in sys.modules:
        # left there, every later run in this process would find the fake ROCm plugin,
        # set the GPU flag in XLA_FLAGS and so change the compilation cache's keys
        for name, module in list(sys.modules.items()):
            where = [*getattr(module, "__path__", []), getattr(module, "__file__", None) or ""]
            if any(str(tmp_path) in str(p) for p in where):
                del sys.modules[name]
        determinism._gpu_plugin_installed.cache_clear()
    assert determinism.gpu_possible() is before


def _backend(monkeypatch, started: bool, platform: str = "cpu"):
    monkeypatch.setattr(determinism, "_backend_started", lambda: started)
    import jax

    monkeypatch.setattr(jax, "devices", lambda: [types.SimpleNamespace(platform=platform)])


def test_apply_sets_the_flag_before_the_backend_starts(monkeypatch, gpu):
    monkeypatch.setenv("XLA_FLAGS", "")
    _backend(monkeypatch, started=False)
    assert determinism.apply(False) is False and determinism.flag_in_env() is None
    assert determinism.apply(None) is True and determinism.flag_in_env() is True  # default
    assert determinism.apply(True) is True
    assert determinism.apply(False) is False  # the backend has not read it yet
    monkeypatch.setenv("XLA_FLAGS", f"{FLAG}=false")
    assert determinism.apply(None) is False  # the user's XLA_FLAGS


def test_apply_after_the_backend_started(monkeypatch, gpu):
    monkeypatch.setenv("XLA_FLAGS", "")
    _backend(monkeypatch, started=True, platform="cpu")
    for asked in (None, True, False):
        assert determinism.apply(asked) is True  # CPU kernels are deterministic anyway
    assert determinism.flag_in_env() is None  # the cache key of later programs unchanged
    _backend(monkeypatch, started=True, platform="gpu")
    assert determinism.apply(False) is False
    assert determinism.apply(None) is False  # what the process has
    with pytest.raises(InputError, match=r"^deterministic = True: JAX has started") as err:
        determinism.apply(True)
    assert "\n" not in str(err.value) and "=false" in str(err.value)
    monkeypatch.setenv("XLA_FLAGS", f"{FLAG}=true")  # set before the backend started
    assert determinism.apply(True) is True and determinism.apply(None) is True
    with pytest.raises(InputError, match=r"^deterministic = False: .*=true; set XLA_FLAGS"):
        determinism.apply(False)


def test_bad_values_are_one_line_naming_the_option(tmp_path):
    import mjx_radar

    with pytest.raises(
        ScenarioError, match=r"^deterministic = 'yes': must be True, False or None$"
    ):
        mjx_radar.simulate("smoke", deterministic="yes")
    with pytest.raises(ScenarioError, match=r"^deterministic = 1: must be True, False or None$"):
        mjx_radar.run_study("smoke", trials=2, chunk=2, out=tmp_path / "s", deterministic=1)
    assert not (tmp_path / "s").exists()


def test_command_line_option():
    from mjx_radar.cli.main import build_parser

    parse = build_parser().parse_args
    for cmd in (["run", "smoke"], ["study", "smoke", "--out", "x"]):
        assert parse(cmd).deterministic is None  # on where a GPU may start (the default)
        assert parse([*cmd, "--deterministic"]).deterministic is True
        assert parse([*cmd, "--no-deterministic"]).deterministic is False


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
        "determinism._gpu_plugin_installed = lambda: True  # as on a GPU machine\n"
        "assert determinism.apply(None) is True\n"
        "assert not xla_bridge.backends_are_initialized()\n"
        "assert '--xla_gpu_deterministic_ops=true' in os.environ['XLA_FLAGS']\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-1000:]


@pytest.mark.parametrize("platforms, possible", [("cpu", False), ("cuda,cpu", True), ("", True)])
def test_jax_platforms_decides_before_plugins(platforms, possible):
    """``JAX_PLATFORMS=cpu`` keeps JAX off an installed GPU plugin: nothing is set then."""
    import os
    import subprocess
    import sys

    code = (
        "from mjx_radar.engine import determinism as d\n"
        "d._gpu_plugin_installed = lambda: True\n"
        f"assert d.gpu_possible() is {possible}\n"
    )
    env = {**os.environ, "JAX_PLATFORMS": platforms}
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert proc.returncode == 0, proc.stderr[-1000:]
