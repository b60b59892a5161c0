"""The fused estimator against simulator truth (nonlinear tyres, roll, bank, sensor errors)."""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest

from sideslip.drive import Drive
from sideslip.evaluate import SPEED_GATE, metrics
from sideslip.frames import wrap_angle
from sideslip.methods.fused import FusedSettings, fuse
from sideslip.methods.registry import all_methods, run_method, why_not
from sideslip.vehicle import load_vehicle
from tests.conftest import sim_drive

OURS = {"fused", "fused_filter"}


def beta_rmse_all(drive, vehicle):
    out = {}
    for name, method in all_methods().items():
        if why_not(method, drive, vehicle) is None:
            m = metrics(drive, run_method(method, drive, vehicle).series)
            if "beta_rmse_deg" in m:
                out[name] = m["beta_rmse_deg"]
    return out


def two_sigma_share(drive, est):
    gate = drive["ref_vx"] > SPEED_GATE
    err = np.abs(wrap_angle(est["beta"] - drive["ref_beta"]))[gate]
    return float(np.mean(err < 2 * est["beta_std"][gate]))


SUITE = (
    "demo", "dlc_bank", "banked_turn", "step_steer", "two_turns_gyro_sf", "banked_track_turn",
    "race_lap", "slalom_low_mu", "cr_step_steer", "cr_slalom", "cr_circle",
)  # fmt: skip


@pytest.mark.slow
@pytest.mark.parametrize("stiffness_factor", [1.0, 0.7])
def test_fused_has_the_lowest_mean_error_over_the_scenario_suite(stiffness_factor):
    """Over banked, mixed, transient, high-slip and low-friction drives and CommonRoad's
    multi-body model (a truth nobody here wrote, constants not chosen on it), with the right
    vehicle file and one 30 % off in cornering stiffness, the fused smoother has the lowest
    mean beta RMSE of all methods (measured, seed 0, over these 11: 0.045 deg with the right
    file and 0.052 with the wrong one, the next method 0.089 (doppler_slip) / 0.167).  The
    bound asks for a 1.5x margin so that a regression that erodes the advantage fails."""
    totals: dict[str, list[float]] = {}
    for scenario in SUITE:
        drive = sim_drive(scenario)
        v = load_vehicle(drive.meta["vehicle"])
        v = v.with_changes(cf=stiffness_factor * v.cf, cr=stiffness_factor * v.cr)
        for name, value in beta_rmse_all(drive, v).items():
            totals.setdefault(name, []).append(value)
    means = {k: float(np.mean(v)) for k, v in totals.items() if len(v) == len(SUITE)}
    others = {k: v for k, v in means.items() if k not in OURS}
    assert len(others) >= 10
    best_other = min(others, key=others.get)
    assert 1.5 * means["fused"] < others[best_other], (means["fused"], best_other, others[best_other])


@pytest.mark.commonroad
@pytest.mark.parametrize(("scenario", "bound_deg"), [("cr_limit_slalom", 0.25), ("cr_limit_ramp", 0.25)])
def test_multipath_bursts_at_the_grip_limit_do_not_make_fused_confidently_wrong(scenario, bound_deg):
    """CommonRoad's multi-body BMW on mu 0.6 (an independent truth), the tyres saturating,
    the GNSS carrying multipath bursts (runs of wrong epochs that agree with each other).
    Measured, seed 1 (beta RMSE, share inside 2 sigma): slalom 0.45 deg / 0.89 without the
    inertial Doppler check, 0.14 / 0.97 with it; ramp 2.13 / 0.17 without, 0.14 / 0.97 with.
    With the smoother's second look at the Doppler (fused_bursts; session 27), both checks /
    the forward one only / the second look only / neither: slalom 0.097 / 0.105 / 0.210 /
    0.768, ramp 0.078 / 0.072 / 0.053 / 0.283, every share 1.00 but neither's 0.92 on the
    slalom.  fused is the best method on both (next: doppler_slip_noroll 0.54 on the slalom,
    fused_filter 0.52 on the ramp).  Bounds: the 0.14 measured before the second look plus
    75 %, the 2-sigma target of issue 15, and the checks must matter (both off at least 1.5x
    worse)."""
    pytest.importorskip("vehiclemodels", reason="needs the optional commonroad extra")
    drive = sim_drive(scenario, 1)
    vehicle = load_vehicle(drive.meta["vehicle"])
    est = run_method("fused", drive, vehicle)
    rmse = metrics(drive, est.series)["beta_rmse_deg"]
    assert rmse < bound_deg
    assert two_sigma_share(drive, est) >= 0.90
    off = run_method("fused", drive, vehicle, settings={"doppler_check": False, "doppler_burst_check": False})
    assert metrics(drive, off.series)["beta_rmse_deg"] > 1.5 * rmse
    others = {k: v for k, v in beta_rmse_all(drive, vehicle).items() if k != "fused"}
    assert rmse < min(others.values()), others


