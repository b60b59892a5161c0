"""doppler_slip / doppler_slip_noroll (seed 000): slip gain K, sideslip, roll, dead reckoning.

Two kinds of drive:
* ``steady_drive``: an analytic truth built here that obeys the paper's model exactly
  (beta_r = -K G_y with the vehicle file's K, suspension roll = static gain x G_y, road bank),
  run through the simulator's *sensor* models (noise, biases, scale factors, multipath).  The
  method must recover K, b_ay and beta to within what the sensor noise allows.
* the simulator's urban scenarios (nonlinear tyres, roll dynamics): the paper's orderings.
"""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest

from sideslip.drive import Drive
from sideslip.methods.doppler_slip import (
    doppler_slip,
    doppler_slip_noroll,
    fit_slip_gain,
    run_doppler_slip,
)
from sideslip.methods.registry import all_methods, run_method
from sideslip.simulate.road import road_from_pieces, straight, turn
from sideslip.simulate.run import drive_from_truth
from sideslip.simulate.sensors import SensorConfig
from sideslip.simulate.truth import Truth
from sideslip.vehicle import G, Vehicle, load_vehicle

VEHICLE = "alphard_minivan"


def _route(bank_deg: float) -> tuple[list, list]:
    pieces: list = straight(200.0)
    for angle, radius, length in [
        (90, 40, 250), (-90, 50, 200), (120, 60, 300), (-60, 45, 250), (-90, 35, 200),
        (90, 70, 350), (180, 45, 250), (-120, 55, 300), (90, 40, 250), (-90, 60, 300),
    ]:  # fmt: skip
        pieces += turn(angle, radius, 20.0) + straight(length)
    total = sum(p[0] for p in pieces)
    bank = [(0.0, 0.0), (0.3 * total, bank_deg), (0.6 * total, bank_deg), (0.7 * total, -bank_deg),
            (total, -bank_deg)]  # fmt: skip
    return pieces, bank


def steady_truth(vehicle: Vehicle, speed: float = 13.0, bank_deg: float = 4.0, dt: float = 0.01) -> Truth:
    """Analytic truth obeying seed 000's model; standstill 10 s at both ends."""
    pieces, bank_knots = _route(bank_deg)
    road = road_from_pieces(pieces, bank_deg=bank_knots)
    acc = 1.5
    t_acc = speed / acc
    t_cruise = (road.length - speed * t_acc) / speed
    t_total = 10.0 + 2 * t_acc + t_cruise + 10.0
    t = np.arange(0.0, t_total, dt)
    tau = t - 10.0
    v = np.clip(np.minimum(acc * tau, speed), 0.0, None)
    v = np.minimum(v, np.clip(acc * (t_total - 10.0 - t), 0.0, None))
    s = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * dt)])
    s = np.minimum(s, road.length)
    course = road.at(s, "heading")
    bank = road.at(s, "bank")
    kappa = road.at(s, "curvature")
    a_lat = v * v * kappa
    gy = a_lat + G * np.sin(bank)  # lateral tyre force per unit mass (our roll sign)
    roll_sus = vehicle.static_roll_gain * gy
    roll = bank + roll_sus
    r0 = v * kappa
    moving = v > 0.5
    beta = np.where(moving, -vehicle.slip_gain_k * gy + vehicle.lr * r0 / np.maximum(v, 0.5), 0.0)
    yaw = course - beta
    r = np.gradient(yaw, t)
    vx, vy = v * np.cos(beta), v * np.sin(beta)
    e, n = road.at(s, "e"), road.at(s, "n")
    vel = np.column_stack([np.gradient(e, t), np.gradient(n, t)])
    acc_enu = np.column_stack([np.gradient(vel[:, 0], t), np.gradient(vel[:, 1], t), np.zeros_like(t)])
    c, sn = np.cos(yaw), np.sin(yaw)
    ax_h = c * acc_enu[:, 0] + sn * acc_enu[:, 1]
    ay_h = -sn * acc_enu[:, 0] + c * acc_enu[:, 1]
    droll = np.gradient(roll, t)
    omega = np.column_stack([droll, r * np.sin(roll), r * np.cos(roll)])
    half = 0.5 * vehicle.track_rear
    wheel = np.column_stack([vx - r * half, vx + r * half, vx - r * half, vx + r * half])
    zeros = np.zeros_like(t)
    return Truth(
        t=t, e=e, n=n, u=zeros, yaw=yaw, pitch=zeros, roll=roll, roll_sus=roll_sus, bank=bank,
        grade=zeros, vx=vx, vy=vy, r=r, ax=ax_h, ay=ay_h, acc_enu=acc_enu, omega_body=omega,
        wheel_speed=wheel, steer=vehicle.wheelbase * kappa, mu=np.ones_like(t),
    )  # fmt: skip


