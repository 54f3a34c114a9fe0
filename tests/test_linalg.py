"""Tests of mjx_radar.estimation.linalg against numpy/LAPACK references."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjx_radar.estimation import linalg
from mjx_radar.estimation import linalg_small as ls


def _random_spd(rng, batch, n, cond=1e3):
    q, _ = np.linalg.qr(rng.standard_normal((*batch, n, n)))
    eig = np.logspace(0, np.log10(cond), n)
    return (q * eig[..., None, :]) @ np.swapaxes(q, -1, -2)


def test_symmetrize():
    a = np.arange(9.0).reshape(3, 3)
    np.testing.assert_array_equal(np.asarray(linalg.symmetrize(a)), 0.5 * (a + a.T))


def test_cholesky_solve_inv_logdet_match_numpy_float64():
    rng = np.random.default_rng(0)
    A = _random_spd(rng, (4,), 9)
    B = rng.standard_normal((4, 9, 5))
    with jax.enable_x64(True):
        L, X, x, Ainv, ld = (
            np.asarray(a)
            for a in jax.jit(  # one program (suite time: eager ops compile one by one)
                lambda A, B: (
                    linalg.psd_cholesky(A),
                    linalg.psd_solve(A, B),
                    linalg.psd_solve(A, B[..., 0]),
                    linalg.psd_inv(A),
                    linalg.logdet_psd(A),
                )
            )(A, B)
        )
    assert L.dtype == np.float64
    # cond 1e3, jitter 2.2e-15 relative: factors agree to ~1e-13 relative; 1e-11 is safe.
    np.testing.assert_allclose(L, np.linalg.cholesky(A), rtol=0, atol=1e-11 * np.abs(A).max())
    np.testing.assert_allclose(X, np.linalg.solve(A, B), rtol=1e-10)  # cond*eps ~ 2e-13
    np.testing.assert_allclose(x, np.linalg.solve(A, B[..., :1])[..., 0], rtol=1e-10)
    np.testing.assert_allclose(Ainv, np.linalg.inv(A), rtol=1e-10, atol=1e-13)
    # log det error = tr(A^-1 dA) ~ n * 2.2e-15 * cond: far below 1e-10.
    np.testing.assert_allclose(ld, np.linalg.slogdet(A)[1], rtol=0, atol=1e-10)


def test_float32_accuracy_and_dtype():
    rng = np.random.default_rng(1)
    A = _random_spd(rng, (), 12, cond=1e2).astype(np.float32)
    L, logdet, inv = jax.jit(  # one program (suite time: eager ops compile one by one)
        lambda A: (linalg.psd_cholesky(A), linalg.logdet_psd(A), linalg.psd_inv(A))
    )(A)
    assert L.dtype == jnp.float32
    ref = np.linalg.cholesky(A.astype(np.float64))
    # float32 eps 1.2e-7, jitter 1.2e-6 relative, cond 1e2 -> ~1e-5 relative is ample.
    np.testing.assert_allclose(np.asarray(L), ref, atol=2e-5 * np.abs(ref).max())
    assert logdet.dtype == jnp.float32
    assert inv.dtype == jnp.float32


def test_batched_equals_vmap_and_jit():
    rng = np.random.default_rng(2)
    A = _random_spd(rng, (2, 3), 5).astype(np.float32)
    batched, logdet = jax.jit(lambda A: (linalg.psd_cholesky(A), linalg.logdet_psd(A)))(A)
    mapped = jax.jit(jax.vmap(jax.vmap(linalg.psd_cholesky)))(A)
    # identical arithmetic up to XLA fusion order: a few float32 ulps.
    np.testing.assert_allclose(np.asarray(batched), np.asarray(mapped), rtol=1e-5, atol=1e-6)
    assert logdet.shape == (2, 3)


@jax.jit  # one program per dtype for every kind (suite time: eager ops compile one by one)
def _degenerate_outputs(A):
    return (
        linalg.psd_cholesky(A),
        linalg.logdet_psd(A),
        linalg.logdet_psd(A, floor=1e-6),
        linalg.psd_solve(A, jnp.ones(A.shape[-1], A.dtype)),
    )


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize(
    "kind", ["zero", "rank1", "rank_deficient", "slightly_indefinite", "indefinite"]
)
def test_degenerate_inputs_are_finite(kind, dtype):
    rng = np.random.default_rng(3)
    n = 6
    v = rng.standard_normal((n, 2))
    A = {
        "zero": np.zeros((n, n)),
        "rank1": np.outer(v[:, 0], v[:, 0]),
        "rank_deficient": v @ v.T,
        "slightly_indefinite": v @ v.T + np.eye(n) - np.diag([1.0] * 5 + [1.001]),
        "indefinite": np.array(rng.standard_normal((n, n))),
    }[kind].astype(dtype)
    with jax.enable_x64(dtype == np.float64):
        L, ld, ld_floor, X = _degenerate_outputs(A)
        L, ld, ld_floor, X = np.asarray(L), float(ld), float(ld_floor), np.asarray(X)
    assert np.all(np.isfinite(L)) and np.all(np.isfinite(X))
    assert np.isfinite(ld) and np.isfinite(ld_floor)
    np.testing.assert_array_equal(np.triu(L, 1), 0.0)
    assert np.all(np.diag(L) > 0)
    if kind in ("rank1", "rank_deficient"):
        # PSD input: the factor still reproduces A up to the relative jitter (float32: ~1e-6).
        tol = 1e-5 if dtype == np.float32 else 1e-12
        np.testing.assert_allclose(L @ L.T, A, atol=tol * np.abs(A).max())


def test_logdet_floor_value():
    # zero information floored at 1e-6: log det = n log(1e-6) (relative jitter is ~0 here).
    logdet = jax.jit(lambda A: linalg.logdet_psd(A, floor=1e-6))  # one program
    np.testing.assert_allclose(float(logdet(jnp.zeros((3, 3)))), 3 * np.log(1e-6), rtol=1e-5)


def test_logdet_gradient_is_inverse():
    rng = np.random.default_rng(4)
    A = _random_spd(rng, (), 4, cond=10.0)
    with jax.enable_x64(True):
        g = np.asarray(jax.jit(jax.grad(linalg.logdet_psd))(jnp.asarray(A)))
    # d logdet / dA = A^{-1} (symmetrised input): exact up to float64 rounding.
    np.testing.assert_allclose(0.5 * (g + g.T), np.linalg.inv(A), rtol=1e-9, atol=1e-12)


@jax.jit  # one program per n for every kind (suite time: eager ops compile one by one)
def _entry_and_array_forms(A):
    n = A.shape[-1]
    L_ref = linalg.psd_cholesky(A)
    L = ls.psd_cholesky_entries(ls.entries(A))
    zero = jnp.zeros(A.shape[0])
    L = ls.from_entries([[L[i][j] if j <= i else zero for j in range(n)] for i in range(n)])
    logdet = ls.logdet_from_cholesky_entries(ls.psd_cholesky_entries(ls.entries(A)))
    inv = ls.from_entries(ls.inv_from_cholesky_entries(L_entries(ls, A)))
    packed = ((0, 0), (1, 0), (2, 0), (1, 1), (2, 1), (2, 2))
    sym3 = ls.logdet_sym3(*(A[..., i, j] for i, j in packed)) if n == 3 else None
    return L_ref, L, logdet, inv, sym3


@pytest.mark.parametrize("n", [1, 2, 3, 6])
@pytest.mark.parametrize("kind", ["pd", "singular", "indefinite"])
def test_entry_form_matches_array_form(n, kind):
    """linalg_small (one array per entry) is the same algorithm as linalg's arrays: the
    Cholesky factor agrees to round-off for PD, singular and indefinite input (float64);
    inverse and log det agree where they are well conditioned."""
    rng = np.random.default_rng(n)
    B = rng.standard_normal((40, n, n))
    A = {"pd": B @ np.swapaxes(B, -1, -2) + 0.1 * np.eye(n),
         "singular": B[..., :1] @ np.swapaxes(B[..., :1], -1, -2),
         "indefinite": B + np.swapaxes(B, -1, -2)}[kind]  # fmt: skip
    with jax.enable_x64(True):
        L_ref, L, logdet, inv, sym3 = _entry_and_array_forms(A)
        L_ref, L, logdet, inv = (np.asarray(a) for a in (L_ref, L, logdet, inv))
        scale = np.abs(L_ref).max()
        np.testing.assert_allclose(L, L_ref, atol=1e-12 * scale if kind != "singular" else 1e-7)
        assert np.all(np.isfinite(L))
        # (a singular input's log det is set by round-off-sized pivots: not compared)
        if kind != "singular":
            want = 2 * np.log(np.diagonal(L_ref, 0, -2, -1)).sum(-1)
            np.testing.assert_allclose(logdet, want, atol=1e-9)
        if kind == "pd":
            np.testing.assert_allclose(inv, np.linalg.inv(A), rtol=1e-9, atol=1e-12)
            if n == 3:
                np.testing.assert_allclose(sym3, np.linalg.slogdet(A)[1], atol=1e-12)  # jitter δ


def L_entries(ls, A):
    return ls.psd_cholesky_entries(ls.entries(jnp.asarray(A)))


def test_factorisations_traced_once_per_shape():
    """psd_cholesky / psd_solve / psd_inv are jitted: called twice on the same shapes in
    one program, both calls share one traced jaxpr (traced, batched and lowered once)."""

    def two_solves(a, b):
        return linalg.psd_solve(a, b), linalg.psd_solve(a + 1.0, b), linalg.psd_inv(a)

    closed = jax.make_jaxpr(two_solves)(jnp.eye(4), jnp.ones((4, 2)))
    calls = [e.params["jaxpr"] for e in closed.jaxpr.eqns if "jaxpr" in e.params]
    assert len(calls) == 3 and calls[0] is calls[1] and calls[2] is not calls[0]
    x = jnp.array([[4.0, 1.0], [1.0, 3.0]])
    # still the solve: the relative jitter delta = 10 eps scale (1.2e-6 x 4) bounds the error
    np.testing.assert_allclose(linalg.psd_inv(x) @ x, np.eye(2), atol=1e-5)
