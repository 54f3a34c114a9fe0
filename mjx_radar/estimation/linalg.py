"""PSD-safe linear algebra: the one place covariance and information solves go through.

Every covariance (CKF) and information matrix (SFIM/PFIM) in :mod:`mjx_radar` is
symmetric positive (semi-)definite in exact arithmetic, but float32 round-off
(e.g. the ``P - K Pzz Kᵀ`` subtraction of a Kalman update, or a rank-3 Fisher
matrix of a target seen by one radar) can make it slightly asymmetric or
indefinite. :func:`jax.numpy.linalg.cholesky` then silently returns NaN, which
would poison a whole ``lax.scan``. The helpers here therefore

1. symmetrise: ``A <- (A + Aᵀ)/2`` (removes round-off asymmetry);
2. add a small *relative* jitter ``δ = 10·eps·scale + sqrt(tiny)`` with
   ``scale = max(mean|diag A|, max|A_ij|/n)`` (= mean diag for a PSD matrix),
   ``eps``/``tiny`` of the dtype (δ ≈ 1.2e-6·scale in float32, 2.2e-15·scale in
   float64; the ``sqrt(tiny)`` term lets an all-zero matrix factor);
3. factor ``A + δI`` with a modified Cholesky (Gill & Murray): every pivot is
   floored at δ and raised where needed so that ``|L_ij| <= β``
   (β² = max(max|a_ii|, max|a_ij|/sqrt(n²−1))). For a PD input both safeguards
   are inactive (every pivot of ``A + δI`` is ≥ δ and ``|L_ij| <= sqrt(a_jj)``);
   for a singular or indefinite input the factor stays finite with
   ``diag(L) >= sqrt(δ)``. Hence ``logdet`` is finite and nothing is ever NaN for
   finite input, with no Python control flow on traced values.

The factorisation and the triangular solves are written in pure JAX
(``lax.fori_loop`` over columns, O(n³), intended for the small n ≤ ~30 here)
instead of calling LAPACK: besides allowing the pivot floor, this sidesteps a
deadlock of jaxlib 0.10's CPU LAPACK kernels (``potrf``/``trsm`` split a vmapped
batch over the XLA intra-op pool with ``ParallelBatchMap`` and block; two such
kernels running concurrently on a 2-thread pool hang forever, observed on a
vmapped+scanned filter).

The jitter perturbs results by a relative ``O(10·eps)``; in float64 this is below
1e-13 and invisible to the exact-arithmetic tests.

All functions are pure JAX, accept arbitrary leading batch dimensions
(``A[..., n, n]``), and preserve the input dtype. Inputs must be finite: a NaN
input is propagated, never hidden.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
from jax import lax

from mjx_radar.batching import batched_like
from mjx_radar.estimation import linalg_small

__all__ = ["symmetrize", "psd_cholesky", "psd_solve", "psd_inv", "logdet_psd"]


def _float_dtype(A):
    """Floating dtype of ``A`` (integers are promoted to the default float)."""
    dtype = jnp.result_type(A)
    return dtype if jnp.issubdtype(dtype, jnp.floating) else jnp.result_type(float)


def symmetrize(A):
    """Symmetric part of ``A``.

    Args:
        A: ``[..., n, n]`` matrix.

    Returns:
        ``(A + Aᵀ)/2``, ``[..., n, n]``.
    """
    A = jnp.asarray(A, dtype=_float_dtype(A))
    return 0.5 * (A + jnp.swapaxes(A, -1, -2))


def _jitter(A):
    """Relative jitter ``δ[..., 1]`` for symmetric ``A[..., n, n]`` (see module docstring)."""
    finfo = jnp.finfo(A.dtype)
    n = A.shape[-1]
    diag = jnp.diagonal(A, axis1=-2, axis2=-1)
    scale = jnp.maximum(jnp.mean(jnp.abs(diag), axis=-1), jnp.max(jnp.abs(A), axis=(-2, -1)) / n)
    tiny = jnp.sqrt(jnp.asarray(finfo.tiny, A.dtype))
    return (10.0 * finfo.eps * scale + tiny)[..., None]


UNROLL_MAX = 8
"""On accelerators, matrices up to this size are factored with Python-unrolled loops: one
fused elementwise program per factorisation instead of a sequential ``fori_loop`` (the
6×6 PFIM recursion inside the MPPI objective runs on millions of them, and a GPU's loop
iterations are driven from the host). On the CPU every factorisation is a ``fori_loop``
(:func:`_unrolls`)."""


def _unrolls() -> bool:
    """Whether small factorisations are unrolled: not on the CPU, whose backend compiles
    every unrolled column into kernels of its own (half of a closed-loop program's
    operations) while a loop costs nothing there; the programs compile 15-18 % faster with
    the same numbers (docs/notes/scaling-history.md, "Where the CPU compile goes")."""
    return jax.default_backend() != "cpu"


def _loop(n: int, body, init):
    """``lax.fori_loop(0, n, body, init)``, unrolled at trace time when n <= UNROLL_MAX
    on an accelerator."""
    if n > UNROLL_MAX or not _unrolls():
        return lax.fori_loop(0, n, body, init)
    for i in range(n):
        init = body(i, init)
    return init


def _row(X, i):
    """``X[..., i, :]`` for a (possibly traced, unbatched) loop index ``i``."""
    return lax.dynamic_index_in_dim(X, i, axis=X.ndim - 2, keepdims=False)


def _col(X, i):
    """``X[..., :, i]``."""
    return lax.dynamic_index_in_dim(X, i, axis=X.ndim - 1, keepdims=False)


def _cholesky_floored(A, floor):
    """Column-by-column (left-looking) modified Cholesky.

    Pivot ``d_j = max(v_j, floor, max_{i>j} v_i² / β²)`` (Gill & Murray): the floor
    keeps ``d_j > 0`` and the β term bounds ``|L_ij| <= β`` so an indefinite input
    cannot make the factor blow up. Both are inactive for a PD input.

    Pure JAX (``lax.fori_loop`` over the n columns) rather than the LAPACK custom
    call: besides the pivot floor, this avoids a thread-pool deadlock of jaxlib's
    CPU batched ``potrf`` observed under ``vmap`` (see module docstring).
    """
    n = A.shape[-1]
    idx = jnp.arange(n)
    # Gill-Murray bound: |L_ij| <= beta. Inactive for PD input (|L_ij| <= sqrt(a_ii)).
    offdiag = jnp.where(jnp.eye(n, dtype=bool), 0.0, jnp.abs(A))
    beta2 = (
        jnp.maximum(
            jnp.max(jnp.abs(jnp.diagonal(A, axis1=-2, axis2=-1)), axis=-1),
            jnp.max(offdiag, axis=(-2, -1)) / max(1.0, (n * n - 1.0) ** 0.5),
        )[..., None]
        + floor
    )

    def body(j, L):
        v = _col(A, j) - jnp.einsum("...ik,...k->...i", L, _row(L, j))
        v_j = lax.dynamic_slice_in_dim(v, j, 1, axis=v.ndim - 1)
        below = jnp.max(jnp.where(idx > j, v * v, 0.0), axis=-1, keepdims=True)
        d = jnp.maximum(jnp.maximum(v_j, floor), below / beta2)
        ljj = jnp.sqrt(d)
        col = jnp.where(idx > j, v / ljj, 0.0) + jnp.where(idx == j, ljj, 0.0)
        return lax.dynamic_update_index_in_dim(L, col[..., :, None], j, axis=L.ndim - 1)

    return _loop(n, body, batched_like(jnp.zeros_like(A), A))  # (one batching, mjx_radar.batching)


def psd_cholesky(A):
    """Lower Cholesky factor of a (numerically) PSD matrix; never NaN for finite input.

    Computes ``L`` with ``L Lᵀ = sym(A) + δ I``; every pivot is floored at δ so a
    non-PD input still yields a finite factor with ``diag(L) >= sqrt(δ)`` (see the
    module docstring for δ).

    Args:
        A: ``[..., n, n]`` symmetric PSD matrix (asymmetry/indefiniteness from
            round-off is tolerated).

    Returns:
        ``[..., n, n]`` lower-triangular factor with strictly positive diagonal.
    """
    A = symmetrize(A)
    delta = _jitter(A)
    eye = jnp.eye(A.shape[-1], dtype=A.dtype)
    return _cholesky_floored(A + delta[..., None] * eye, delta)


def _solve_lower(L, B):
    """Forward substitution ``L Y = B`` for ``L[..., n, n]``, ``B[..., n, k]``."""

    def body(i, Y):
        l_row = _row(L, i)
        l_ii = lax.dynamic_slice_in_dim(l_row, i, 1, axis=l_row.ndim - 1)
        y_i = (_row(B, i) - jnp.einsum("...n,...nk->...k", l_row, Y)) / l_ii
        return lax.dynamic_update_index_in_dim(Y, y_i, i, axis=Y.ndim - 2)

    return _loop(L.shape[-1], body, batched_like(jnp.zeros_like(B), (L, B)))


def _solve_upper_t(L, Y):
    """Back substitution ``Lᵀ X = Y`` for lower ``L[..., n, n]``, ``Y[..., n, k]``."""
    n = L.shape[-1]

    def body(k, X):
        i = n - 1 - k
        l_col = _col(L, i)
        l_ii = lax.dynamic_slice_in_dim(l_col, i, 1, axis=l_col.ndim - 1)
        x_i = (_row(Y, i) - jnp.einsum("...n,...nk->...k", l_col, X)) / l_ii
        return lax.dynamic_update_index_in_dim(X, x_i, i, axis=X.ndim - 2)

    return _loop(n, body, batched_like(jnp.zeros_like(Y), (L, Y)))


def psd_solve(A, B):
    """Solve ``A X = B`` for symmetric PSD ``A`` through :func:`psd_cholesky`.

    Args:
        A: ``[..., n, n]`` PSD matrix.
        B: ``[..., n, k]`` matrix, or a vector ``[..., n]`` (B is taken as a vector
            when ``B.ndim == 1`` or ``B.ndim == A.ndim - 1``); leading dims broadcast.

    Returns:
        ``A⁻¹ B`` with the shape of ``B`` (broadcast against A's batch dims).
    """
    L = psd_cholesky(A)
    B = jnp.asarray(B, dtype=L.dtype)
    is_vec = B.ndim == 1 or B.ndim == L.ndim - 1
    Bm = B[..., None] if is_vec else B
    batch = jnp.broadcast_shapes(L.shape[:-2], Bm.shape[:-2])
    L = jnp.broadcast_to(L, batch + L.shape[-2:])
    Bm = jnp.broadcast_to(Bm, batch + Bm.shape[-2:])
    X = _solve_upper_t(L, _solve_lower(L, Bm))
    return X[..., 0] if is_vec else X


def psd_inv(A):
    """Symmetric inverse of a PSD matrix.

    Args:
        A: ``[..., n, n]`` PSD matrix.

    Returns:
        ``sym(A⁻¹)``, ``[..., n, n]``.
    """
    A = jnp.asarray(A, dtype=_float_dtype(A))
    eye = jnp.broadcast_to(jnp.eye(A.shape[-1], dtype=A.dtype), A.shape)
    return symmetrize(psd_solve(A, eye))


def logdet_psd(A, floor=0.0):
    """``log det(A + floor·I)`` of a PSD matrix, finite and NaN-free.

    Computed as ``2 Σ log diag(L)`` with ``L = psd_cholesky(A + floor·I)``. For a
    rank-deficient ``A`` and ``floor = 0`` the result is finite but dominated by
    the jitter δ; pass an absolute ``floor`` (e.g.
    :data:`mjx_radar.estimation.information.fisher.INFO_FLOOR`
    = 1e-6 1/m² for Fisher matrices with entries O(1e-2..1e2)) to make such
    values meaningful and smooth.

    Args:
        A: ``[..., n, n]`` PSD matrix.
        floor: absolute diagonal floor added before factorising (scalar).

    Returns:
        ``[...]`` log-determinants.
    """
    A = jnp.asarray(A, dtype=_float_dtype(A))
    A = A + jnp.asarray(floor, A.dtype) * jnp.eye(A.shape[-1], dtype=A.dtype)
    if A.shape[-1] == 3:
        return _logdet3(A)
    L = psd_cholesky(A)
    d = jnp.diagonal(L, axis1=-2, axis2=-1)
    return 2.0 * jnp.sum(jnp.log(d), axis=-1)


def _logdet3(A):
    """:func:`linalg_small.logdet_sym3` of the entries of ``sym(A)``, ``A[..., 3, 3]``."""
    A = symmetrize(A)
    a = [[A[..., i, j] for j in range(3)] for i in range(3)]
    return linalg_small.logdet_sym3(a[0][0], a[1][0], a[2][0], a[1][1], a[2][1], a[2][2])


# One trace per program and matrix shape: the filter and the planner factor matrices of
# the same shapes several times per step (the CKF's covariance in predict and update,
# the PFIM's blocks). A jitted function's trace, its batching under vmap and its
# lowering are reused at every call with the same input types, and XLA inlines the
# calls before it optimises (the same program, the same numbers).
psd_cholesky = jax.jit(psd_cholesky)
psd_solve = jax.jit(psd_solve)
psd_inv = jax.jit(psd_inv)