@functools.lru_cache(maxsize=8)
def steady_drive(seed: int = 0, bank_deg: float = 4.0, accel_bias: float = 0.0,
                 multipath: float = 0.002, outages: tuple = ()) -> Drive:  # fmt: skip
    """The analytic truth through the simulator's sensor models (default grades)."""
    vehicle = load_vehicle(VEHICLE)
    truth = steady_truth(vehicle, bank_deg=bank_deg)
    cfg = SensorConfig(gnss_multipath_prob=multipath, gnss_outages=outages)
    drive = drive_from_truth(truth, vehicle, seed, cfg, "steady", VEHICLE)
    if accel_bias:
        data = dict(drive.data)
        data["ay"] = data["ay"] + accel_bias
        drive = Drive(drive.t, data, {**drive.meta, "extra_ay_bias": accel_bias}, drive.path)
    return drive


def rms_deg(x: np.ndarray) -> float:
    return float(np.degrees(np.sqrt(np.mean(np.square(x)))))


@functools.lru_cache(maxsize=16)
def estimate(scenario: str, use_roll: bool = True, extra_ay: float = 0.0):
    """(drive, estimate) for a simulator scenario, optionally with an added a_y error."""
    from tests.conftest import sim_drive

    drive = sim_drive(scenario, 0)
    if extra_ay:
        drive = Drive(drive.t, {**drive.data, "ay": drive.data["ay"] + extra_ay}, drive.meta,
                      drive.path)  # fmt: skip
    vehicle = load_vehicle(drive.meta["vehicle"])
    return drive, run_doppler_slip(drive, vehicle, use_roll=use_roll)


def moving(drive: Drive) -> np.ndarray:
    return np.nan_to_num(drive["ref_vx"]) > 5.0


# ---- analytic drive (the paper's model holds exactly) --------------------------------------
def test_steady_drive_recovers_k_and_beta() -> None:
    drive = steady_drive(0)
    vehicle = load_vehicle(VEHICLE)
    est = doppler_slip(drive, vehicle)
    p = est.params
    assert p["slip_correction_applied"] and p["slip_correction_note"] == ""
    # with roll, G_y is the accelerometer reading, which holds the suspension roll's gravity
    # part: the K to expect is m lf / (L cr) / (1 + g m h / k_phi) (docstring); 5 %: the fit's
    # 1-sigma is ~2 % and the truth's a_y = V^2 kappa differs from psi' V in the transitions
    assert p["K"] == pytest.approx(p["K_vehicle_accel"], rel=0.05)
    assert p["K_vehicle_accel"] == pytest.approx(
        vehicle.slip_gain_k / (1 + G * vehicle.static_roll_gain))
    err = est["beta"][moving(drive)] - drive["ref_beta"][moving(drive)]
    # beta up to 1.2 deg; the K error (~2 %) and heading noise leave a few hundredths of a deg
    assert rms_deg(err) < 0.05
    assert est["beta"].min() < np.radians(-0.5) and est["beta"].max() > np.radians(0.5)


