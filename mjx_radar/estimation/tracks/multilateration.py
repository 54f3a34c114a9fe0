"""Positions from several radars' returns: trilateration and Gauss-Newton (issue 35).

Range-only radars measure ``z_i = 2 ‖x − p_i‖ + ν_i`` (round trip, ``var ν_i = v_i``).
Three ranges fix a point up to its mirror in the plane of the three radars
(:func:`trilaterate`, closed form): with ``e_x = (p_2 − p_1)/d``, ``e_y`` the unit
part of ``p_3 − p_1`` orthogonal to ``e_x``, ``e_z = e_x × e_y``, ``i = e_x·(p_3 − p_1)``,
``j = e_y·(p_3 − p_1)`` and one-way ranges ``r_i = z_i / 2``::

    a = (r_1² − r_2² + d²) / (2d),   b = (r_1² − r_3² + i² + j²) / (2j) − (i/j) a,
    c² = r_1² − a² − b²,             x = p_1 + a e_x + b e_y ± c e_z.

Radars stand on the ground and drones fly above them: of the two solutions the one
with the larger height is kept (``c² < 0`` from noise is clamped to 0 up to a
tolerance, beyond it the triple is inconsistent). More returns refine the point by
Gauss-Newton on the weighted least squares (:func:`gauss_newton`)::

    min_x Σ_i r(z_i, h_i(x))ᵀ R_i⁻¹ r(z_i, h_i(x)) + (x_z − h₀)² / σ_h²

(a weak height prior ``h₀, σ_h``: it makes one range-azimuth return a point, and
changes nothing measurable with several ranges), whose linearised information
``Λ = Σ H_iᵀ R_i⁻¹ H_i + e_z e_zᵀ / σ_h²`` gives the covariance ``Λ⁻¹`` (Cramér-Rao
for the noiseless geometry; the tests check it against a Monte Carlo spread).
Any measurement model works through its ``predict`` and ``residual``.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from mjx_radar.estimation import linalg

__all__ = ["trilaterate", "gauss_newton", "above_radars", "polar_point"]

DISC_TOL = 0.05  # c² >= -DISC_TOL r_1² still counts as consistent (noise), clamped to 0


def trilaterate(p, r):
    """The point at one-way ranges ``r [3]`` from the radars ``p [3, 3]`` (the upper one).

    Returns:
        ``(x [3], ok [])``: ``ok`` False for collinear radars or inconsistent ranges.
    """
    d_vec = p[1] - p[0]
    d = jnp.linalg.norm(d_vec)
    ex = d_vec / jnp.maximum(d, 1e-9)
    q = p[2] - p[0]
    i = ex @ q
    ey_v = q - i * ex
    j = jnp.linalg.norm(ey_v)
    ey = ey_v / jnp.maximum(j, 1e-9)
    ez = jnp.cross(ex, ey)
    ez = jnp.where(ez[2] < 0, -ez, ez)  # the solution above the radars' plane
    a = (r[0] ** 2 - r[1] ** 2 + d**2) / (2 * d)
    b = (r[0] ** 2 - r[2] ** 2 + i**2 + j**2) / (2 * j) - i / j * a
    c2 = r[0] ** 2 - a**2 - b**2
    ok = (d > 1e-3) & (j > 1e-3 * d) & (c2 >= -DISC_TOL * r[0] ** 2) & jnp.all(r > 0)
    x = p[0] + a * ex + b * ey + jnp.sqrt(jnp.maximum(c2, 0.0)) * ez
    return x, ok & jnp.all(jnp.isfinite(x))


def above_radars(x, radar_pos):
    """``x`` reflected to above the mean height of the radars (the range-only mirror)."""
    z0 = jnp.mean(radar_pos[:, 2])
    return x.at[2].set(jnp.where(x[2] < z0, 2 * z0 - x[2], x[2]))


def polar_point(p, rng, az, height):
    """The point at one-way range ``rng``, azimuth ``az`` from ``p [3]`` at height ``height``
    (ground range ``ρ = sqrt(rng² − (height − p_z)²)``, floored at 0)."""
    dz = height - p[2]
    rho = jnp.sqrt(jnp.maximum(rng**2 - dz**2, 0.0))
    return jnp.stack([p[0] + rho * jnp.cos(az), p[1] + rho * jnp.sin(az), height])


def gauss_newton(model, x0, radar_pos, z, r_var, use, h0, sh2, iters: int = 4):
    """Weighted least-squares position from one return per radar (module docstring).

    Args:
        model: the measurement model (``predict``, ``residual``, ``dim``).
        x0: ``[3]`` start; radar_pos: ``[N, 3]``.
        z: ``[N, dim]`` one return per radar; r_var: ``[N, dim]`` its noise variances.
        use: ``[N]`` bool the radars whose return counts.
        h0, sh2: height prior mean [m] and variance [m²].
        iters: Gauss-Newton iterations (static).

    Returns:
        ``(x [3], P [3, 3], chi2 [])``: the point, ``Λ⁻¹`` there, and the weighted sum
        of squared residuals of the used returns at ``x``.
    """
    w = jnp.where(use[:, None], 1.0 / r_var, 0.0)  # [N, dim]
    ez = jnp.array([0.0, 0.0, 1.0], x0.dtype)

    def pred(x, p):
        return model.predict(p[None], x[None]).reshape(model.dim)

    def parts(x):
        zh = jax.vmap(pred, (None, 0))(x, radar_pos)  # [N, dim]
        hj = jax.vmap(jax.jacfwd(pred), (None, 0))(x, radar_pos)  # [N, dim, 3]
        res = jax.vmap(model.residual)(z, zh)  # [N, dim]
        info = jnp.einsum("nda,nd,ndb->ab", hj, w, hj) + jnp.outer(ez, ez) / sh2
        grad = jnp.einsum("nda,nd,nd->a", hj, w, res) + ez * (h0 - x[2]) / sh2
        return info, grad, res

    x = x0
    for _ in range(iters):
        info, grad, _ = parts(x)
        x = x + linalg.psd_solve(info, grad)
        x = above_radars(x, radar_pos)
    info, _, res = parts(x)
    chi2 = jnp.sum(w * res**2)
    return x, linalg.psd_inv(info), chi2
