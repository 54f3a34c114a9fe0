"""The memory a run may count on: free host RAM, the device's free memory, a user's cap.

On the CPU device and host share ``MemAvailable`` of ``/proc/meminfo``; on a GPU the
device has ``bytes_limit - bytes_in_use`` of ``jax.Device.memory_stats()``. Either is
capped by ``$MJX_RADAR_MEMORY_LIMIT`` (:func:`memory_limit`), read by the memory check of
:mod:`mjx_radar.engine.resources` before anything is compiled.
"""

from __future__ import annotations

import os
import re

from mjx_radar.errors import InputError

#: caps the memory a run may count on [bytes, or with K/M/G/T]: a shared machine, a test
LIMIT_ENV = "MJX_RADAR_MEMORY_LIMIT"


def memory_limit() -> int | None:
    """``$MJX_RADAR_MEMORY_LIMIT`` in bytes (``"6G"``, ``"512M"``, ``"2.5e9"``), None if unset.

    The memory check counts on no more than this (on the device and in host RAM): a run
    on a shared machine leaves the rest to others, and a test can force a refusal.

    Raises:
        InputError: the value is not a positive size.
    """
    raw = os.environ.get(LIMIT_ENV, "").strip()
    if not raw:
        return None
    m = re.fullmatch(r"([0-9]*\.?[0-9]+(?:[eE][0-9]+)?)\s*([KMGT]?)i?B?", raw, re.IGNORECASE)
    value = float(m.group(1)) * 1024 ** " KMGT".index(m.group(2).upper() or " ") if m else 0
    if value < 1:
        raise InputError(f"{LIMIT_ENV} = {raw!r}: expected a size > 0 such as 6G, 512M or 2e9")
    return int(value)


def capped(avail: int | None) -> int | None:
    limit = memory_limit()
    return avail if limit is None else limit if avail is None else min(avail, limit)


def host_available() -> int | None:
    """Free host memory [bytes]: ``MemAvailable`` of ``/proc/meminfo``, else ``os.sysconf``."""
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None


def platform() -> str:
    """``"cpu"`` or ``"gpu"`` (``jax.Device.platform``) of this process's first device."""
    import jax

    return jax.local_devices()[0].platform


def device_available() -> tuple[bool, int | None]:
    """``(shared with the host, free bytes on this process's first device or None)``."""
    import jax

    dev = jax.local_devices()[0]  # under jax.distributed, devices()[0] is process 0's
    if dev.platform == "cpu":
        return True, None
    try:
        stats = dev.memory_stats() or {}
    except Exception:  # backends without memory statistics
        return False, None
    if "bytes_limit" not in stats:
        return False, None
    return False, int(stats["bytes_limit"]) - int(stats.get("bytes_in_use", 0))


def allocate_gpu_memory_on_demand() -> None:
    """Asks JAX to take GPU memory as a run needs it instead of reserving 75 % of the
    device at its first transfer (``XLA_PYTHON_CLIENT_PREALLOCATE=false``, before JAX
    starts its backend), unless the user set that variable.

    The reservation took about 1 s of every ``mjx-radar run`` on an H100 before any work,
    and a warm run loads its programs in the background meanwhile waited for it (paper_3r4t,
    600 steps: 7.0-7.8 s -> 5.4-5.6 s; the same numbers). The device's limit
    (``bytes_limit`` of ``memory_stats``, which :func:`check` compares the estimate with)
    is the same either way; what JAX gives up is the protection against fragmentation of
    one large block, which the loop's fixed-size buffers do not need.
    """
    os.environ.setdefault("XLA_PYTHON_CLIENT_PREALLOCATE", "false")