def test_slip_correction_is_really_applied_in_curves() -> None:
    # the ROS implementation's failure: correction silently off.  Here beta - l_r r / V must
    # equal -K G_y, and be far from zero in curves
    drive = steady_drive(0)
    vehicle = load_vehicle(VEHICLE)
    est = doppler_slip(drive, vehicle)
    v = np.nan_to_num(drive["ref_vx"])
    curve = (np.abs(est["r"]) > 0.15) & (v > 5)
    beta_r = est["beta"][curve] - np.arctan(vehicle.lr * est["r"][curve] / v[curve])
    assert np.median(np.abs(beta_r)) > np.radians(0.3)
    assert est.params["slip_correction_applied"] is True


def test_poor_curve_data_fall_back_to_the_vehicle_file_then_to_no_correction() -> None:
    import math

    drive = steady_drive(0).slice(0, 2800)  # standstill, pull-away, 200 m straight: no curve
    vehicle = load_vehicle(VEHICLE)
    est = doppler_slip(drive, vehicle)
    p = est.params
    assert p["K"] == 0.0  # nothing identified ...
    assert p["K_source"] == "vehicle file"  # ... so the file's m lf / (L cr) is used, and said
    assert p["K_used"] == pytest.approx(p["K_vehicle_accel"])
    assert "no slip correction applied" in p["slip_correction_note"]
    assert "using the vehicle file's K instead" in p["slip_correction_note"]
    # a file without the rear cornering stiffness: no correction at all, and said why
    est = doppler_slip(drive, vehicle.with_changes(cr=math.nan))
    p = est.params
    assert p["K_source"] == "none" and p["slip_correction_applied"] is False
    assert "no slip correction applied" in p["slip_correction_note"]
    for name, values in est.series.items():
        assert np.isfinite(values).all(), name


def test_slip_gain_guards() -> None:
    rng = np.random.default_rng(3)
    gy = rng.uniform(-4.0, 4.0, 400)
    good = fit_slip_gain(gy, -0.007 * gy + rng.normal(0, 0.003, 400), per_second=10.0)
    assert good.applied and good.k == pytest.approx(0.007, rel=0.1)
    assert 0 < good.k_std < 0.001
    few = fit_slip_gain(gy[:20], -0.007 * gy[:20], per_second=10.0)
    assert not few.applied and "too few curve samples" in few.reason
    narrow = fit_slip_gain(np.full(400, 0.6) + rng.normal(0, 0.05, 400),
                           rng.normal(0, 0.003, 400), per_second=10.0)  # fmt: skip
    assert not narrow.applied and "spans" in narrow.reason
    # curve data without slip information (pure noise, multipath-like): K must not diverge
    noise = fit_slip_gain(gy, rng.normal(0, 0.05, 400), per_second=10.0)
    assert not noise.applied and noise.k == 0.0
    absurd = fit_slip_gain(gy, -0.2 * gy, per_second=10.0)
    assert not absurd.applied and "outside" in absurd.reason
    wrong_sign = fit_slip_gain(gy, 0.007 * gy, per_second=10.0)
    assert not wrong_sign.applied


def test_beta_std_does_not_blow_up_after_turns() -> None:
    drive = steady_drive(0)
    est = doppler_slip(drive, load_vehicle(VEHICLE))
    std = est["beta_std"]
    straight = (np.abs(est["r"]) < 0.005) & (np.nan_to_num(drive["ref_vx"]) > 5)
    first_half = straight & (drive.t < drive.t[-1] / 2)
    second_half = straight & (drive.t > drive.t[-1] / 2)
    # after ten turns the straight-line 1-sigma is what it was before them (banked road:
    # G_y = g sin(bank) on straights, hence not exactly the floor)
    assert np.median(std[second_half]) < 1.5 * np.median(std[first_half]) + np.radians(0.01)
    assert std.max() < np.radians(0.5)
    # and it is honest: the errors sit within ~2 sigma
    err = est["beta"] - drive["ref_beta"]
    mv = moving(drive)
    assert np.mean(np.abs(err[mv]) < 2.5 * std[mv]) > 0.9


