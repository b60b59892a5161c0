"""The drive's own road friction (:func:`sideslip.calibrate.friction.drive_friction`) against
the truth's road mu, on drives from the simulator's Magic Formula tyres with load sensitivity
and CommonRoad's multi-body model (never the estimator's brush curve), and its effect on
``fused`` as mu's prior."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from sideslip.calibrate.friction import DUGOFF_RATIO_MAX, axle_slip, drive_friction
from sideslip.evaluate import metrics
from sideslip.methods.fused import roll_gain
from sideslip.methods.registry import run_method
from sideslip.models.axle_force import axle_lateral_force
from sideslip.vehicle import load_vehicle
from tests.conftest import sim_drive


@pytest.mark.parametrize("shape", [0.0, 1.3])
def test_axle_slip_inverts_the_estimators_axle_curve(shape: float) -> None:
    """Analytic: the closed-form inverse gives back the slip of every force below the limit
    (to rounding), and the slip at the limit for forces at or beyond it."""
    c, f_max = 60.0, 4.0
    z_peak = 3.0 * f_max / c if shape <= 0 else math.tan(0.5 * math.pi / shape) * shape * f_max / c
    z = np.linspace(-0.999 * z_peak, 0.999 * z_peak, 401)
    force = np.array([axle_lateral_force(float(v), c, f_max, shape)[0] for v in z])
    np.testing.assert_allclose(axle_slip(force, c, f_max, shape), z, rtol=1e-7, atol=1e-9)
    beyond = axle_slip(np.array([f_max, -1.5 * f_max]), c, f_max, shape)
    np.testing.assert_allclose(beyond, [z_peak, -z_peak], rtol=1e-12)


def test_axle_slip_inverts_the_dugoff_curve_up_to_its_cap() -> None:
    """Analytic: Dugoff's curve reaches the limit only at infinite slip, so forces up to
    DUGOFF_RATIO_MAX of it invert exactly (both branches) and beyond take the slip there."""
    c, f_max = 60.0, 4.0
    z_cap = f_max / (4.0 * c * (1.0 - DUGOFF_RATIO_MAX))
    z = np.linspace(-0.999 * z_cap, 0.999 * z_cap, 401)
    force = np.array([axle_lateral_force(float(v), c, f_max, -1.0)[0] for v in z])
    np.testing.assert_allclose(axle_slip(force, c, f_max, -1.0), z, rtol=1e-7, atol=1e-9)
    beyond = axle_slip(np.array([f_max, -1.5 * f_max]), c, f_max, -1.0)
    np.testing.assert_allclose(beyond, [z_cap, -z_cap], rtol=1e-12)


def _fit(name: str, seed: int = 0, scale: float = 1.0):  # type: ignore[no-untyped-def]
    drive = sim_drive(name, seed)
    vehicle = load_vehicle(drive.meta["vehicle"])
    vehicle = vehicle.with_changes(cf=scale * vehicle.cf, cr=scale * vehicle.cr)
    return drive_friction(drive, vehicle, roll_gain(vehicle))


@pytest.mark.commonroad
@pytest.mark.parametrize("name", ["cr_limit_ramp", "cr_limit_slalom"])
@pytest.mark.parametrize("scale", [1.0, 1.3, 0.7])
def test_friction_at_the_limit_of_commonroads_car(name: str, scale: float) -> None:
    """CommonRoad's BMW on mu 0.6 (front axle saturating on the ramp, rear in the slalom):
    measured 0.54-0.59 with the right file and files 30 % stiff or soft
    (benchmarks/results/friction.md).  The multi-body tyres' axle peak sits below the road's
    mu under load transfer, so the bound is 0.6 - 0.1 .. 0.6 + 0.05, and the 1-sigma is at
    most 0.05 (the fit is decided: the drive used 93 % of it)."""
    pytest.importorskip("vehiclemodels", reason="needs the optional commonroad extra")
    fit = _fit(name, scale=scale)
    assert fit.informed, fit.note
    assert 0.5 <= fit.value <= 0.65, fit
    assert fit.sigma <= 0.05


def test_friction_of_the_simulated_race_lap() -> None:
    """The simulated race lap on mu 1.05 at 95 % of mu g: the Magic Formula axle with load
    sensitivity (mu falls 10 % per unit load increase) peaks below the road's mu; measured
    0.98.  Bound 1.05 - 0.15 .. 1.05 + 0.05."""
    fit = _fit("race_lap")
    assert fit.informed, fit.note
    assert 0.9 <= fit.value <= 1.1, fit


@pytest.mark.parametrize("name", ["urban_highway", "demo", "step_steer"])
def test_friction_is_left_alone_where_the_drive_does_not_decide_it(name: str) -> None:
    """Drives that never went near their limit (urban_highway 0.12 g, demo 0.22 g; step_steer
    0.42 g on mu 0.85) fit any mu above a bound: not informed, with the reason."""
    fit = _fit(name)
    assert not fit.informed
    assert math.isnan(fit.value)
    assert "not bounded" in fit.note or "under 90%" in fit.note, fit.note


def test_friction_without_a_steer_column_says_so() -> None:
    drive = sim_drive("race_lap")
    drive = replace(drive, data={k: v for k, v in drive.data.items() if k != "steer"})
    vehicle = load_vehicle(drive.meta["vehicle"])
    fit = drive_friction(drive, vehicle, roll_gain(vehicle))
    assert not fit.informed
    assert fit.note == "no steer, yaw-rate or lateral-acceleration column"


@pytest.mark.commonroad
def test_fused_with_identify_mu_takes_the_drives_friction_as_mus_prior() -> None:
    """cr_limit_ramp without GNSS, right file (the BMW, whose rear takes the front's mu well):
    with mu's prior at 1.0 the rear axle's slip at the limit is half the truth's (beta -0.5
    against -1.07 deg); with identify_mu the drive's 0.56 and it follows.  Measured seed 0:
    0.309 -> 0.080 deg.  Bounds: below 0.15 and at least 0.1 deg better.  By default (off) and
    on a drive the fit leaves alone (demo) fused's beta is the same bit for bit, and the
    params say which mu was used."""
    pytest.importorskip("vehiclemodels", reason="needs the optional commonroad extra")
    drive = sim_drive("cr_limit_ramp")
    drive = replace(drive, data={k: v for k, v in drive.data.items() if not k.startswith("gnss")})
    vehicle = load_vehicle(drive.meta["vehicle"])
    off = run_method("fused", drive, vehicle)
    on = run_method("fused", drive, vehicle, {"identify_mu": True})
    rmse_off = metrics(drive, off.series)["beta_rmse_deg"]
    rmse_on = metrics(drive, on.series)["beta_rmse_deg"]
    assert rmse_on < 0.15 and rmse_on < rmse_off - 0.1, (rmse_off, rmse_on)
    assert "from the drive's understeer angle" in on.params["assumed"]["mu_prior"]
    assert off.params["assumed"]["mu_prior"] == "1 +- 0.35 (settings): FusedSettings.identify_mu is off"
    demo = sim_drive("demo")
    demo_vehicle = load_vehicle(demo.meta["vehicle"])
    a = run_method("fused", demo, demo_vehicle)
    b = run_method("fused", demo, demo_vehicle, {"identify_mu": True})
    np.testing.assert_array_equal(a["beta"], b["beta"])
    assert "not bounded" in b.params["assumed"]["mu_prior"]