@pytest.mark.commonroad
def test_a_long_multipath_burst_is_not_learned_as_a_tyre_property():
    """cr_limit_ramp seed 11: a 5 s multipath burst (5.6-10.4 s) while the BMW ramps up to
    the limit for the first time, with a file 30 % soft.  The inertial check flags the
    burst's start but admits its middle once the IMU-carried velocity has drifted enough;
    the tyres learned the burst's course error as a rear axle at the 0.5x bound and kept
    beta ~2 deg off after the burst: fused 2.02 deg with 21 % inside 2 sigma, fused_filter
    1.99 / 80 %.  With stiffness and mu consider parameters while the check rejects a run of
    epochs: 0.34 / 95 % and 1.31 / 94 %.  Since the suspension's gravity term is exact
    (a_y / (1 + g k_phi), models.fused_process) the smoother no longer needs the hold here
    (0.334 deg without it, 0.343 with); the causal filter still does: 1.23 deg / 98 % with
    it, 3.93 / 29 % without, the rear scale held past its 0.5 bound.  Since session 30 a
    scale past its bound is projected back onto it and learns again, which alone takes the
    filter to 1.55 / 92 %; with the hold 1.37 / 99 %.  Bounds: fused's measured value
    doubled, the filter's under its 1.99 without either guard, issue 15's 2-sigma share, the
    hold still better than the projection alone, and without both the filter at least 2x
    worse."""
    pytest.importorskip("vehiclemodels", reason="needs the optional commonroad extra")
    drive = sim_drive("cr_limit_ramp", 11)
    v = load_vehicle(drive.meta["vehicle"])
    soft = v.with_changes(cf=0.7 * v.cf, cr=0.7 * v.cr)
    est = run_method("fused", drive, soft)
    rmse = metrics(drive, est.series)["beta_rmse_deg"]
    assert rmse < 0.68
    assert two_sigma_share(drive, est) >= 0.90
    causal = run_method("fused_filter", drive, soft)
    assert metrics(drive, causal.series)["beta_rmse_deg"] < 1.7
    assert two_sigma_share(drive, causal) >= 0.90
    causal_rmse = metrics(drive, causal.series)["beta_rmse_deg"]
    off = run_method("fused_filter", drive, soft, settings={"doppler_check_holds_tyres": False})
    assert metrics(drive, off.series)["beta_rmse_deg"] > causal_rmse
    neither = run_method(
        "fused_filter", drive, soft, settings={"doppler_check_holds_tyres": False, "filter_project_scales": False}
    )
    assert metrics(drive, neither.series)["beta_rmse_deg"] > 2.0 * causal_rmse


@pytest.mark.commonroad
def test_a_steady_circle_on_a_level_road_reads_no_bank_change():
    """cr_circle (CommonRoad's multi-body BMW, 3.5 m/s^2 on a level road for 50 s): the
    bank fused reports in the circle equals the one on the straight before it (both hold the
    accelerometer's offset; the road is level throughout).  The first-order suspension term
    a_y (1 - g k_phi) put (g k_phi)^2 a_y into c_y: a 0.27 deg bank change (seeds 0-2: 0.27,
    0.29, 0.28; roll RMSE 0.53 deg), 0.02-0.04 with the exact a_y / (1 + g k_phi) (roll RMSE
    0.28).  Bound 0.1 deg: an accelerometer scale-factor error of 0.3 % (the simulated MEMS's
    spread) reads 0.01 m/s^2, 0.06 deg, at this a_y."""
    pytest.importorskip("vehiclemodels", reason="needs the optional commonroad extra")
    drive = sim_drive("cr_circle", 0)
    est = run_method("fused", drive, load_vehicle(drive.meta["vehicle"]))
    straight, circle = drive.t < 3.0, (drive.t > 10.0) & (drive.t < 55.0)
    assert np.all(np.abs(drive["ref_bank"]) < 1e-9)
    change = np.degrees(np.mean(est["bank"][circle]) - np.mean(est["bank"][straight]))
    assert abs(change) < 0.1


@pytest.mark.parametrize("scenario", ["urban_highway", "race_lap"])
def test_an_accelerometer_offset_stays_inside_beta_std(scenario):
    """The lateral accelerometer 0.25 m/s^2 high (25 mg, or the IMU mounted 1.5 deg rolled):
    the tyres read it as a rear-axle force and turn it into one slip offset for the whole
    drive (through the heading, GNSS Doppler cannot tell it from a constant sideslip).  White
    axle noise averaged over thousands of updates does not carry it; beta_std carries the
    slip of an accel_offset_sigma = 0.25 m/s^2 offset.  Measured share inside 2 sigma
    without / with that term (the velocity random walk read from the drive): urban_highway
    0.51 / 1.00, race_lap 0.61 / 1.00 (slalom_low_mu 0.71 / 1.00).  Bounds: issue 15's 0.90, and the term must matter
    (under 0.90 without)."""
    from dataclasses import replace

    drive = sim_drive(scenario)
    drive = replace(drive, data={**drive.data, "ay": np.asarray(drive.data["ay"]) + 0.25})
    vehicle = load_vehicle(drive.meta["vehicle"])
    est = run_method("fused", drive, vehicle)
    assert two_sigma_share(drive, est) >= 0.90
    assert est.params["beta_std_accel_offset_deg"] > 0.0
    # the drive's lateral offset level (offset_level_share) would carry it too: both off
    # (and the offset read from the curves, fused_accel_offset, which a 1e-9 prior overrules)
    without = run_method(
        "fused", drive, vehicle, settings={"accel_offset_sigma": 1e-9, "offset_level_share": 0.0,
                                           "identify_accel_offset": False},
    )  # fmt: skip
    assert two_sigma_share(drive, without) < 0.90
    level_only = run_method(
        "fused", drive, vehicle, settings={"accel_offset_sigma": 1e-9, "identify_accel_offset": False}
    )
    assert two_sigma_share(drive, level_only) >= 0.90
    if est.params["accel_offset_y_informed"]:  # urban_highway's curves read the offset itself
        truth = 0.25 + drive.meta["truth_sensor"]["ay_bias_level"]
        assert abs(est.params["accel_offset_y_m_s2"] - truth) < 2.0 * est.params["accel_offset_y_m_s2_sigma"]