def test_standstill_and_a_gnss_outage_stay_finite_and_sensible() -> None:
    drive = steady_drive(0, outages=((120.0, 180.0),))
    est = doppler_slip(drive, load_vehicle(VEHICLE))
    for name, values in est.series.items():
        assert np.isfinite(values).all(), name
    still = np.nan_to_num(drive["ref_vx"]) < 0.05
    assert np.all(est["beta"][still] == 0.0)
    inside = (drive.t > 120.0) & (drive.t < 180.0)
    yaw_err = np.degrees(np.angle(np.exp(1j * (est["yaw"] - drive["ref_yaw"]))))
    # 60 s on the gyro alone: offset known to ~2e-5 rad/s, random walk 2e-5 rad/s/sqrt(s)
    assert np.max(np.abs(yaw_err[inside])) < 0.3
    err = est["beta"][inside & moving(drive)] - drive["ref_beta"][inside & moving(drive)]
    assert rms_deg(err) < 0.1


def test_noroll_variant_needs_no_accelerometer() -> None:
    drive = steady_drive(0)
    data = {k: v for k, v in drive.data.items() if k not in ("ax", "ay", "az")}
    no_acc = Drive(drive.t, data, drive.meta, drive.path)
    est = doppler_slip_noroll(no_acc, load_vehicle(VEHICLE))
    assert "roll" not in est.series and est.params["slip_correction_applied"]
    assert rms_deg(est["beta"][moving(drive)] - drive["ref_beta"][moving(drive)]) < 0.5


def test_registered_with_their_columns() -> None:
    methods = all_methods()
    assert "doppler_slip" in methods and "doppler_slip_noroll" in methods
    assert "steer" not in methods["doppler_slip"].columns
    assert methods["doppler_slip"].vehicle_params == ()
    est = run_method(methods["doppler_slip"], steady_drive(0), load_vehicle(VEHICLE))
    assert {"beta", "yaw", "roll", "e", "n", "gyro_bias", "ay_bias", "beta_std"} <= set(est.series)


def test_cornering_stiffness_30_percent_off_changes_nothing_but_the_reference_k() -> None:
    drive = steady_drive(0)
    vehicle = load_vehicle(VEHICLE)
    off = vehicle.with_changes(cf=0.7 * vehicle.cf, cr=0.7 * vehicle.cr)
    a, b = doppler_slip(drive, vehicle), doppler_slip(drive, off)
    assert np.array_equal(a["beta"], b["beta"]) and np.array_equal(a["e"], b["e"])
    assert b.params["K_vehicle"] == pytest.approx(a.params["K_vehicle"] / 0.7)


# ---- the simulator's urban scenarios: the paper's evaluation --------------------------------
@pytest.mark.parametrize("scenario", ["urban_course", "urban_highway"])
def test_slip_error_is_at_the_papers_level(scenario: str) -> None:
    # paper, table 4: mean 0.01 / -0.01 deg, std 0.07 / 0.10 deg (POS LV reference)
    drive, est = estimate(scenario)
    err = np.degrees(est["beta"] - drive["ref_beta"])[moving(drive)]
    assert abs(np.mean(err)) < 0.1
    assert np.std(err) < 0.15
    assert est.params["slip_correction_applied"]


@pytest.mark.parametrize("scenario", ["urban_course", "urban_highway"])
def test_identified_k_matches_the_vehicle_file(scenario: str) -> None:
    _, est = estimate(scenario)
    p = est.params
    # Pacejka tyres and load transfer make the simulator's K differ from the linear model's;
    # 15 % covers that and the fit's ~5 % 1-sigma on these short drives
    assert p["K"] == pytest.approx(p["K_vehicle_accel"], rel=0.15)
    assert p["K_std"] < 0.2 * p["K"]


