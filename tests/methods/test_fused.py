"""The fused estimator against simulator truth (nonlinear tyres, roll, bank, sensor errors)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sideslip.evaluate import SPEED_GATE, metrics
from sideslip.frames import wrap_angle
from sideslip.methods.fused import fuse
from sideslip.methods.registry import all_methods, run_method, why_not
from sideslip.vehicle import load_vehicle
from tests.conftest import sim_drive

OURS = {"fused", "fused_filter"}


def _beta_rmse_all(drive, vehicle):
    out = {}
    for name, method in all_methods().items():
        if why_not(method, drive, vehicle) is None:
            m = metrics(drive, run_method(method, drive, vehicle).series)
            if "beta_rmse_deg" in m:
                out[name] = m["beta_rmse_deg"]
    return out


SUITE = (
    "demo", "dlc_bank", "banked_turn", "step_steer", "two_turns_gyro_sf", "banked_track_turn",
    "race_lap", "slalom_low_mu",
)  # fmt: skip


@pytest.mark.parametrize("stiffness_factor", [1.0, 0.7])
def test_fused_has_the_lowest_mean_error_over_the_scenario_suite(stiffness_factor):
    """The mission's claim, measured honestly: over banked, mixed, transient, high-slip and
    low-friction drives, with the right vehicle file and with one 30 % off in cornering
    stiffness, the fused smoother has the lowest mean beta RMSE of all methods.  It is not the
    best on every single drive (steering-model methods win the step steer and slalom, where
    steering leads the motion); measured means over this suite (seed 0): 0.052 deg vs 0.127
    (doppler_slip) with the right file, 0.057 vs 0.22 with the wrong one
    (benchmarks/results/compare_methods.md has every scenario).  The bound asks for a 1.5x
    margin so that a regression that erodes the advantage fails."""
    totals: dict[str, list[float]] = {}
    for scenario in SUITE:
        drive = sim_drive(scenario)
        v = load_vehicle(drive.meta["vehicle"])
        v = v.with_changes(cf=stiffness_factor * v.cf, cr=stiffness_factor * v.cr)
        for name, value in _beta_rmse_all(drive, v).items():
            totals.setdefault(name, []).append(value)
    means = {k: float(np.mean(v)) for k, v in totals.items() if len(v) == len(SUITE)}
    others = {k: v for k, v in means.items() if k not in OURS}
    assert len(others) >= 10
    best_other = min(others, key=others.get)
    assert 1.5 * means["fused"] < others[best_other], (means["fused"], best_other, others[best_other])


@pytest.mark.parametrize("scenario", ["dlc_bank", "banked_turn", "race_lap"])
def test_fused_beats_every_paper_method_on_banks_and_at_the_limit(scenario):
    """Where bank and tyre saturation defeat the linear models, the fused smoother is the best
    single method (measured: dlc_bank 0.070 vs 0.122 deg, banked_turn 0.022 vs 0.046, race_lap
    0.114 vs 0.175)."""
    drive = sim_drive(scenario)
    rmse = _beta_rmse_all(drive, load_vehicle(drive.meta["vehicle"]))
    others = {k: val for k, val in rmse.items() if k not in OURS}
    best_other = min(others, key=others.get)
    assert rmse["fused"] < others[best_other], (rmse["fused"], best_other, others[best_other])


@pytest.mark.parametrize("scenario", ["demo", "urban_course", "two_turns_gyro_sf"])
def test_beta_std_covers_the_error(scenario):
    """Calibration: a Gaussian 1-sigma covers 68 % and 2-sigma 95 % of errors.  The smoother
    is allowed to be conservative (it carries the slip relation's 30 % model error even where
    the tyres are linear) but not overconfident: at least 90 % inside 2 sigma, and sigma not
    more than 4x the actual RMS error (measured: 99-100 % and about 2x)."""
    drive = sim_drive(scenario)
    est = fuse(drive, load_vehicle(drive.meta["vehicle"]), smooth=True)
    gate = drive["ref_vx"] > SPEED_GATE
    err = np.abs(wrap_angle(est["beta"] - drive["ref_beta"]))[gate]
    std = est["beta_std"][gate]
    assert np.mean(err < 2 * std) > 0.90
    assert np.sqrt(np.mean(std**2)) < 4 * np.sqrt(np.mean(err**2))


def test_slip_gain_is_identified_from_a_wrong_vehicle_file():
    """Starting 43 % high (cornering stiffness 30 % low), K converges to within 15 % of the
    value the true vehicle implies (m lf / (L cr); the simulator's tyres are Magic Formula, so
    the effective linear K differs by a few %; measured 0.00530 vs 0.00511)."""
    drive = sim_drive("demo")
    v = load_vehicle(drive.meta["vehicle"])
    wrong = v.with_changes(cf=0.7 * v.cf, cr=0.7 * v.cr)
    est = fuse(drive, wrong, smooth=True)
    assert est.params["slip_gain_k_prior"] == pytest.approx(v.slip_gain_k / 0.7)
    assert est.params["slip_gain_k_s2pm"] == pytest.approx(v.slip_gain_k, rel=0.15)


def test_gyro_bias_and_scale_factor_are_identified():
    """Seed 001's hard case: a 2 % gyro scale factor.  Bias within 0.03 deg/s of the truth the
    simulator drew (gyro noise 0.1 deg/s per sample over 78 s), scale factor within 0.4 %
    (measured: 0.007 deg/s, 1.54 % vs 1.66 %)."""
    drive = sim_drive("two_turns_gyro_sf")
    est = fuse(drive, load_vehicle(drive.meta["vehicle"]), smooth=True)
    truth = drive.meta["truth_sensor"]
    assert abs(math.degrees(est["gyro_bias"][-1] - truth["gyro_bias"][2])) < 0.03
    assert est.params["gyro_scale_factor"] == pytest.approx(truth["gyro_scale_factor"], abs=0.004)


def test_position_through_the_demo_outage_stays_inside_its_own_ellipse():
    """During the demo's 10 s GNSS outage (a banked curve), the smoothed position error stays
    below 3 m and inside 3 sigma of the estimate's own position uncertainty."""
    drive = sim_drive("demo")
    est = fuse(drive, load_vehicle(drive.meta["vehicle"]), smooth=True)
    (t0, t1), *_ = drive.meta["sensor_config"]["gnss_outages"]
    rows = (drive.t > t0) & (drive.t < t1)
    err = np.hypot(est["e"] - drive["ref_e"], est["n"] - drive["ref_n"])[rows]
    sd = np.hypot(est["e_std"], est["n_std"])[rows]
    assert err.max() < 3.0
    assert np.all(err < 3 * sd)