def test_the_doppler_check_does_not_blame_the_receiver_for_a_bank_ramp():
    """banked_turn seed 2 (bank 0 -> 25 deg in 3 s, then a 150 m turn): the offset state c_y
    lags the ramp, the inertial propagation from an anchor taken during the ramp drifts, and
    the check rejected 17 right Doppler epochs in a row and kept them suspect for 5 s; the
    tyres, with a stiffness learned at 0.32 of the file's, carried the slip: beta RMSE 0.290
    deg, 67 % inside 2 sigma.  The check now also allows for the bank change of the last 2 s
    (roll gyro less the suspension's roll, beyond 2 deg of suspension-model slack): 0.020 deg,
    100 %; seeds 0-5 all under 0.035.  Bounds: 0.06 deg (3x the measured), issue 15's 2 sigma
    share, and the check itself left on."""
    drive = sim_drive("banked_turn", 2)
    vehicle = load_vehicle(drive.meta["vehicle"])
    est = run_method("fused", drive, vehicle)
    assert est.params["settings"]["doppler_check"] is True
    assert metrics(drive, est.series)["beta_rmse_deg"] < 0.06
    assert two_sigma_share(drive, est) >= 0.90


@pytest.mark.parametrize("scenario", ["dlc_bank", "race_lap"])
def test_fused_beats_every_paper_method_on_banks_and_at_the_limit(scenario):
    """Where bank transients and tyre saturation defeat the linear models, the fused smoother
    is the best single method (measured: dlc_bank 0.021 vs 0.084 deg, race_lap 0.048 vs
    0.167)."""
    drive = sim_drive(scenario)
    rmse = beta_rmse_all(drive, load_vehicle(drive.meta["vehicle"]))
    others = {k: val for k, val in rmse.items() if k not in OURS}
    best_other = min(others, key=others.get)
    assert rmse["fused"] < others[best_other], (rmse["fused"], best_other, others[best_other])


def test_fused_is_level_with_the_zeroed_linear_graph_on_a_steady_bank():
    """A steady 25 deg bank (banked_turn) no longer defeats the paper's graph once its steering
    sensor is zeroed with the drive's own offset (sideslip.calibrate.steer_zero): per seed the
    two trade places within 0.015 deg (seeds 0-5, deg: fused 0.024 0.015 0.030 0.026 0.015
    0.012, kf_linear 0.021 0.025 0.025 0.013 0.019 0.024).  Issue 15's target on the mean
    over the six draws: within 10 % of the best paper method (measured 0.020 vs 0.021)."""
    total: dict[str, float] = {}
    for seed in range(6):
        drive = sim_drive("banked_turn", seed)
        for name, value in beta_rmse_all(drive, load_vehicle(drive.meta["vehicle"])).items():
            total[name] = total.get(name, 0.0) + value
    best_other = min(v for n, v in total.items() if n not in OURS)
    assert total["fused"] <= 1.10 * best_other, total


@pytest.mark.parametrize(
    ("scenario", "factor"),
    [("demo", 1.0), ("urban_course", 1.0), ("two_turns_gyro_sf", 1.0), ("race_lap", 1.0),
     ("cr_circle", 0.7), ("cr_step_steer", 0.7)],
)  # fmt: skip
def test_beta_std_covers_the_error(scenario, factor):
    """Calibration: a Gaussian 2-sigma covers 95 % of errors.  At least 90 % inside 2 sigma,
    also at the limit (race_lap) and on CommonRoad drives with a 30 %-off file, and sigma not
    more than 20x the actual RMS error (measured with the trapezoidal rule, 2026-12-07: 100 %;
    RMS sigma / RMS error 5.2 demo, 5.9 urban_course, 6.7 two_turns_gyro_sf, 6.6 race_lap,
    6.9 cr_circle, 17.2 cr_step_steer, whose error fell 0.035 -> 0.022 deg under the same
    sigma, the latency term below.  Before it, with the rectangle rule: 4.4 on
    race_lap .. 12.5 on cr_circle and 10.7 on cr_step_steer, 5.4 and 8.4 before the process
    noise was read from the drive: their errors fell 0.120 -> 0.051 and 0.045 -> 0.035 deg,
    the sigma did not, since the latency term below sets it).  What widens sigma most
    against these on-time drives is
    a Doppler latency they cannot decide (one turn at one speed: |r| x the latency's rms about
    0 from the 50 ms prior and the fits, 8.4 on cr_step_steer and 5.4 on cr_circle; 6.0 and
    3.6 with a 30 ms prior, which left step_steer 100 ms late with 18 % inside 2 sigma) and
    the tyre-relaxation term where GNSS pins beta (demo 4.8, urban_course 6.1; 2026-12-07,
    with the relaxation lag no longer differentiating the gyro's noise and the accelerometer
    offset's sigma in beta_std: demo 6.7, urban_course 5.5, race_lap 4.3)."""
    drive = sim_drive(scenario)
    v = load_vehicle(drive.meta["vehicle"])
    est = fuse(drive, v.with_changes(cf=factor * v.cf, cr=factor * v.cr), smooth=True)
    gate = drive["ref_vx"] > SPEED_GATE
    err = np.abs(wrap_angle(est["beta"] - drive["ref_beta"]))[gate]
    std = est["beta_std"][gate]
    assert two_sigma_share(drive, est) > 0.90
    assert np.sqrt(np.mean(std**2)) < 20 * np.sqrt(np.mean(err**2))


