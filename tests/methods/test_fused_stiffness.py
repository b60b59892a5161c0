"""The learned rear stiffness's secant and model-form sigma (sideslip.methods.fused_stiffness)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from sideslip.calibrate.truth import reference_calibration
from sideslip.methods.fused import fuse
from sideslip.methods.fused_stiffness import (
    MIN_SECONDS,
    PRIOR_SHIFT,
    RearSecant,
    model_form_params,
    prior_share,
    rear_secant,
)
from sideslip.models.axle_force import lateral_force
from sideslip.vehicle import G, load_vehicle
from tests.conftest import sim_drive

LF, LR, IZ_M, CR_M = 1.2, 1.6, 1.9, 130.0  # m, m, m^2, m/s^2 per rad (a mid-size car per kg)


def _weave(duration_s: float = 30.0) -> tuple[np.ndarray, ...]:
    """A weave at 20 m/s: yaw rate and sideslip as sines (|r'| <= 0.025 rad/s^2), and the rear
    slip angle they give."""
    t = np.arange(0.0, duration_s, 0.01)
    vx = np.full(t.size, 20.0)
    r = 0.05 * np.sin(0.5 * t)
    beta = -0.004 * np.sin(0.5 * t - 0.2)
    alpha = np.arctan(LR * r / vx - np.tan(beta))
    return t, vx, r, beta, alpha


def _lateral_force(t: np.ndarray, r: np.ndarray, f_rear: np.ndarray) -> np.ndarray:
    """The f_y whose rear share by the force and moment balance is ``f_rear``."""
    return ((LF + LR) * f_rear + IZ_M * np.gradient(r, t)) / LF


def test_a_linear_axle_gives_its_own_stiffness():
    """Forces exactly 1.3 x C_r alpha: the secant is 1.3 (to rounding)."""
    t, vx, r, beta, alpha = _weave()
    f_y = _lateral_force(t, r, 1.3 * CR_M * alpha)
    assert np.abs(f_y).max() < 0.4 * G  # the rows are inside the reference's range
    secant = rear_secant(t, beta, r, vx, f_y, (LF, LR, IZ_M, CR_M), 0.5)
    assert secant is not None
    assert secant.scale == pytest.approx(1.3, rel=1e-9)
    assert secant.seconds > 10.0


def test_a_brush_axle_bends_below_its_slope_at_zero():
    """Brush-curve forces of stiffness C_r at up to 41 % of mu F_z: the secant through the
    origin lies below the curve's slope at zero (between the secant at the largest force,
    0.83, and 1), which is the model-form gap the sigma takes up."""
    t, vx, r, beta, alpha = _weave()
    f_max = 0.6 * G * LF / (LF + LR)  # mu 0.6 on the rear axle's static share
    f_rear = lateral_force(alpha, CR_M, f_max)
    secant = rear_secant(t, beta, r, vx, _lateral_force(t, r, f_rear), (LF, LR, IZ_M, CR_M), 0.5)
    assert secant is not None
    top = np.abs(f_rear).max() / np.abs(CR_M * np.tan(alpha)).max()  # secant at the peak
    assert top < secant.scale < 0.99


def test_too_little_cornering_gives_no_secant_and_the_formal_sigma():
    """Under MIN_SECONDS of rows beyond the learning threshold: None, and the params keep the
    smoother's sigma and say why."""
    t, vx, r, beta, alpha = _weave(duration_s=MIN_SECONDS)
    f_y = _lateral_force(t, r, CR_M * alpha)
    assert rear_secant(t, beta, r, vx, f_y, (LF, LR, IZ_M, CR_M), 0.5) is None
    params = model_form_params(1.1, 0.05, None)
    assert params["rear_stiffness_scale_sigma"] == 0.05
    assert params["rear_stiffness_scale_secant"] is None
    assert "no secant" in params["rear_stiffness_scale_secant_note"]


def test_the_sigma_adds_the_gap_to_the_secant():
    params = model_form_params(1.0, 0.03, RearSecant(scale=0.96, seconds=40.0))
    assert params["rear_stiffness_scale_sigma"] == pytest.approx(0.05)
    assert params["rear_stiffness_scale_sigma_formal"] == 0.03
    assert params["rear_stiffness_scale_secant"] == 0.96


