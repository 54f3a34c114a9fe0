"""A mixed radar fleet ([[radar_override]]): per-radar noise constants and fixed sites."""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np

from mjx_radar.estimation.filters import measurement_filter
from mjx_radar.estimation.sensor import measurement
from mjx_radar.scenario.reader import scenario_from_dict
from mjx_radar.task.method import parse_method
from mjx_radar.task.params import detection_of, task_params

LIGHT = 299_792_458.0
BASE = {
    "name": "fleet",
    "n_radars": 3,
    "targets": [[0.0, 0.0, 50.0, 4.0, -2.0, 0.0], [60.0, 10.0, 45.0, 0.0, 3.0, 1.0]],
    "radars": [[300.0, 0.0, 0.0], [-300.0, 0.0, 1.0], [0.0, 300.0, 2.0]],
    "timing": {"steps": 40},
    "mpc": {"horizon": 3, "rollout": "analytic"},
    "mppi": {"samples": 32, "iterations": 1},
    "radar_override": [
        {"radar": 0, "mobile": False, "radar_equation": {"r_ref": 1500.0, "snr_db": -10.0}},
        {"radar": 2, "radar_equation": {"fc": 3e8}, "limits": {"accel": 5.0}},
    ],
}


def _closed_form_c(fc, r_ref, snr_db, m):
    """SPEC §1: C = c² σ_a² / (8π² fc² K), σ_a² = M K / (R_ref⁴ 10^(snr/10)): K cancels."""
    return LIGHT**2 * m / (8 * math.pi**2 * fc**2 * r_ref**4 * 10 ** (snr_db / 10))


def test_per_radar_constants_in_sfim_ckf_noise_and_ccr():
    s = scenario_from_dict(BASE)
    noise = task_params(s, parse_method("ddr-sfim")).noise
    c = np.array([_closed_form_c(1e8, 1500.0, -10.0, 2), _closed_form_c(1e8, 500.0, -20.0, 2),
                  _closed_form_c(3e8, 500.0, -20.0, 2)])  # fmt: skip
    np.testing.assert_allclose(np.asarray(noise.c), c, rtol=1e-5)
    np.testing.assert_allclose(np.asarray(noise.sigma_r2), c * s.mpc.r2t**4, rtol=1e-5)
    radars = np.array([[300.0, 0, 0], [-300.0, 0, 0], [0, 300.0, 0]])
    targets = np.array([[0.0, 0, 50], [60.0, 10, 45]])
    model = measurement.make_model("range")
    got = np.asarray(measurement.information_dense(model, radars, targets, noise, False))
    d = targets[None] - radars[:, None]  # [N, M, 3]
    r = np.linalg.norm(d, axis=-1)
    w = 4 / (c[:, None] * r**6) + 8 / r**4  # SFIM closed form, each radar's C
    ref = np.einsum("nm,nmi,nmj->mij", w, d, d)
    np.testing.assert_allclose(got, ref, rtol=2e-4)
    # the CKF's noise: DDR C_n d⁴ per radar row, CCR C_n R2T⁴
    z = 2 * r.reshape(-1)  # rows radar-major
    for ccr, var in ((False, np.repeat(c, 2) * r.reshape(-1) ** 4),
                     (True, np.repeat(c, 2) * s.mpc.r2t**4)):  # fmt: skip
        big = measurement_filter.noise_cov_fn(model, noise, ccr)(jnp.asarray(z, jnp.float32))
        np.testing.assert_allclose(np.diag(np.asarray(big)), var, rtol=1e-4)
    # the truth sampler: var(z - 2d) = C_n d⁴ (Monte Carlo, 4000 draws: 4.5% rel. s.e.)
    keys = jax.random.split(jax.random.PRNGKey(0), 4000)
    draws = jax.vmap(lambda k: model.sample(k, radars, targets, noise))(keys)[..., 0]
    var = np.asarray(draws, np.float64).var(0)
    np.testing.assert_allclose(var, c[:, None] * r**4, rtol=0.2)


def test_fleet_without_equation_overrides_keeps_scalar_constants():
    raw = dict(BASE, radar_override=[{"radar": 1, "mobile": False}])
    noise = task_params(scenario_from_dict(raw), parse_method("ddr-sfim")).noise
    assert all(jnp.ndim(x) == 0 for x in noise)