@pytest.mark.parametrize("scenario", ["urban_course", "urban_highway"])
def test_slip_correction_improves_the_100m_cross_track_error(scenario: str) -> None:
    from sideslip.evaluate import xtrack_100m

    drive, est = estimate(scenario)
    with_slip = np.abs(xtrack_100m(drive, est["e"], est["n"], est["yaw"]))
    without = np.abs(xtrack_100m(drive, est["e_noslip"], est["n_noslip"], est["yaw"]))
    assert np.percentile(with_slip, 95) < np.percentile(without, 95)
    assert np.mean(with_slip) < np.mean(without)
    # the paper's requirement: 0.3 m per 100 m
    assert np.percentile(with_slip, 95) < 0.3


def test_roll_term_helps_most_on_the_banked_highway() -> None:
    from sideslip.evaluate import xtrack_100m

    drive, full = estimate("urban_highway", True)
    _, noroll = estimate("urban_highway", False)
    mv = moving(drive)
    err_full = rms_deg(full["beta"][mv] - drive["ref_beta"][mv])
    err_noroll = rms_deg(noroll["beta"][mv] - drive["ref_beta"][mv])
    assert err_full < 0.5 * err_noroll
    xt_full = np.abs(xtrack_100m(drive, full["e"], full["n"], full["yaw"]))
    xt_noroll = np.abs(xtrack_100m(drive, noroll["e"], noroll["n"], noroll["yaw"]))
    assert np.mean(xt_full) < np.mean(xt_noroll)


def test_roll_error_with_and_without_the_accelerometer_correction() -> None:
    # the paper's tables 2-3, with its identified 0.25 m/s^2 lateral error added to our IMU;
    # the highway's 11 curves pin delta G_y to ~0.1 m/s^2
    drive, est = estimate("urban_highway", True, 0.25)
    mv = moving(drive)
    err = np.degrees(est["roll"] - drive["ref_roll"])[mv]
    err_raw = np.degrees(est["roll_raw"] - drive["ref_roll"])[mv]  # eq 16 with delta G_y = 0
    assert abs(np.mean(err)) < 0.5 * abs(np.mean(err_raw))
    assert abs(np.mean(err)) < 0.3  # paper: -0.17 deg against -1.06 deg
    assert np.std(err) < 0.15  # paper: 0.29 deg
    assert est.params["dGy_note"] == "" and est.params["ay_bias_applied"]


def test_urban_course_curves_too_few_to_pin_the_accelerometer_error_say_so() -> None:
    # the urban course has six 90 deg corners; left out one at a time (jackknife) they move
    # delta G_y by ~0.2 m/s^2, so the honest 1-sigma is above the 0.15 m/s^2 limit: the
    # correction is not applied, the reason is given, and the 1-sigma holds the truth
    drive, est = estimate("urban_course", True, 0.25)
    p = est.params
    assert not p["ay_bias_applied"] and "too uncertain" in p["dGy_note"]
    assert np.array_equal(est["roll"], est["roll_raw"])
    true_dgy = -(drive.meta["truth_sensor"]["ay_bias_level"] + 0.25)
    assert abs(p["dGy_joint_mps2"] - true_dgy) < 2.0 * p["dGy_std_mps2"]


def test_another_scenario_and_vehicle_is_finite_and_not_absurd() -> None:
    drive, est = estimate("demo")
    for name, values in est.series.items():
        assert np.isfinite(values).all(), name
    mv = moving(drive)
    assert rms_deg(est["beta"][mv] - drive["ref_beta"][mv]) < 1.0
    assert 0.0 <= est.params["K"] < 0.03


def test_cli_estimate_and_evaluate(tmp_path) -> None:
    from sideslip.drive import save_drive
    from tests.helpers import run_cli

    drive = steady_drive(0)
    path = tmp_path / "drive.parquet"
    save_drive(drive, path)
    out = tmp_path / "est.parquet"
    res = run_cli("estimate", path, "--vehicle", VEHICLE, "--method", "doppler_slip",
                  "--out", out)  # fmt: skip
    assert res.returncode == 0, res.stderr
    res = run_cli("evaluate", path, out, "--json", tmp_path / "m.json")
    assert res.returncode == 0, res.stderr
    import json

    metrics = json.loads((tmp_path / "m.json").read_text())["doppler_slip"]
    assert metrics["beta_rmse_deg"] < 0.05
    assert math.isfinite(metrics["xtrack_100m_p95_m"])