def test_rear_stiffness_is_identified_from_a_wrong_vehicle_file():
    """Starting from a file 30 % low in cornering stiffness (slip gain K 43 % high), the
    identified K is within 25 % of the value of the right file's run (m l_f / (L C_r)
    scaled by the identified rear-stiffness factor; the simulator's tyres are Magic Formula,
    so the effective K differs from the file's by a few %; measured 22 % apart, 15 % before
    the axle noise was identified from the innovations (FusedSettings.adapt_min): on the
    highway's long straights the relation's factor sits at its floor, and at turn-in the
    wrong stiffness pulls v_y a little before the factor grows)."""
    drive = sim_drive("urban_highway")
    v = load_vehicle(drive.meta["vehicle"])
    wrong = v.with_changes(cf=0.7 * v.cf, cr=0.7 * v.cr)
    right_est = fuse(drive, v, smooth=True)
    est = fuse(drive, wrong, smooth=True)
    assert est.params["slip_gain_k_prior_s2_m"] == pytest.approx(v.slip_gain_k / 0.7)
    assert est.params["rear_stiffness_scale"] > 1.15  # learned upwards from 1
    assert est.params["slip_gain_k_s2_m"] == pytest.approx(right_est.params["slip_gain_k_s2_m"], rel=0.25)


def test_gyro_bias_and_scale_factor_are_identified():
    """Seed 001's hard case: a 2 % gyro scale factor.  Bias within 0.03 deg/s of the truth the
    simulator drew (gyro noise 0.1 deg/s per sample over 78 s), scale (measured / true) within
    0.4 % of 1 + the drawn scale factor."""
    drive = sim_drive("two_turns_gyro_sf")
    est = fuse(drive, load_vehicle(drive.meta["vehicle"]), smooth=True)
    truth = drive.meta["truth_sensor"]
    assert abs(math.degrees(est["gyro_bias"][-1] - truth["gyro_bias"][2])) < 0.03
    assert est.params["gyro_scale"] == pytest.approx(1.0 + truth["gyro_scale_factor"], abs=0.004)


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


@pytest.mark.parametrize("gnss", [True, False])
def test_filter_is_causal(gnss: bool):
    """fused_filter at row k must not depend on data after row k (it is the on-line form)
    with whole_drive_calibration off; with it on (the default) the calibrations read from the
    whole drive (noise levels, roll gyro bias) make the first half differ.  The cut falls two
    rows into a 50 ms node step: the node updates once read their step's later rows (a 40 ms
    look-ahead at 100 Hz) and differed there; now they read the rows up to their own."""
    drive = sim_drive("dlc_bank")
    if not gnss:
        drive = Drive(drive.t, {k: v for k, v in drive.data.items() if not k.startswith("gnss_")}, drive.meta)
    v = load_vehicle(drive.meta["vehicle"])
    online = FusedSettings(whole_drive_calibration=False)
    full = fuse(drive, v, smooth=False, settings=online)
    cut = len(drive) // 2 + 2
    half = fuse(drive.slice(0, cut), v, smooth=False, settings=online)
    np.testing.assert_allclose(half["beta"], full["beta"][:cut], atol=1e-12)
    calibrated = fuse(drive, v, smooth=False)
    assert not np.allclose(calibrated["beta"], full["beta"], atol=1e-9)


def test_the_causal_filter_learns_the_stiffness_from_a_mean_yaw_rate():
    """urban_course without GNSS: at walking pace the rear slip (v_y - l_r r) / v_x takes
    one gyro sample's noise as its own, and a noisy regressor biases the stiffness fitted
    against it low.  With the node's own gyro row the filter learned a rear scale of 0.75
    and beta 0.133 deg; with the mean of the node step's rows ending there 0.86 and 0.085
    (measured 2026-12-07; the old look-ahead block mean, not causal: 0.074).  Bound: 0.11,
    between the two."""
    full = sim_drive("urban_course")
    drive = Drive(full.t, {k: v for k, v in full.data.items() if not k.startswith("gnss_")}, full.meta)
    est = run_method("fused_filter", drive, load_vehicle(drive.meta["vehicle"]))
    assert metrics(drive, est.series)["beta_rmse_deg"] < 0.11
    assert est.params["rear_stiffness_scale"] > 0.8


def test_straight_driving_is_never_worse_than_zero_sideslip():
    """On the straights of the country road (|a_y| < 0.3 m/s^2), beta = 0 is nearly right;
    fused must not be worse than it by more than 0.1 deg RMSE (measured: 0.01 vs 0.05)."""
    drive = sim_drive("demo")
    est = fuse(drive, load_vehicle(drive.meta["vehicle"]), smooth=True)
    straight = (np.abs(drive["ref_ay"]) < 0.3) & (drive["ref_vx"] > SPEED_GATE)
    fused_rmse = np.degrees(np.sqrt(np.mean((est["beta"] - drive["ref_beta"])[straight] ** 2)))
    zero_rmse = np.degrees(np.sqrt(np.mean(drive["ref_beta"][straight] ** 2)))
    assert fused_rmse < zero_rmse + 0.1


