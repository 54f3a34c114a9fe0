"""PSD helpers for batches of small matrices held entry by entry (structure of arrays).

A batch of n×n matrices is given as entries ``a[i][j]``, each an array over the batch
``[...]``; every function is unrolled at trace time into elementwise arithmetic. In
the MPPI objective (hundreds of thousands of 3×3 and 6×6 matrices per iteration) this
is what XLA vectorises on the CPU and fuses into few kernels on the GPU; batched
``[..., n, n]`` arrays with a small minor dimension were ~4-10x slower on 2 CPU cores.

The algorithms are those of :mod:`mjx_radar.estimation.linalg` (same relative jitter
δ, the same Gill-Murray pivot floor), so results agree with its array functions to
round-off (tests/test_linalg.py).
"""

from __future__ import annotations

import functools

import jax.numpy as jnp

__all__ = [  # noqa: RUF022
    "psd_cholesky_entries",
    "inv_from_cholesky_entries",
    "logdet_from_cholesky_entries",
    "logdet_sym3",
    "entries",
    "from_entries",
]


def _cholesky_entries(a, floor):
    """``linalg``'s floored Cholesky on a matrix given as entries ``a[i][j]`` (``[...]`` each).

    The same Gill-Murray modified Cholesky, written on one array per entry so that a
    batch of small matrices is pure elementwise arithmetic (contiguous in the batch,
    vectorised by XLA on every backend). Returns the lower factor as entries
    ``L[i][j]`` for ``j <= i``.
    """
    n = len(a)
    diag_max = functools.reduce(jnp.maximum, [jnp.abs(a[i][i]) for i in range(n)])
    off = [jnp.abs(a[i][j]) for i in range(n) for j in range(i)]
    beta2 = diag_max + floor
    if off:
        off_max = functools.reduce(jnp.maximum, off) / max(1.0, (n * n - 1.0) ** 0.5)
        beta2 = jnp.maximum(diag_max, off_max) + floor
    L = [[None] * n for _ in range(n)]
    for j in range(n):
        v = [a[i][j] - sum((L[i][k] * L[j][k] for k in range(j)), 0.0) for i in range(j, n)]
        below = functools.reduce(jnp.maximum, [x * x for x in v[1:]], 0.0)
        ljj = jnp.sqrt(jnp.maximum(jnp.maximum(v[0], floor), below / beta2))
        L[j][j] = ljj
        for i in range(j + 1, n):
            L[i][j] = v[i - j] / ljj
    return L


def psd_cholesky_entries(a):
    """`linalg.psd_cholesky` of a symmetric matrix given as entries ``a[i][j]`` (``[...]`` each).

    Only ``a[i][j]`` with ``j <= i`` are read. Returns the lower factor ``L[i][j]``
    (``j <= i``; ``None`` above the diagonal) of ``A + δI`` with the same δ.
    """
    n = len(a)
    a = [[a[max(i, j)][min(i, j)] for j in range(n)] for i in range(n)]
    dtype = jnp.result_type(*[a[i][j] for i in range(n) for j in range(i + 1)], float)
    finfo = jnp.finfo(dtype)
    diag = [jnp.abs(a[i][i]) for i in range(n)]
    entries = functools.reduce(jnp.maximum, [jnp.abs(x) for row in a for x in row])
    scale = jnp.maximum(sum(diag) / n, entries / n)
    delta = 10.0 * finfo.eps * scale + jnp.sqrt(jnp.asarray(finfo.tiny, dtype))
    shifted = [[a[i][j] + delta if i == j else a[i][j] for j in range(n)] for i in range(n)]
    return _cholesky_entries(shifted, delta)


def inv_from_cholesky_entries(L):
    """``(L Lᵀ)⁻¹`` as symmetric entries from a lower factor's entries ``L[i][j]``.

    ``L⁻¹`` by forward substitution, then ``(L⁻¹)ᵀ L⁻¹``; entry-wise (see
    :func:`_cholesky_entries`).
    """
    n = len(L)
    li = [[None] * n for _ in range(n)]  # L⁻¹, lower
    for i in range(n):
        li[i][i] = 1.0 / L[i][i]
        for j in range(i):
            li[i][j] = -sum(L[i][k] * li[k][j] for k in range(j, i)) * li[i][i]
    out = [[None] * n for _ in range(n)]
    for i in range(n):
        for j in range(i + 1):
            out[i][j] = out[j][i] = sum(li[k][i] * li[k][j] for k in range(i, n))
    return out


def logdet_from_cholesky_entries(L):
    """``log det(L Lᵀ) = 2 Σ log L_ii`` from a lower factor's entries."""
    return 2.0 * sum(jnp.log(L[i][i]) for i in range(len(L)))


def entries(A):
    """``[..., n, n]`` -> entries ``a[i][j]`` (``[...]`` each)."""
    n = A.shape[-1]
    return [[A[..., i, j] for j in range(n)] for i in range(n)]


def from_entries(a):
    """Entries ``a[i][j]`` (full, ``[...]`` each) -> ``[..., n, n]``."""
    return jnp.stack([jnp.stack(row, axis=-1) for row in a], axis=-2)


def logdet_sym3(xx, xy, xz, yy, yz, zz, floor=0.0):
    """Unrolled LDLᵀ (square-root-free Cholesky) log-determinant of symmetric 3×3 matrices.

    ``log det A = Σ log D_ii`` with ``D_11 = a11``, ``D_22 = a22 − a21²/D_11``,
    ``D_33 = a33 − a31²/D_11 − (a32 − a31 a21/D_11)²/D_22``. Elementwise on the six
    unique entries (each ``[...]``), so it vectorises over millions of matrices (the
    MPPI objective), where a batched LAPACK call per matrix would dominate. Each
    pivot is floored at the same relative jitter δ as `linalg.psd_cholesky`, so the
    result is finite for every finite input.

    Args:
        xx, xy, xz, yy, yz, zz: the entries ``a11, a21, a31, a22, a32, a33``, each ``[...]``.
        floor: absolute diagonal floor added first (scalar).

    Returns:
        ``[...]`` ``log det(A + floor·I)``.
    """
    dtype = jnp.result_type(xx, xy, xz, yy, yz, zz, float)
    xx, xy, xz, yy, yz, zz = (
        jnp.asarray(a, dtype) for a in jnp.broadcast_arrays(xx, xy, xz, yy, yz, zz)
    )
    finfo = jnp.finfo(dtype)
    floor = jnp.asarray(floor, dtype)
    xx, yy, zz = xx + floor, yy + floor, zz + floor
    scale = (jnp.abs(xx) + jnp.abs(yy) + jnp.abs(zz)) / 3.0
    delta = 10.0 * finfo.eps * scale + jnp.sqrt(jnp.asarray(finfo.tiny, dtype))
    d1 = jnp.maximum(xx + delta, delta)
    l21, l31 = xy / d1, xz / d1
    d2 = jnp.maximum(yy + delta - l21 * xy, delta)
    l32 = (yz - l31 * xy) / d2
    d3 = jnp.maximum(zz + delta - l31 * xz - l32 * l32 * d2, delta)
    return jnp.log(d1) + jnp.log(d2) + jnp.log(d3)