def _reversing_truth(vehicle: Vehicle, dt: float = 0.01) -> Truth:
    """Straight East: 30 s forward at up to 12 m/s, stop, 20 s backwards at up to -6 m/s."""
    t = np.arange(0.0, 70.0, dt)
    v = np.interp(t, [0, 5, 25, 30, 35, 40, 55, 60, 70], [0, 12, 12, 0, 0, -6, -6, 0, 0])
    yaw = np.full_like(t, 0.3)
    s = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * dt)])
    e, n = s * np.cos(0.3), s * np.sin(0.3)
    a = np.gradient(v, t)
    acc = np.column_stack([a * np.cos(0.3), a * np.sin(0.3), np.zeros_like(t)])
    zeros = np.zeros_like(t)
    return Truth(
        t=t, e=e, n=n, u=zeros, yaw=yaw, pitch=zeros, roll=zeros, roll_sus=zeros, bank=zeros,
        grade=zeros, vx=v, vy=zeros, r=zeros, ax=a, ay=zeros, acc_enu=acc,
        omega_body=np.zeros((t.size, 3)), wheel_speed=np.column_stack([v, v, v, v]),
        steer=zeros, mu=np.ones_like(t),
    )  # fmt: skip


def test_reversing_keeps_the_heading_and_gives_zero_sideslip() -> None:
    vehicle = load_vehicle(VEHICLE)
    drive = drive_from_truth(_reversing_truth(vehicle), vehicle, 0, SensorConfig(), "rev", VEHICLE)
    est = doppler_slip(drive, vehicle)
    for name, values in est.series.items():
        assert np.isfinite(values).all(), name
    back = drive["ref_vx"] < -0.5
    assert np.all(est["beta"][back] == 0.0)
    # the Doppler course points backwards while reversing; it is turned by pi, so the heading
    # stays on the body axis (0.3 rad) to within the course noise and gyro drift
    assert np.max(np.abs(np.degrees(est["yaw"] - 0.3))) < 0.5
    # dead reckoning follows the reference backwards too (wheel scale ~0.5 %, GNSS start ~1 m)
    end_err = np.hypot(est["e"][-1] - drive["ref_e"][-1], est["n"][-1] - drive["ref_n"][-1])
    assert end_err < 3.0


def test_without_lr_the_rear_axle_sideslip_is_output_and_said() -> None:
    drive = steady_drive(0)
    vehicle = load_vehicle(VEHICLE).with_changes(lr=math.nan)
    est = doppler_slip(drive, vehicle)
    assert est.params["beta_point"].startswith("rear axle")
    assert np.isfinite(est["beta"]).all()


# ---- self-check: transient lag, honest beta_std, health ------------------------------------
def _two_sigma_share(drive: Drive, est) -> float:
    mv = moving(drive)
    err = np.abs(est["beta"] - drive["ref_beta"])[mv]
    return float(np.mean(err < 2.0 * est["beta_std"][mv]))


def test_slip_lag_is_identified_near_the_friction_limit_and_helps() -> None:
    # race lap (seed 002's car near mu): the steady-state relation lags the turn-ins; the
    # Doppler innovations identify the lag (significant at 3 sigma) and the corrected beta is
    # better than the steady-state one (measured 0.48 -> 0.23 deg RMSE)
    from tests.conftest import sim_drive

    drive = sim_drive("race_lap", 0)
    vehicle = load_vehicle(drive.meta["vehicle"])
    est = run_doppler_slip(drive, vehicle)
    p = est.params
    assert p["slip_lag_applied"] and 0.05 < p["slip_lag_s"] < 0.6
    mv = moving(drive)
    rmse = rms_deg((est["beta"] - drive["ref_beta"])[mv])
    assert rmse < 0.35  # steady-state relation alone: 0.48 deg
    assert _two_sigma_share(drive, est) >= 0.9