def test_settings_reach_the_method_and_are_recorded():
    """register(..., settings=FusedSettings): run_method takes a mapping, the params record it,
    and a value out of range is one clear ValueError naming the field."""
    drive = sim_drive("step_steer")
    v = load_vehicle(drive.meta["vehicle"])
    est = run_method("fused", drive, v, settings={"step_s": 0.0})
    assert est.params["settings"]["step_s"] == 0.0
    assert est.params["node_step_s"] == pytest.approx(drive.dt_median)
    with pytest.raises(ValueError, match=r"FusedSettings.force_rel = -1.0: expected"):
        FusedSettings(force_rel=-1.0)


def test_health_flags_a_receiver_that_disagrees_with_the_car():
    """Cue consistency: a GNSS whose velocities are 2 m/s off (and positions drifting with
    them) for 10 s disagrees with the wheel speed, the IMU and the tyres beyond every sigma;
    fused says so (health raised on the span, flagged in params) and is not confidently
    wrong: its beta error stays small and mostly inside 2 sigma (measured: health 0.31 on the
    span vs 0.0 on the clean drive, beta error at most 0.17 deg, 96 % inside 2 sigma)."""
    from sideslip.drive import drive_from_columns

    drive = sim_drive("demo")
    cols = {"t": drive.t, **{k: val.copy() for k, val in drive.data.items()}}
    bad = (drive.t > 40.0) & (drive.t < 50.0)
    cols["gnss_ve"][bad] += 2.0
    cols["gnss_e"][bad] += np.cumsum(np.where(bad, 2.0 * drive.dt_median, 0.0))[bad]
    faulty = drive_from_columns(cols, dict(drive.meta))
    v = load_vehicle(drive.meta["vehicle"])
    good, est = fuse(drive, v, smooth=True), fuse(faulty, v, smooth=True)
    assert est["health"][bad].mean() > 0.25
    assert good["health"][bad].mean() < 0.05
    assert est.params["health"]["flagged_share"] > good.params["health"]["flagged_share"] + 0.05
    err = np.abs(est["beta"] - drive["ref_beta"])[bad]
    assert np.degrees(err.max()) < 0.5
    assert np.mean(err < 2 * est["beta_std"][bad]) > 0.85


@pytest.mark.parametrize(
    ("scenario", "factor", "bound"),
    [("race_lap", 1.0, 0.35), ("race_lap", 0.7, 0.40), ("cr_step_steer", 0.7, 0.12)],
)
def test_filter_is_accurate_and_honest_at_the_limit_and_with_a_soft_file(scenario, factor, bound):
    """The causal filter at the limit (race lap: wheels slip -3.5 % braking, +6 % driving,
    which the wheel-speed sigma carries) and on CommonRoad's step steer with a file 30 % soft
    (the stiffness it has not yet learned in the transient is a consider parameter of the
    axle relation): beta RMSE under ``bound`` (measured 0.29 / 0.08 deg; before: 0.25 / 0.29,
    0.27 / 0.17 with the consider stiffness's variance alone, no cross-covariances; the race
    lap with the soft file 0.34, before 0.83, then 0.57, and 0.41 with the cornering drag and
    combined slip in the wheel-speed sigma, whose overconfidence in the first limit corner
    pulled the gyro scale to 3 sigma and the slip with it) and >= 90 % inside 2 sigma
    (measured 0.98 / 1.00; before 0.90 / 0.82: in a corner GNSS cannot tell slip from a gyro scale error until the
    turn is complete, so beta_std carries the tyre relation's error there)."""
    drive = sim_drive(scenario)
    v = load_vehicle(drive.meta["vehicle"])
    est = fuse(drive, v.with_changes(cf=factor * v.cf, cr=factor * v.cr), smooth=False)
    assert metrics(drive, est.series)["beta_rmse_deg"] < bound
    assert two_sigma_share(drive, est) >= 0.90


@pytest.mark.parametrize("smooth", [True, False])
def test_a_drive_that_starts_from_rest_and_reverses(smooth):
    """Parking drive (robust_drives): pull away from rest, 8 m/s with gentle steering, stop,
    reverse at 2 m/s with 10 deg of steer.  Before the rear axle's low-speed relation the
    first Doppler course error at walking pace went into v_y, the tyre relation met a slip
    past saturation and was gated, and beta stayed 5.8 deg (smoother) / 9.4 deg (filter) off
    above 5 m/s with 2 sigma of 6 deg.  Truth here is |beta| <= 1.3 deg; the paper methods
    score 0.02 deg: within 0.2 deg (10x theirs, 3 % of the failure) and the 2-sigma share
    >= 0.9; the heading, 5.8 / 9.3 deg off with it, within 0.5 deg (kkf's bound in issue 15;
    measured 0.08 / 0.14).  Reversing (truth: the kinematic 5.9 deg of 10 deg steer, read as
    atan(v_y / |v_x|)): within 1 deg rms (measured 0.33 / 0.51; it was 4.5 / 6.2)."""
    from tests.methods.robust_drives import parking_drive

    drive = parking_drive()
    est = fuse(drive, load_vehicle("midsize_sedan"), smooth=smooth)
    m = metrics(drive, est.series)
    assert m["beta_rmse_deg"] < 0.2, m["beta_rmse_deg"]
    assert two_sigma_share(drive, est) >= 0.9
    assert m["yaw_rmse_deg"] < 0.5, m["yaw_rmse_deg"]
    rev = drive["ref_vx"] < -1.5
    truth = np.arctan2(drive["ref_vy"][rev], np.abs(drive["ref_vx"][rev]))
    err = np.degrees(est["beta"][rev] - truth)
    assert abs(np.degrees(np.median(truth))) > 5.0
    assert np.sqrt(np.mean(err**2)) < 1.0, np.sqrt(np.mean(err**2))


