"""Throughput of the planner's PFIM recursion (``fisher.pfim_logdets``) over a large batch.

One MPPI call of a study chunk evaluates the recursion for chunk × samples × targets
(250 × 200 × 4 = 200 k) 6×6 information matrices over the horizon, five times. This
times one evaluation of ``E`` matrices over ``T`` steps, for the entry-wise form as it
is, with XLA optimisation barriers between its stages, and (a timing reference) on
batched ``[E, 6, 6]`` matrices (``--variants``)::

    python benchmarks/bench_pfim.py [--elements 200000] [--steps 15] [--calls 20]
"""

from __future__ import annotations

import argparse
import time

import jax
import jax.numpy as jnp
import numpy as np

from mjx_radar.estimation import linalg_small
from mjx_radar.estimation.information import fisher
from mjx_radar.physics.motion import cv_process_noise, cv_transition


def _barriered(fn):
    def wrapped(*a, **k):
        out = fn(*a, **k)
        flat = [x for row in out for x in row if x is not None]
        flat = iter(jax.lax.optimization_barrier(flat))
        return [[next(flat) if x is not None else None for x in row] for row in out]

    return wrapped


def _matrix_form(j0, a, w, s2, jd, floor=fisher.INFO_FLOOR):
    """The same recursion on ``[E, 6, 6]`` arrays (batched Cholesky and solves; plain
    Cholesky without the Gill-Murray floor: a timing reference, not a replacement)."""
    eye = jnp.eye(6, dtype=j0.dtype)
    sol = jax.scipy.linalg.cho_solve

    def step(j, jdt):
        jinv = sol((jnp.linalg.cholesky(j), True), jnp.broadcast_to(eye, j.shape))
        prior = a @ jinv @ a.T + s2 * w
        new = sol((jnp.linalg.cholesky(prior), True), jnp.broadcast_to(eye, j.shape))
        xx, xy, xz, yy, yz, zz = jdt
        d = jnp.stack([jnp.stack([xx, xy, xz], -1), jnp.stack([xy, yy, yz], -1),
                       jnp.stack([xz, yz, zz], -1)], -2)  # fmt: skip
        new = new.at[..., :3, :3].add(d)
        chol = jnp.linalg.cholesky(new + floor * eye)
        return new, 2.0 * jnp.log(jnp.diagonal(chol, axis1=-2, axis2=-1)).sum(-1)

    return jax.lax.scan(step, j0, jd)[1]


def run(variant: str, e: int, t: int, calls: int) -> float:
    a, w = np.asarray(cv_transition(0.1)), np.asarray(cv_process_noise(0.1, 1.0))
    key = jax.random.PRNGKey(0)
    x = jax.random.normal(key, (e, 6, 6)) * 0.1
    j0 = jnp.einsum("...ij,...kj->...ik", x, x) + 50.0 * jnp.eye(6)
    jd = tuple(jnp.abs(jax.random.normal(key, (t, e))) for _ in range(6))
    saved = linalg_small.psd_cholesky_entries, linalg_small.inv_from_cholesky_entries
    if variant == "barrier":
        linalg_small.psd_cholesky_entries = _barriered(saved[0])
        linalg_small.inv_from_cholesky_entries = _barriered(saved[1])
    try:
        form = _matrix_form if variant == "matrix" else fisher.pfim_logdets
        f = jax.jit(lambda j0, jd: form(j0, a, w, 2.0, jd).sum())
        t0 = time.perf_counter()
        jax.block_until_ready(f(j0, jd))
        compile_s = time.perf_counter() - t0
    finally:
        linalg_small.psd_cholesky_entries, linalg_small.inv_from_cholesky_entries = saved
    times = []
    for _ in range(calls):
        t0 = time.perf_counter()
        jax.block_until_ready(f(j0, jd))
        times.append(time.perf_counter() - t0)
    med = float(np.median(times))
    print(
        f"{variant:8s} E={e} T={t} on {jax.devices()[0].device_kind}: compile {compile_s:.1f} s, "
        f"median {med * 1e3:.2f} ms ({e * t / med / 1e6:.1f} M matrix-steps/s)",
        flush=True,
    )
    return med


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--elements", type=int, default=200_000)
    ap.add_argument("--steps", type=int, default=15)
    ap.add_argument("--calls", type=int, default=20)
    ap.add_argument("--variants", default="entries,barrier,matrix")
    args = ap.parse_args()
    for v in args.variants.split(","):
        run(v, args.elements, args.steps, args.calls)


if __name__ == "__main__":
    main()