def test_race_lap_stiffness_is_inside_its_sigma():
    """Race lap with GNSS Doppler and the right file (Magic Formula tyres near the limit,
    against the reference's secant of true force over true slip up to 0.4 g): the brush
    curve's scale is far from it in its formal sigma (measured 0.902 +- 0.017 against 0.733:
    z = 10), inside 2 sigma with the model-form term (sigma 0.155); the secant from the
    estimate's own slip is within 10 % of the reference (measured 0.747, 2 %)."""
    drive = sim_drive("race_lap")
    vehicle = load_vehicle(drive.meta["vehicle"])
    truth = reference_calibration(drive)["cr"] / vehicle.cr
    p = fuse(drive, vehicle, smooth=True).params
    scale = p["rear_stiffness_scale"]
    assert abs(scale - truth) > 2 * p["rear_stiffness_scale_sigma_formal"]  # the term matters here
    assert abs(scale - truth) < 2 * p["rear_stiffness_scale_sigma"]
    assert p["rear_stiffness_scale_secant"] == pytest.approx(truth, rel=0.10)
    assert math.isfinite(p["rear_stiffness_scale_secant_seconds"])


def test_the_prior_check_takes_the_larger_sigma():
    """A scale that kept the whole prior shift has the prior's sigma; one that kept 4 % of
    it, sigma_prior x 0.2 (the linear-Gaussian identity), here below the formal one."""
    assert prior_share(1.0, 1.0 + PRIOR_SHIFT) == 1.0
    assert prior_share(1.0, 1.0 + 2 * PRIOR_SHIFT) == 1.0  # held at 1
    assert prior_share(1.0, 1.0 + 0.04 * PRIOR_SHIFT) == pytest.approx(0.04)
    wide = model_form_params(1.0, 0.05, None, (1.0, 0.5))
    assert wide["rear_stiffness_scale_sigma"] == pytest.approx(0.5)
    narrow = model_form_params(1.0, 0.15, None, (0.04, 0.5))
    assert narrow["rear_stiffness_scale_sigma"] == pytest.approx(0.15)
    assert narrow["rear_stiffness_scale_prior_share"] == pytest.approx(0.04)


def test_without_gnss_a_drive_that_does_not_inform_the_stiffness_says_so():
    """urban_course without GNSS, file 30 % soft: gentle urban turns do not pin the rear
    stiffness (the scale stays near the file's, 1.005 against the reference's 1.419, and the
    right file's run gives 0.916: the estimate follows the file), yet the smoother's sigma
    shrinks to 0.105 (z = -3.9).  The prior check keeps 77 % of a moved prior (bound 0.5:
    a drive that informed the scale would keep a few %) and the sigma grows to 0.44, with
    the reference inside 2 sigma."""
    drive = sim_drive("urban_course")
    drive = replace(drive, data={k: v for k, v in drive.data.items() if not k.startswith("gnss")})
    right = load_vehicle(drive.meta["vehicle"])
    soft = right.with_changes(cf=0.7 * right.cf, cr=0.7 * right.cr)
    truth = reference_calibration(drive)["cr"] / soft.cr
    p = fuse(drive, soft, smooth=True).params
    scale = p["rear_stiffness_scale"]
    assert p["rear_stiffness_scale_prior_share"] > 0.5
    assert abs(scale - truth) > 2 * p["rear_stiffness_scale_sigma_formal"]
    assert abs(scale - truth) < 2 * p["rear_stiffness_scale_sigma"]


def test_with_doppler_the_prior_check_does_not_run():
    """GNSS Doppler measures v_y: no second pass, and no share in the params."""
    drive = sim_drive("urban_course")
    p = fuse(drive, load_vehicle(drive.meta["vehicle"]), smooth=True).params
    assert "rear_stiffness_scale_prior_share" not in p


def test_a_scale_held_at_its_bound_has_at_least_the_priors_sigma():
    """Held at a bound (the relation asked for beyond it) the scale is no estimate."""
    params = model_form_params(0.5, 0.12, RearSecant(scale=0.48, seconds=2.1), (0.0, 0.5), 0.5)
    assert params["rear_stiffness_scale_sigma"] == pytest.approx(math.hypot(0.5, 0.02))
