"""The executable cache (engine.executable_cache): compiled programs loaded without lowering.

The closed loop's own round trip across processes, with its numbers, is in
``tests/test_program_lock.py`` (the other process compiles, this one loads its
executables); here the cache's parts on a small program.
"""

from __future__ import annotations

import os

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjx_radar.engine import compile_cache, executable_cache


def _program(seed: float):
    """A small flat program ``(x, y) -> (a, b)`` with its own constant (its own HLO)."""

    def f(x, y):
        return jnp.broadcast_to(x, (4, 3)) * (jnp.arange(3.0) + seed) + y, jnp.sum(x * y[0])

    return jax.jit(f, donate_argnums=(1,)).lower(jnp.ones(3), jnp.ones((4, 3)))


def test_round_trip_reproduces_the_outputs_and_the_call_contract(tmp_path):
    compiled, _ = executable_cache.compile_lowered(_program(0.25))
    file = tmp_path / "exe.bin"
    executable_cache.save(file, (compiled, compiled))
    loaded = executable_cache.load(file, jax.local_devices()[:1])
    assert loaded is not None and len(loaded) == 2
    x = jnp.asarray([1.0, -2.0, 0.5])
    want = compiled(x, jnp.full((4, 3), 3.0))
    for c in loaded:
        got = c(x, jnp.full((4, 3), 3.0))
        assert jax.tree.structure(got) == jax.tree.structure(want)
        for a, b in zip(got, want, strict=True):
            np.testing.assert_array_equal(a, b)
    with pytest.raises(TypeError):  # the argument count is checked as before
        loaded[0](x)


def test_unreadable_files_are_ignored(tmp_path):
    compiled, _ = executable_cache.compile_lowered(_program(0.5))
    file = tmp_path / "exe.bin"
    executable_cache.save(file, (compiled,))
    raw = file.read_bytes()
    assert executable_cache.load(tmp_path / "absent.bin", jax.local_devices()) is None
    for damaged in (raw[: len(raw) // 2], b"not ours" + raw[8:], b""):
        file.write_bytes(damaged)
        assert executable_cache.load(file, jax.local_devices()[:1]) is None
    assert executable_cache.load(None, jax.local_devices()) is None
    executable_cache.save(None, (compiled,))  # no store: nothing written, no error


def test_a_persistent_cache_hit_is_not_fresh():
    """JAX's persistent cache answering (on the CPU such an executable serialises without
    its code) is told apart from XLA compiling."""
    if not compile_cache.enabled():
        pytest.skip("the session's persistent cache is off (--no-cache run)")
    seed = float(np.random.default_rng().uniform(1.0, 2.0))  # an HLO no run has compiled
    _, fresh = executable_cache.compile_lowered(_program(seed))
    assert fresh
    jax.clear_caches()  # the in-memory caches: the next compile asks the persistent one
    _, again = executable_cache.compile_lowered(_program(seed))
    assert not again


def test_cache_hits_are_written_off_the_cpu_only(tmp_path, monkeypatch):
    """An executable JAX's persistent cache answered is written on GPUs (it serialises
    whole there: written, loaded and run again on an H100 with the same metrics), never on
    the CPU (it would lack its code); XLA's own compilations everywhere. Without this a
    program whose code fingerprint changed but whose HLO did not (a package upgrade) never
    got its executable file on a GPU host."""
    hit = executable_cache.compile_lowered(_program(0.75))[0]
    monkeypatch.setattr(executable_cache, "compile_lowered", lambda lowered: (hit, False))
    assert executable_cache._platform((hit,)) == "cpu"
    for platform, written in (("cpu", False), ("gpu", True)):
        monkeypatch.setattr(executable_cache, "_platform", lambda compiled, p=platform: p)
        file = tmp_path / f"exe-{platform}.bin"
        (out,), seconds = executable_cache.compile_and_save(file, (_program(0.75),))
        assert out is hit and file.exists() == written and (seconds > 0) == written
    monkeypatch.setattr(executable_cache, "compile_lowered", lambda lowered: (hit, True))
    executable_cache.compile_and_save(tmp_path / "fresh.bin", (_program(0.75),))
    assert (tmp_path / "fresh.bin").exists()  # fresh: written on the CPU too


def test_the_key_holds_the_xla_flags(monkeypatch):
    dev = jax.local_devices()[0]
    base = executable_cache.compile_key(dev)
    flags = os.environ.get("XLA_FLAGS", "")
    monkeypatch.setenv("XLA_FLAGS", flags + " --xla_cpu_enable_fast_math=false")
    assert executable_cache.compile_key(dev) != base
    monkeypatch.setenv("XLA_FLAGS", flags)
    assert executable_cache.compile_key(dev) == base