@pytest.mark.parametrize(
    ("found", "used", "sigma"),
    [
        ((0.05, 0.005), 0.05, math.hypot(0.005, 0.01)),  # decisive and late: applied
        ((0.015, 0.004), 0.0, 0.015),  # the 1 h bench drive on time: within the fit's errors
        ((-0.08, 0.005), 0.0, 0.08),  # the wheels' clock late (a filtered CAN speed)
        ((0.1, 0.05), 0.0, math.hypot(0.05, 0.05 / math.sqrt(2))),  # informs, does not decide
        ((0.2, 0.04), 0.2, math.hypot(0.04, 0.01)),  # a few turns decide a large latency
        ((-3.0, 900.0), 0.0, 0.05),  # tells nothing (one turn at constant speed): the prior
    ],
)
def test_doppler_latency_is_applied_only_where_the_drive_decides_it(monkeypatch, found, used, sigma):
    """fused._doppler_latency's choice from the tyre-free fit: the latency the epochs are taken
    with and the sigma whose |r| multiple enters beta_std (0.05 s: the prior's default)."""
    from sideslip.gnss_latency import LatencyEstimate
    from sideslip.methods import fused

    monkeypatch.setattr(fused, "doppler_fit", lambda drive, geometry: LatencyEstimate(*found, 1.0, 500))
    params: dict[str, object] = {}
    tau, sig = fused._doppler_latency(sim_drive("demo"), FusedSettings(), params)
    assert tau == pytest.approx(used)
    assert sig == pytest.approx(sigma)
    assert params["gnss_doppler_latency_s"] == pytest.approx(used)
    off = FusedSettings(identify_doppler_latency=False)
    assert fused._doppler_latency(sim_drive("demo"), off, {}) == (0.0, 0.0)


def test_a_late_doppler_at_the_limit_is_taken_at_the_latency_its_turns_reveal() -> None:
    """cr_limit_slalom (CommonRoad's multi-body truth, one speed, beta to 5 deg) with every
    GNSS epoch 100 ms late: the wheels cannot time the Doppler, its course rate against the
    lateral accelerometer can (measured +0.091 +- 0.008 s), and fused takes the epochs that
    much earlier: beta RMSE 0.266 deg (0.449 with the epochs at their stamps, 0.229 on time).
    Bounds: the latency within 0.03 s (3.5 sigma) and beta within 0.35 deg, closer to the
    on-time run than to the stamped one."""
    from tests.test_gnss_latency import doppler_drive

    drive = doppler_drive("cr_limit_slalom", 0.1)
    vehicle = load_vehicle(drive.meta["vehicle"])
    est = run_method("fused", drive, vehicle)
    assert est.params["gnss_doppler_latency_s"] == pytest.approx(0.1, abs=0.03)
    assert est.params["gnss_doppler_latency_lateral_fit_s"][1] < 0.015
    assert metrics(drive, est.series)["beta_rmse_deg"] < 0.35
    assert two_sigma_share(drive, est) > 0.9


def test_a_doppler_200_ms_late_is_taken_where_a_few_turns_decide_it() -> None:
    """slalom_low_mu (one speed, 26 s) with every GNSS epoch 200 ms late: the course-rate fit
    reads +0.195 +- 0.015 s, beyond the 15 ms the speed fit alone once needed but 13 sigma
    from 0.  Measured 2026-12-07: fused at the stamps 0.132 deg beta RMSE (inside 2 sigma,
    which carried |r| x the rms latency), with the fit applied 0.020 (0.019 on time).  Bound
    near the geometric mean."""
    from tests.test_gnss_latency import doppler_drive

    drive = doppler_drive("slalom_low_mu", 0.2)
    vehicle = load_vehicle(drive.meta["vehicle"])
    est = run_method("fused", drive, vehicle)
    assert est.params["gnss_doppler_latency_s"] == pytest.approx(0.2, abs=0.03)
    assert metrics(drive, est.series)["beta_rmse_deg"] < 0.05
    assert two_sigma_share(drive, est) > 0.9


def test_a_coarse_log_with_doppler_integrates_its_inputs_on_time() -> None:
    """Seed 002's race lap logged at 20 Hz (every fifth row; the 10 Hz GNSS epochs all kept).
    With each step taking its rows' mean (rectangle rule), the kinematics ran half a row
    (25 ms) behind the interval they propagate over, and against the Doppler that lag read
    r x 25 ms as slip: 0.311 deg beta RMSE (0.048 at 100 Hz) with 93.7 % inside 2 sigma.
    With the trapezoidal rule where Doppler is present: 0.037 deg, 100 % (measured
    2026-12-07); beta_std keeps |r| times half a row for what a sample stands for.  0.1 deg
    is between the two, three times the measured error."""
    from sideslip.drive import drive_from_columns

    whole = sim_drive("race_lap")
    keep = np.zeros(len(whole), dtype=bool)
    keep[::5] = True
    drive = drive_from_columns({"t": whole.t[keep], **{k: np.asarray(v)[keep] for k, v in whole.data.items()}})
    est = run_method("fused", drive, load_vehicle(whole.meta["vehicle"]))
    assert metrics(drive, est.series)["beta_rmse_deg"] < 0.1
    assert two_sigma_share(drive, est) >= 0.97


