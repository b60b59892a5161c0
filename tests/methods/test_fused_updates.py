"""The fused estimator's combined-slip wheel term against the simulator's wheel speeds."""

from __future__ import annotations

import numpy as np

from sideslip.methods.fused_updates import wheel_slip_ratio
from sideslip.signals import speed_raw
from sideslip.vehicle import G, load_vehicle
from tests.conftest import sim_drive


def test_wheel_slip_ratio_is_linear_at_small_slip_and_grows_with_saturation() -> None:
    c_k = 15.0
    # linear range: the secant compliance below 1 / (g C_k): a_x / (g C_k)
    assert wheel_slip_ratio(3.0, 1.0, 0.001, 0.0, 1.0, c_k) == 3.0 / (G * c_k)
    # saturated rear axle: z F_x / F_y (isotropic brush model)
    assert np.isclose(wheel_slip_ratio(0.5, 4.5, 0.09, 0.0, 1.0, c_k), 0.09 * 0.5 / 4.5)
    # cornering drag of the front axle enters the driving force: f_front q_front
    assert np.isclose(wheel_slip_ratio(0.0, 4.5, 0.09, 0.1, 0.8, c_k), 0.09 * (4.5 * 0.8 * 0.1) / 4.5)


def test_wheel_slip_sigma_matches_the_simulated_race_lap_wheel_error_in_limit_corners() -> None:
    """Simulator truth (Magic Formula tyres, load transfer, traction control): in the race
    lap's limit corners (|a_y| > 7 m/s^2, |a_x| < 1 m/s^2) the wheel speed reads 0.77 % RMS
    off the true speed; the relative sigma ``wheel_rel_sigma + slip`` with the combined-slip
    ratio (from the true slip angles) is 0.99 % RMS (error / sigma 0.78), with a_x / (g C_k)
    alone 0.57 % (1.36: overconfident, the wheel speed then pulls v_x and, through the
    cross-covariances, the gyro scale and the slip in the first limit corner)."""
    drive = sim_drive("race_lap")
    v = load_vehicle(drive.meta["vehicle"])
    vx, vy, r = drive["ref_vx"], drive["ref_vy"], drive["ref_r"]
    vw = speed_raw(drive)
    sel = (np.abs(drive["ay"]) > 7.0) & (np.abs(drive["ax"]) < 1.0) & (vx > 10.0) & np.isfinite(vw)
    assert sel.sum() > 500
    rel = vw[sel] / vx[sel] - 1.0
    f_rear = v.lf / (v.lf + v.lr) * drive["ay"]
    rows = zip(drive["ax"][sel], f_rear[sel], vx[sel], vy[sel], r[sel], strict=True)
    slip = np.array(
        [
            wheel_slip_ratio(a, f, -(y - v.lr * w) / u, (y + v.lf * w) / u, v.lr / v.lf, 15.0)
            for a, f, u, y, w in rows
        ]
    )
    old = np.abs(drive["ax"][sel]) / (G * 15.0)
    wheel_rel = 0.003  # FusedSettings.wheel_rel_sigma

    def ratio(s: np.ndarray) -> float:
        return float(np.sqrt(np.mean(rel**2)) / np.sqrt(np.mean((wheel_rel + s) ** 2)))

    assert 0.6 < ratio(slip) < 1.0
    assert ratio(old) > 1.25