@pytest.mark.parametrize("scenario", ["urban_course", "urban_highway"])
def test_lag_not_significant_on_urban_drives_is_not_applied(scenario: str) -> None:
    _drive, est = estimate(scenario)
    assert not est.params["slip_lag_applied"] and "not significant" in est.params["slip_lag_note"]


@pytest.mark.parametrize("use_roll", [True, False])
def test_beta_std_honest_on_a_low_mu_slalom_and_a_banked_lane_change(use_roll: bool) -> None:
    # 0.5 Hz slalom at 140 km/h on mu 0.25 (unmodelled lag) and a lane change on a 16 deg bank
    # (the no-roll variant's relation leaves out the bank): a calibrated 1-sigma keeps about
    # 95 % of the errors inside 2 sigma; 0.9 is the acceptance bound (before: 0.74 and 0.49)
    from tests.conftest import sim_drive

    for scenario in ("slalom_low_mu", "dlc_bank"):
        drive = sim_drive(scenario, 0)
        est = run_doppler_slip(drive, load_vehicle(drive.meta["vehicle"]), use_roll=use_roll)
        assert _two_sigma_share(drive, est) >= 0.9, scenario


def test_health_flags_reversing_and_long_outages_and_is_bounded() -> None:
    from tests.methods.robust_drives import parking_drive

    drive = parking_drive(0)
    est = doppler_slip(drive, load_vehicle("midsize_sedan"))
    h = est["health"]
    assert np.all(np.isfinite(h)) and h.min() >= 0.0 and h.max() <= 1.0
    rev = drive["ref_vx"] < -1.0
    assert np.all(h[rev] == 1.0)
    fast = drive["ref_vx"] > 6.0
    assert np.median(h[fast]) < 0.5
    assert "flagged_share" in est.params["health"]


def test_settings_reach_the_method_and_bad_values_say_what_is_expected() -> None:
    from sideslip.errors import InputError
    from sideslip.methods.registry import run_method

    drive = steady_drive(0)
    vehicle = load_vehicle(VEHICLE)
    strict = run_method("doppler_slip", drive, vehicle, {"dgy_max_sigma_m_s2": 0.0})
    assert not strict.params["ay_bias_applied"] and "too uncertain" in strict.params["dGy_note"]
    assert strict.params["settings"]["dgy_max_sigma_m_s2"] == 0.0
    with pytest.raises(InputError, match=r"k_min_speed_m_s = 0\.1: expected 0\.5 \.\.\. 50"):
        run_method("doppler_slip", drive, vehicle, {"k_min_speed_m_s": 0.1})


COST_SCRIPT = """
import math, time
from sideslip.bench import tiled_drive
from sideslip.methods.registry import run_method
from sideslip.simulate import simulate
from sideslip.vehicle import load_vehicle
short = simulate("endurance", seed=0, duration_s=1200.0)
vehicle = load_vehicle(short.meta["vehicle"])
long = tiled_drive(short, 80.0 / 60.0)
run_method("doppler_slip", short.slice(0, 6000), vehicle)
def cpu_s(drive):
    best = math.inf
    for _ in range(2):
        start = time.process_time()
        run_method("doppler_slip", drive, vehicle)
        best = min(best, time.process_time() - start)
    return best
print(cpu_s(long) / cpu_s(short))
"""