def test_a_doppler_too_short_to_time_says_why_and_keeps_the_prior() -> None:
    """step_steer (12 s) with a 5 Hz receiver: about 35 usable epochs, fewer than either
    latency fit needs, so nothing is identified; the note says why (it once said "above
    3 m/s" for a drive that was at 22 m/s throughout) and the latency's sigma is the prior's,
    which reaches beta_std through |r| in the turn."""
    from sideslip.doppler_latency_lateral import MIN_EPOCHS
    from sideslip.gnss_latency import MIN_FIXES
    from sideslip.methods import fused
    from sideslip.simulate import SensorConfig, simulate

    drive = simulate("step_steer", seed=0, config=SensorConfig(gnss_rate_hz=5.0))
    params: dict[str, object] = {}
    nz = FusedSettings()
    assert fused._doppler_latency(drive, nz, params) == (0.0, nz.doppler_latency_prior_sigma_s)
    note = str(params["gnss_doppler_latency_note"])
    assert note.startswith("not identified: too few usable Doppler epochs above 3 m/s")
    assert f"the speed fit needs {MIN_FIXES}, the course-rate fit {MIN_EPOCHS}" in note


def test_a_late_doppler_the_drive_cannot_time_widens_beta_std_in_the_turn() -> None:
    """step_steer at one speed, 100 ms late: one turn informs the latency (+0.10 +- 0.06 s)
    but does not decide it.  Without the tyres' profile (on by default, below and
    tests/methods/test_fused_latency.py) the epochs stay at their stamps and beta is about
    r x 0.1 s (1 deg) off in the turn; beta_std carries |r| times the latency's rms about 0
    (0.054 s: the fit with the 50 ms prior), so the errors stay inside 2 sigma (measured
    100 %; 18 % with a 30 ms prior alone).  At one speed the lag r tau v is what an antenna
    tau v behind the file's would add, so the antenna check moves a sensor by about 1.1 m,
    which lowers the error (measured 0.819 -> 0.549 deg), still inside 2 sigma.  The tyres'
    profile takes the epochs 100 ms earlier instead (measured 0.028 deg)."""
    from tests.test_gnss_latency import doppler_drive

    drive = doppler_drive("step_steer", 0.1)
    vehicle = load_vehicle(drive.meta["vehicle"])
    est = run_method("fused", drive, vehicle, {"check_doppler_lever": False, "profile_doppler_latency": False})
    assert est.params["gnss_doppler_latency_s"] == 0.0
    lagged = metrics(drive, est.series)["beta_rmse_deg"]
    assert lagged > 0.5  # the lag is there ...
    assert two_sigma_share(drive, est) > 0.9  # ... and beta_std says so
    checked = run_method("fused", drive, vehicle, {"profile_doppler_latency": False})
    p = checked.params
    assert p["gnss_lever_x_applied_m"] < -0.5 or p["imu_lever_x_applied_m"] > 0.5
    assert metrics(drive, checked.series)["beta_rmse_deg"] < 0.7 * lagged
    assert two_sigma_share(drive, checked) > 0.9
    profiled = run_method("fused", drive, vehicle)
    assert abs(profiled.params["gnss_doppler_latency_s"] - 0.1) < 0.02
    assert metrics(drive, profiled.series)["beta_rmse_deg"] < 0.2 * lagged


@functools.lru_cache(maxsize=1)
def antenna_ahead_drive() -> object:
    """urban_course with the antenna 0.5 m ahead of where the vehicle file says."""
    from sideslip.simulate import SensorConfig, simulate
    from sideslip.simulate.run import _lookup

    config = SensorConfig().with_overrides(_lookup("urban_course").sensor_overrides)
    return simulate("urban_course", seed=0, config=config.with_overrides({"gnss_lever_offset_x": 0.5}))


def test_an_antenna_the_file_misplaces_does_not_make_fused_confidently_wrong() -> None:
    """The Doppler's lateral velocity carries r x 0.5 m the model does not expect (r dl / v of
    course at town speeds).  With the stiffness scales free to 0.2 .. any, the rear scale ran
    to 5.2 and beta was 0.283 deg off with 64 % inside 2 sigma; held to half .. twice the
    file's, the disagreement stays visible: measured 0.178 deg, 98 % (0.037 deg with the right
    antenna).  Bounds: share 0.9, beta under 0.25 deg.  With the file's antenna kept (the
    antenna check off: with it the antenna is moved, tests/methods/test_fused_lever.py)."""
    drive = antenna_ahead_drive()
    est = run_method("fused", drive, load_vehicle(drive.meta["vehicle"]), {"check_doppler_lever": False})
    assert two_sigma_share(drive, est) > 0.9
    assert metrics(drive, est.series)["beta_rmse_deg"] < 0.25
    # the params report the scale the relation used, and say that it was held
    assert est.params["rear_stiffness_scale"] == pytest.approx(2.0)
    assert "held at 2 x the file's" in est.params["rear_stiffness_scale_note"]
    # held at a bound, the scale is no estimate: its sigma is at least the prior's 0.5
    assert est.params["rear_stiffness_scale_sigma"] >= 0.5


def test_an_antenna_the_file_misplaces_is_identified_with_doppler_where_asked() -> None:
    """With identify_doppler_lever the lever-arm error is a state (prior 0.5 m): found 0.56 +-
    0.02 m, beta 0.062 deg, 100 % inside 2 sigma.  Bounds: the lever within 0.15 m, beta under
    0.12 deg, 2-sigma share 0.9."""
    drive = antenna_ahead_drive()
    vehicle = load_vehicle(drive.meta["vehicle"])
    est = run_method("fused", drive, vehicle, settings={"identify_doppler_lever": True})
    assert est.params["gnss_lever_arm_xy_m"][0] == pytest.approx(vehicle.gnss_xyz[0] + 0.5, abs=0.15)
    assert metrics(drive, est.series)["beta_rmse_deg"] < 0.12
    assert two_sigma_share(drive, est) > 0.9


