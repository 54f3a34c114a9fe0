"""Properties of a compiled scene that let the plant's fast step skip MJX stages.

Checked numerically with C MuJoCo at random states when a plant is built
(:func:`mjx_radar.physics.plant.make_plant`): a constant joint-space inertia lets the
step reuse one mass-matrix factor, and vanishing bias and passive forces let it skip
the velocity stage's com_vel / passive / RNE passes.
"""

from __future__ import annotations

import mujoco
import numpy as np


def constant_mass_matrix(mj_model: mujoco.MjModel, tries: int = 4) -> bool:
    """True if the joint-space inertia is the same at random configurations."""
    data = mujoco.MjData(mj_model)
    rng = np.random.default_rng(0)
    mats = []
    for _ in range(tries):
        data.qpos[:] = rng.uniform(-100, 100, mj_model.nq)
        mujoco.mj_forward(mj_model, data)
        full = np.zeros((mj_model.nv, mj_model.nv))
        mujoco.mj_fullM(mj_model, data, full)
        mats.append(full)
    return all(np.allclose(m, mats[0], rtol=1e-12, atol=1e-9) for m in mats)


def zero_bias(mj_model: mujoco.MjModel, tries: int = 4) -> bool:
    """True if the bias force ``qfrc_bias`` (and passive force) is zero at random states.

    Holds for the planar radars and the drones (slide/hinge joints, each body's centre
    of mass on its yaw axis, gravity, springs and dampers off); then the velocity stage
    reduces to the actuator velocities.
    """
    data = mujoco.MjData(mj_model)
    rng = np.random.default_rng(1)
    for _ in range(tries):
        data.qpos[:] = rng.uniform(-100, 100, mj_model.nq)
        data.qvel[:] = rng.uniform(-10, 10, mj_model.nv)
        mujoco.mj_forward(mj_model, data)
        if (
            np.abs(data.qfrc_bias).max(initial=0.0) > 1e-9
            or np.abs(data.qfrc_passive).max(initial=0.0) > 1e-9
        ):
            return False
    return True