def test_fixed_sites_never_move_and_bounds_hold():
    import mjx_radar

    s = scenario_from_dict(BASE)
    run = mjx_radar.simulate(s, "ddr-sfim", trials=2, progress=False)
    radar = run.arrays["radar"]  # [T, K, N, 6]
    start = np.array(BASE["radars"])
    # radar 0 is a fixed site: exactly where it started, at every step, in every trial
    np.testing.assert_array_equal(radar[:, :, 0, 0], start[0, 0])
    np.testing.assert_array_equal(radar[:, :, 0, 1], start[0, 1])
    np.testing.assert_array_equal(radar[:, :, 0, 4], 0.0)
    assert np.abs(radar[:, -1, 1, :2] - start[1, :2]).max() > 1.0  # mobile radars move
    control = run.arrays["control"]  # [T, C, N, 2]
    np.testing.assert_array_equal(control[:, :, 0], 0.0)
    assert np.abs(control[:, :, 2, 0]).max() <= 5.0 + 1e-5  # radar 2's own |a| bound
    assert np.abs(control[:, :, 1, 0]).max() > 5.0  # the fleet's bound (35 m/s²) elsewhere
    assert len(run.meta["noise_constants"]) == 3


def test_overlay_draws_fixed_sites_waypoints_and_leaves_out_absent_drones():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from mjx_radar.scenario.schema import TargetMotion
    from mjx_radar.viz import overlays
    from mjx_radar.viz.scene import scene_of

    s = scenario_from_dict(BASE).replace(target_motion=(
        TargetMotion(target=0, model="waypoints", waypoints=((0.0, 0.0, 50.0), (100.0, 0, 60))),
        TargetMotion(target=1, appear=5.0)))  # fmt: skip
    fixed, routes, present = overlays.world_state(scene_of(s), 0.1, 2)  # target 1 not there yet
    assert fixed.tolist() == [True, False, False] and present.tolist() == [True, False]
    assert len(routes) == 1 and routes[0][1].shape == (2, 3)
    ov = overlays.StepOverlay(
        radar=np.array([[0.0, 0, 0, 0, 0, 0], [50.0, 0, 0, 0, 0, 0], [0, 50.0, 0, 0, 0, 0]]),
        radar_rgb=overlays.RADAR_RGB[:3], target=np.array([[0.0, 0, 50], [10.0, 0, 50]]),
        target_rgb=overlays.TARGET_RGB[:2], mean=np.zeros((2, 3)), sigma=np.ones((2, 3)),
        r2t=125.0, r2r=10.0, trail=np.zeros((2, 3, 3)), samples=np.zeros((1, 2, 3, 2)),
        weight=np.ones(1), fixed=fixed, waypoints=routes, present=present,
    )  # fmt: skip
    fig, ax = plt.subplots()
    overlays.draw_matplotlib(ax, ov)
    markers = [(line.get_marker(), line.get_label()) for line in ax.get_lines()]
    plt.close(fig)
    assert ("^", "fixed site") in markers and ("s", "radar") in markers
    assert ("D", "waypoints") in markers
    assert sum(m == "x" for m, _ in markers) == 1  # the absent drone is not drawn
    # the video's MuJoCo overlay: a box per fixed site and per waypoint, no absent drone
    import mujoco

    scene = mujoco.MjvScene(mujoco.MjModel.from_xml_string("<mujoco/>"), maxgeom=2000)
    overlays.draw_mujoco(scene, ov, 1.0)
    types_ = [scene.geoms[i].type for i in range(scene.ngeom)]
    assert types_.count(mujoco.mjtGeom.mjGEOM_BOX) == 1 + 2  # one site, two waypoints
    assert types_.count(mujoco.mjtGeom.mjGEOM_CYLINDER) == 2  # the mobile radars
    assert types_.count(mujoco.mjtGeom.mjGEOM_ELLIPSOID) == 1  # the present drone only


def test_detection_snr_is_per_radar_in_a_mixed_fleet():
    """With [detection] on, each radar's SNR constant k = 10^((snr_db+gain)/10)/M r_ref^4
    comes from its own radar equation (closed form; float32 arrays: rtol 1e-6)."""
    import mjx_radar
    from mjx_radar.estimation.sensor import detection

    s = mjx_radar.load_scenario("mixed_6r4t").replace(
        detection={"model": "swerling1", "gain_db": 10.0}
    )
    k = np.asarray(detection_of(s).k_snr)
    m = s.n_targets
    want = [10.0 ** ((-15.0 + 10.0) / 10.0) / m * 1500.0**4] * 2 + [
        10.0 ** ((s.radar_eq.snr_db + 10.0) / 10.0) / m * s.radar_eq.r_ref**4
    ] * 4
    assert k.shape == (6, 1)
    np.testing.assert_allclose(k[:, 0], want, rtol=1e-6)
    d2 = np.full((6, m), 400.0**2)
    pd = np.asarray(detection.pair_probability("swerling1", detection_of(s), d2))
    assert pd[:2].min() > pd[2:].max()  # the long-range sites detect better at the same range