def test_filter_is_causal():
    """fused_filter at row k must not depend on data after row k (it is the on-line form)."""
    drive = sim_drive("dlc_bank")
    v = load_vehicle(drive.meta["vehicle"])
    full = fuse(drive, v, smooth=False)
    half = fuse(drive.slice(0, len(drive) // 2), v, smooth=False)
    np.testing.assert_allclose(half["beta"], full["beta"][: len(drive) // 2], atol=1e-12)


def test_fused_runs_on_gnss_positions_without_doppler():
    """Many loggers record fixes but not Doppler velocity: fused then takes its heading and
    velocity information from the positions (measured on dlc_bank: 0.095 deg, still ahead of
    the best paper method's 0.122)."""
    from sideslip.drive import drive_from_columns
    from sideslip.methods.registry import all_methods, run_method, why_not

    drive = sim_drive("dlc_bank")
    doppler = ("gnss_ve", "gnss_vn", "gnss_vu", "gnss_vel_std")
    cols = {"t": drive.t, **{k: v for k, v in drive.data.items() if k not in doppler}}
    no_doppler = drive_from_columns(cols, dict(drive.meta))
    vehicle = load_vehicle(drive.meta["vehicle"])
    method = all_methods()["fused"]
    assert why_not(method, no_doppler, vehicle) is None
    est = run_method(method, no_doppler, vehicle)
    assert metrics(no_doppler, est.series)["beta_rmse_deg"] < 0.12
    no_gnss = drive_from_columns(
        {k: v for k, v in cols.items() if not k.startswith("gnss_")}, dict(drive.meta)
    )
    assert "gnss_ve or gnss_e" in why_not(method, no_gnss, vehicle)