def test_cost_grows_linearly_with_the_drive_length() -> None:
    """Issue #17 point 1, the whole method: CPU time of an 80 min drive over a 20 min one.

    Linear is 4 (measured 3.7-5.0: the long drive's arrays outgrow the CPU caches),
    quadratic 16.  The long drive is the short one tiled (same curves, stops and GNSS per
    hour).  Each time is the best of two runs in CPU seconds of a child process with
    single-threaded BLAS, so that neither other load nor BLAS threads spinning count.  At
    these lengths the quadratic terms removed for issue #17 were still small on one thread
    (the old code gives about 6 here, 37 s at 4 h); the pieces themselves are tested without
    a clock in test_doppler_heading.py (peak memory) and test_doppler_stats.py.
    """
    import os
    import subprocess
    import sys

    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1",
           "MKL_NUM_THREADS": "1"}
    done = subprocess.run([sys.executable, "-c", COST_SCRIPT], env=env, capture_output=True,
                          text=True, timeout=300, check=True)
    ratio = float(done.stdout.strip().splitlines()[-1])
    assert ratio < 6.5, f"80 min / 20 min CPU time = {ratio:.1f} (linear 4, quadratic 16)"


@pytest.mark.commonroad
@pytest.mark.parametrize("method", ["doppler_slip", "doppler_slip_noroll"])
def test_a_ramp_to_the_grip_limit_widens_beta_std_by_the_fits_intercept(method: str) -> None:
    """cr_limit_ramp: CommonRoad's multi-body BMW ramps to 0.95 mu g, where beta_r(G_y) bends.
    The straight line of eq 20 leaves an intercept (0.46 / 0.40 deg, measured) that the
    self-check's innovation carries but beta does not, and beta was 0.9 deg off mid-ramp with
    a 1-sigma of 0.3: 73 % / 78 % of the errors inside 2 sigma.  With |c| in beta_std on the
    curves >= 0.90 (measured 1.00), and the band stays under 1.5 deg (median 1-sigma 0.61 /
    0.66 deg measured at an RMSE of 0.51 / 0.54)."""
    pytest.importorskip("vehiclemodels", reason="needs the optional commonroad extra")
    from tests.conftest import sim_drive

    drive = sim_drive("cr_limit_ramp", 0)
    est = run_method(method, drive, load_vehicle(drive.meta["vehicle"]))
    assert est.params["K_source"] == "identified" and est.params["K_intercept_in_beta_std"]
    assert math.degrees(abs(est.params["K_intercept_rad"])) > 0.3  # the line does bend here
    fast = drive["ref_vx"] > 5.0
    err = np.abs(est["beta"] - drive["ref_beta"])[fast]
    assert math.degrees(err.max()) > 0.8  # confidently wrong before
    assert np.mean(err < 2 * est["beta_std"][fast]) >= 0.90
    assert math.degrees(np.median(est["beta_std"][fast])) < 1.5


@pytest.mark.parametrize(
    "scenario", ["slalom_low_mu", pytest.param("cr_limit_slalom", marks=pytest.mark.commonroad)]
)
def test_a_slalom_does_not_set_the_gyro_scale(scenario: str) -> None:
    """In a slalom the yaw acceleration moves with the heading swing, so the transient slip the
    steady relation leaves out read as a gyro gain: measured 1.11 +- 0.03 on the low-mu
    slalom (truth 1.000) and, with the roll variant at the CommonRoad limit slalom seed 4,
    1.14 +- 0.03 with beta 1.55 deg off (noroll 0.54).  With the heading fit's transient
    nuisance the scale stays within 2 sigma (and 3 %) of the simulated one, and beta follows
    (measured 0.031 and 0.61 deg)."""
    from tests.conftest import sim_drive

    if scenario.startswith("cr_"):
        pytest.importorskip("vehiclemodels", reason="needs the optional commonroad extra")
    seed = 4 if scenario.startswith("cr_") else 0
    drive = sim_drive(scenario, seed)
    est = run_doppler_slip(drive, load_vehicle(drive.meta["vehicle"]))
    truth = 1.0 + drive.meta["truth_sensor"]["gyro_scale_factor"]  # measured / true, z axis
    p = est.params
    assert abs(p["gyro_scale"] - truth) < 2.0 * p["gyro_scale_sigma"]
    assert abs(p["gyro_scale"] - truth) < 0.03
    rmse = rms_deg((est["beta"] - drive["ref_beta"])[moving(drive)])
    assert rmse < (0.05 if seed == 0 else 0.8)  # before: 0.086 and 1.55 deg