def test_a_tilted_imu_mount_widens_beta_std_by_what_the_drive_cannot_tell_from_bank() -> None:
    """urban_course seed 1 with the IMU mounted about 2 deg off (drawn: roll -2.8, pitch
    -1.9, yaw 1.0 deg): g sin(-2.8 deg) = -0.48 m/s^2 of lateral reading that is no tyre
    force, twice accel_offset_sigma.  The drive's typical lateral offset (the median of
    c_y) may be crossfall or tilt; half of it enters the offset's sigma: 86 % of the beta
    errors inside 2 sigma without it, 100 % with it (beta itself unchanged, 0.166 deg)."""
    from sideslip.simulate import SensorConfig, simulate
    from sideslip.simulate.run import _lookup

    cfg = SensorConfig().with_overrides(_lookup("urban_course").sensor_overrides)
    drive = simulate("urban_course", seed=1, config=cfg.with_overrides({"imu_misalignment_std": math.radians(2.0)}))
    assert math.degrees(drive.meta["truth_sensor"]["imu_misalignment"][0]) < -2.5
    vehicle = load_vehicle(drive.meta["vehicle"])
    est = run_method("fused", drive, vehicle)
    off = run_method("fused", drive, vehicle, settings={"offset_level_share": 0.0})
    assert two_sigma_share(drive, est) >= 0.95
    assert two_sigma_share(drive, off) < 0.90
    np.testing.assert_array_equal(est["beta"], off["beta"])
    assert est.params["accel_offset_level_m_s2"] > 0.3


@pytest.mark.parametrize("receiver", ["doppler", "positions"])
def test_a_gyro_flipped_against_the_gnss_course_is_one_clear_error(receiver):
    """demo with its yaw gyro's sign flipped (a z axis mounted down): the course over 1 s
    turns against the gyro (correlation -0.99 with Doppler), which is bad input, named in one
    line by every method (registry.run_method), rather than a drive fused would fit with tyres
    and a gyro scale of -1."""
    from dataclasses import replace

    from sideslip.errors import InputError

    drive = sim_drive("demo")
    if receiver == "positions":
        drive = replace(drive, data={k: v for k, v in drive.data.items() if k not in ("gnss_ve", "gnss_vn")})
    flipped = replace(drive, data={**drive.data, "wz": -np.asarray(drive.data["wz"])})
    vehicle = load_vehicle(drive.meta["vehicle"])
    for method in ("fused", "kkf", "fg_batch", "obs_bicycle"):  # every method (run_method)
        with pytest.raises(InputError, match="column 'wz': yaw rate turns opposite to the GNSS course") as err:
            run_method(method, flipped, vehicle)
        assert "\n" not in str(err.value)
    est = run_method("fused", drive, vehicle)  # the same drive with its gyro as mounted runs
    assert np.isfinite(est["beta"]).all()


@pytest.mark.parametrize(
    ("scenario", "fault", "message"),
    [
        ("urban_course", "gnss", "column 'gnss_ve': the GNSS course turns opposite to the yaw rate"),
        ("demo", "gnss", "column 'gnss_ve': the GNSS course turns opposite to the yaw rate"),
        ("urban_course", "sae", "column 'wz': the yaw rate and ay turn opposite to the GNSS course .* SAE axes"),
        ("urban_course", "positions", "column 'gnss_e': the course of the GNSS positions turns opposite"),
    ],
)
def test_a_course_turning_against_the_gyro_names_the_culprit(scenario, fault, message):
    """The GNSS in north-east order (gnss_ve and gnss_vn, gnss_e and gnss_n swapped, as a NED
    receiver's columns put into ENU names) turns its course against the yaw rate, as a gyro
    mounted upside down does; the steering (and ay, where the drive turns enough for the
    units check's slope) turning with the gyro names the GNSS columns instead (measured
    correlations -0.98 / -0.99 against the course, 1.00 with the steering).  An IMU in SAE
    axes (ay and wz both flipped) agrees with itself and turns against the steering: the IMU
    is named.  Only the positions swapped (the Doppler right): the fixes' own course turns
    against the gyro and the Doppler (correlation -0.61 against 0.98; the smoother read 19
    deg with 95 % flagged); the positions are named.  No drive of the comparison (16
    scenarios x seeds 0-2) nor the comma2k19 minute trips any of these.  One line each."""
    from dataclasses import replace

    from sideslip.errors import InputError

    drive = sim_drive(scenario)
    d = drive.data
    if fault == "gnss":
        data = {**d, "gnss_ve": d["gnss_vn"], "gnss_vn": d["gnss_ve"], "gnss_e": d["gnss_n"], "gnss_n": d["gnss_e"]}
    elif fault == "positions":
        data = {**d, "gnss_e": d["gnss_n"], "gnss_n": d["gnss_e"]}
    else:
        data = {**d, "wz": -np.asarray(d["wz"]), "ay": -np.asarray(d["ay"])}
    vehicle = load_vehicle(drive.meta["vehicle"])
    with pytest.raises(InputError, match=message) as err:
        run_method("kkf", replace(drive, data=data), vehicle)
    assert "\n" not in str(err.value)
    assert ("north-east (NED) order" in str(err.value)) == (fault == "gnss")
