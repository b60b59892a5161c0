"""Seed 004 EKF (ekf_wss_sas, ekf_wss_sas_imu): calibration, outage consistency, robustness.

Graded against the simulator's truth (suburban_outages: GNSS 1 Hz with three 30 s outages,
u-blox-class GNSS with a 1 m / 60 s Gauss-Markov error, 0.5 % per-wheel tyre-radius errors,
2 % steering scale factor, 0.1 deg steering offset) and against kinematic truths built here
(standstill, reversing, sensor gaps, multipath).  Tolerances are explained where they are set.
"""

from __future__ import annotations

import functools
import itertools
import math
from typing import Any

import numpy as np
import pytest
from scipy.stats import spearmanr

from sideslip.drive import Drive, drive_from_columns
from sideslip.errors import InputError
from sideslip.evaluate import Window, window_errors
from sideslip.methods.ekf_filter import GNSS_REJECTED
from sideslip.methods.ekf_positioning import EkfResult, EkfTuning, run_ekf
from sideslip.methods.registry import all_methods, run_method
from sideslip.models.kinematic import steer_yaw_rate
from sideslip.models.kinematic_ekf import BD, BG, DW, KD, KU, SW, E, N
from sideslip.simulate.sensors import SensorConfig, sensor_columns
from sideslip.simulate.truth import Truth
from sideslip.vehicle import Vehicle, load_vehicle
from tests.conftest import sim_drive

SEDAN = load_vehicle("midsize_sedan")
CHI2_3SIGMA_2D = 9.0  # Mahalanobis distance 3 in 2-D: the 3-sigma error ellipse


@functools.lru_cache(maxsize=8)
def _suburban(use_gyro: bool) -> tuple[Drive, EkfResult]:
    drive = sim_drive("suburban_outages", 0)
    return drive, run_ekf(drive, load_vehicle(drive.meta["vehicle"]), use_gyro)


def _outages(drive: Drive) -> list[tuple[float, float]]:
    return [(float(a), float(b)) for a, b in drive.meta["sensor_config"]["gnss_outages"]]


def _nees(drive: Drive, res: EkfResult) -> np.ndarray:
    """Squared Mahalanobis distance of the horizontal position error (2 dof)."""
    de = res.x[:, E] - drive["ref_e"]
    dn = res.x[:, N] - drive["ref_n"]
    pe, pn, pc = res.var[:, E], res.var[:, N], res.cov_en
    return (pn * de**2 - 2.0 * pc * de * dn + pe * dn**2) / (pe * pn - pc**2)


def _with_columns(drive: Drive, **cols: np.ndarray) -> Drive:
    data = dict(drive.data)
    data.update(cols)
    return Drive(drive.t, data, drive.meta, drive.path)


# ------------------------------------------------------------------------------------------
# kinematic truth for the robustness cases (no tyre slip: the filter's model is exact)
# ------------------------------------------------------------------------------------------
def _kinematic_drive(
    t: np.ndarray, v: np.ndarray, delta: np.ndarray, seed: int = 0, **config: Any
) -> Drive:
    veh = SEDAN
    dt = np.diff(t, prepend=t[0])
    r = steer_yaw_rate(v, delta, veh.wheelbase)
    yaw = 0.4 + np.cumsum(r * dt)
    vy = veh.lr * r
    c, s = np.cos(yaw), np.sin(yaw)
    ve, vn = c * v - s * vy, s * v + c * vy
    z = np.zeros_like(t)
    tr, tf = veh.track_rear, veh.track_front
    wheels = np.column_stack(
        [(v - r * tf / 2) / np.cos(delta), (v + r * tf / 2) / np.cos(delta),
         v - r * tr / 2, v + r * tr / 2]
    )
    acc = np.column_stack([np.gradient(ve, t), np.gradient(vn, t), z])
    truth = Truth(
        t=t, e=np.cumsum(ve * dt), n=np.cumsum(vn * dt), u=z, yaw=yaw, pitch=z, roll=z,
        roll_sus=z, bank=z, grade=z, vx=v, vy=vy, r=r, ax=c * acc[:, 0] + s * acc[:, 1],
        ay=-s * acc[:, 0] + c * acc[:, 1], acc_enu=acc, omega_body=np.column_stack([z, z, r]),
        wheel_speed=wheels, steer=delta, mu=z + 1.0,
    )  # fmt: skip
    cfg = SensorConfig(gnss_rate_hz=1.0, **config)
    cols, drawn = sensor_columns(truth, veh, cfg, np.random.default_rng(seed))
    return drive_from_columns(cols, {"truth_sensor": drawn, "vehicle": "midsize_sedan"})


def _smooth_steps(t: np.ndarray, knots: list[tuple[float, float]], rise: float = 3.0) -> np.ndarray:
    """Piecewise-constant profile (time, value) with smooth (cosine) transitions of ``rise`` s."""
    out = np.full_like(t, knots[0][1])
    for (_, v0), (t1, v1) in itertools.pairwise(knots):
        w = np.clip((t - t1) / rise, 0.0, 1.0)
        out += (v1 - v0) * 0.5 * (1.0 - np.cos(np.pi * w))
    return out


# ------------------------------------------------------------------------------------------
# Jacobians against finite differences
# ------------------------------------------------------------------------------------------
# ------------------------------------------------------------------------------------------
# calibration on the seed-004 drive
# ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("use_gyro", [False, True])
def test_wheel_scale_factors_converge_to_the_drives_effective_values(use_gyro):
    drive, res = _suburban(use_gyro)
    true = drive.meta["truth_sensor"]["wheel_scale_factor"]  # [FL, FR, RL, RR]
    sd = np.sqrt(res.var_final)
    x = res.x_final
    ok = np.isfinite(drive["v_rl"]) & (drive["ref_vx"] > 0.5)
    vx, r = drive["ref_vx"][ok], drive["ref_r"][ok]
    u_rl = vx - r * SEDAN.track_rear / 2
    u_rr = vx + r * SEDAN.track_rear / 2
    # Wheel speeds carry longitudinal tyre slip (braking on the undriven rear axle) and read
    # along the road's slope, so the "scale factor" a horizontal-position filter can see
    # differs from the tyre-radius error by speed: take the range of the effective mean
    # factor over speed bands (0.5-3, 3-8, 8-13, >13 m/s) and allow 3 sigma of the filter.
    mean_meas = 0.5 * (drive["v_rl"][ok] + drive["v_rr"][ok])
    bands = [(0.5, 3.0), (3.0, 8.0), (8.0, 13.0), (13.0, 99.0)]
    eff = [np.sum(mean_meas[b]) / np.sum(vx[b]) - 1.0
           for lo, hi in bands if (b := (vx >= lo) & (vx < hi)).sum() > 500]
    assert min(eff) - 3 * sd[SW] <= x[SW] <= max(eff) + 3 * sd[SW]
    assert abs(x[SW] - 0.5 * (true[2] + true[3])) < 0.004  # the 0.5 % tyre errors: within 0.4 %
    # The left/right difference is not affected by slip (both wheels slip alike): it must
    # match the drive's effective difference within 3 sigma + 1e-4 (quantisation of the fit).
    d_eff = 0.5 * ((np.sum(drive["v_rr"][ok] * u_rr) / np.sum(u_rr**2))
                   - (np.sum(drive["v_rl"][ok] * u_rl) / np.sum(u_rl**2)))
    assert abs(x[DW] - d_eff) < 3 * sd[DW] + 1e-4
    assert abs(x[DW] - 0.5 * (true[3] - true[2])) < 3 * sd[DW] + 2e-4


@pytest.mark.parametrize("use_gyro", [False, True])
def test_steering_calibration_recovers_the_true_yaw_gain_and_offset(use_gyro):
    # On this drive nearly every turn is taken at about the same speed, so only the product
    # (1 + k_d)(L + K_us v^2) is observable, not k_d and K_us apart: test the identified
    # steering -> yaw-rate gain against the truth yaw rate in turns, where yaw lag and road
    # bank limit it to about 1 % (the uncalibrated model is 2-4 % off on seeds 0-2).
    drive, res = _suburban(use_gyro)
    x, sd = res.x_final, np.sqrt(res.var_final)
    ts = drive.meta["truth_sensor"]
    st = drive["steer"]
    ok = np.isfinite(st) & (np.abs(drive["ref_r"]) > 0.05) & (drive["ref_vx"] > 3.0)
    v = drive["ref_vx"][ok]
    delta = (st[ok] - x[BD]) / (1.0 + x[KD])
    r_model = v * np.tan(delta) / (SEDAN.wheelbase + x[KU] * v * v)
    r_true = drive["ref_r"][ok]
    gain = np.sum(r_true * r_model) / np.sum(r_model**2)
    assert gain == pytest.approx(1.0, abs=0.01)
    # The offset: 3 sigma plus 0.3 mrad for the road crown the driver steers against on
    # average (K_us g sin(crown) = 0.45 mrad at 2 % crown; b_r takes most of it).
    assert abs(x[BD] - ts["steer_offset"]) < 3 * sd[BD] + 3e-4
    # k_d itself: within its prior's 2-sigma band (the 2 % steering-ratio spread) plus the
    # understeer confound, +-(0.3 K_us v^2 / L) at the median cornering speed.
    v_c = float(np.median(v))
    confound = 0.3 * SEDAN.understeer_gradient * v_c**2 / SEDAN.wheelbase
    assert abs(x[KD] - ts["steer_scale_factor"]) < 3 * sd[KD] + confound + 0.02


def test_gyro_bias_converges_to_the_drives_mean_bias():
    drive, res = _suburban(True)
    bias = drive.meta["truth_sensor"]["gyro_bias_mean"][2]
    # the gyro also has a 0.2 % scale factor and 0.1 deg misalignment: in turns of 0.3 rad/s
    # that is 6e-4 rad/s, seen only briefly, so 3 sigma + 2e-4 rad/s.
    sd = math.sqrt(res.var_final[BG])
    assert abs(res.x_final[BG] - bias) < 3 * sd + 2e-4


# ------------------------------------------------------------------------------------------
# outages
# ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("use_gyro", [False, True])
def test_outage_error_stays_inside_the_filters_3sigma_ellipse(use_gyro):
    drive, res = _suburban(use_gyro)
    nees = _nees(drive, res)
    rows = np.zeros(len(drive), dtype=bool)
    for t0, t1 in _outages(drive):
        rows |= (drive.t >= t0) & (drive.t <= t1)
    assert rows.sum() > 8000  # three 30 s outages at 100 Hz
    assert np.mean(nees[rows] <= CHI2_3SIGMA_2D) >= 0.95
    # and not absurdly pessimistic: the mean NEES (2 for a consistent 2-D filter) above 0.1
    assert np.mean(nees[rows]) > 0.1


@pytest.mark.parametrize("use_gyro", [False, True])
def test_outage_errors_are_metres_not_tens_of_metres(use_gyro):
    # Table 3.1 of the paper reports 5.6-19.6 m mean / 13.6-49.7 m max on real CAN data; the
    # simulated sensors are cleaner.  Dead reckoning drift over 30 s: a 0.05 % residual scale
    # factor and a 0.5 deg heading error at 17 m/s give ~5 m, so each outage stays below 10 m.
    drive, res = _suburban(use_gyro)
    wins = [Window(a, b) for a, b in _outages(drive)]
    errs = window_errors(drive, res.x[:, E], res.x[:, N], wins)
    assert len(errs) == 3
    for w in errs:
        assert w["max_m"] < 10.0
        assert w["mean_m"] < 6.0


def test_outage_error_grows_with_speed():
    # The paper's finding (Table 3.1, Fig. 3.4): dead-reckoning error grows with speed.  Blank
    # GNSS in 30 s windows every 75 s of the drive and rank the outage errors by the mean speed:
    # Spearman rho > 0.3 with p < 0.05 (seeds 0-2 give 0.49-0.61), and the faster half of the
    # outages has the larger mean error.
    drive = sim_drive("suburban_outages", 0)
    starts = np.arange(60.0, drive.t[-1] - 60.0, 75.0)
    ge, gn = drive["gnss_e"].copy(), drive["gnss_n"].copy()
    for a in starts:
        blank = (drive.t >= a) & (drive.t < a + 30.0)
        ge[blank] = np.nan
        gn[blank] = np.nan
    res = run_ekf(_with_columns(drive, gnss_e=ge, gnss_n=gn), SEDAN, False)
    errs = window_errors(drive, res.x[:, E], res.x[:, N], [Window(a, a + 30.0) for a in starts])
    mean_err = np.array([w["mean_m"] for w in errs])
    speed = np.array([drive["ref_vx"][(drive.t >= a) & (drive.t <= a + 30.0)].mean()
                      for a in starts])
    rho = spearmanr(speed, mean_err)
    assert rho.statistic > 0.3 and rho.pvalue < 0.05
    fast = speed >= np.median(speed)
    assert mean_err[fast].mean() > mean_err[~fast].mean()


# ------------------------------------------------------------------------------------------
# robustness
# ------------------------------------------------------------------------------------------
def test_standstill_drive_gives_finite_output_at_the_gnss_position():
    t = np.arange(0.0, 60.0, 0.01)
    drive = _kinematic_drive(t, np.zeros_like(t), np.full_like(t, 0.1))
    est = run_method(all_methods()["ekf_wss_sas"], drive, SEDAN)
    assert all(np.isfinite(v).all() for v in est.series.values())
    # never moved: no heading information, the yaw sigma stays at its prior of pi
    assert est["yaw_std"][-1] == pytest.approx(math.pi, rel=0.05)
    # position: mean of 60 fixes with a 1 m drifting error (GM, tau 60 s) -> within 3 m
    err = np.hypot(est["e"] - drive["ref_e"], est["n"] - drive["ref_n"])
    assert err[-1] < 3.0
    assert np.all(est["vx"] == pytest.approx(0.0, abs=0.05))


@pytest.mark.parametrize("signed", [True, False])
def test_reversing_tracks_the_path_with_signed_or_unsigned_wheel_speeds(signed):
    # forward at 8 m/s, stop, back up at 2 m/s with steering, stop, drive off again
    t = np.arange(0.0, 120.0, 0.01)
    v = _smooth_steps(t, [(0, 0.0), (2, 8.0), (40, 0.0), (48, -2.0), (70, 0.0), (78, 8.0)])
    delta = _smooth_steps(
        t, [(0, 0.0), (20, 0.05), (30, 0.0), (50, 0.25), (62, 0.0), (90, -0.06), (100, 0.0)]
    )
    drive = _kinematic_drive(t, v, delta, seed=3, wheel_speed_signed=signed)
    est = run_method(all_methods()["ekf_wss_sas"], drive, SEDAN)
    assert all(np.isfinite(s).all() for s in est.series.values())
    assert (est["vx"][(t > 54) & (t < 66)] < -1.5).all()
    err = np.hypot(est["e"] - drive["ref_e"], est["n"] - drive["ref_n"])
    # GNSS at 1 Hz with a 1 m drifting error: the track stays within 3 m everywhere, except
    # that magnitude-only wheel speeds need about 2.5 m of travel to tell reverse from forward
    reversing = (t > 48) & (t < 56)
    assert err[~reversing].max() < 3.0
    assert err[reversing].max() < (3.0 if signed else 8.0)
    yaw_err = np.degrees(np.abs(est["yaw"] - drive["ref_yaw"]))
    assert yaw_err[(t > 10) & ~reversing].max() < 3.0


def test_multipath_at_the_start_of_a_stretch_does_not_fake_reversing():
    t = np.arange(0.0, 40.0, 0.01)
    v = _smooth_steps(t, [(0, 0.0), (2, 8.0)])
    drive = _kinematic_drive(t, v, np.zeros_like(t), seed=6, gnss_multipath_prob=0.0)
    ge, gn = drive["gnss_e"].copy(), drive["gnss_n"].copy()
    fixes = np.flatnonzero(np.isfinite(ge))
    bad = fixes[np.searchsorted(t[fixes], 4.0)]  # ~3 m into the first stretch
    yaw = drive["ref_yaw"][bad]
    ge[bad] -= 15.0 * math.cos(yaw)  # 15 m behind the car: looks like backing up
    gn[bad] -= 15.0 * math.sin(yaw)
    res = run_ekf(_with_columns(drive, gnss_e=ge, gnss_n=gn), SEDAN, False)
    assert (res.x[t > 5.0, 3] > 0.0).all()  # v stays forward
    err = np.hypot(res.x[:, E] - drive["ref_e"], res.x[:, N] - drive["ref_n"])
    assert err.max() < 3.0


def test_gaps_in_wheel_and_steering_data_stay_finite_and_bounded():
    t = np.arange(0.0, 100.0, 0.01)
    v = _smooth_steps(t, [(0, 0.0), (2, 12.0)])
    delta = _smooth_steps(t, [(0, 0.0), (30, 0.04), (60, 0.0)])
    drive = _kinematic_drive(t, v, delta, seed=4, gnss_outages=((40.0, 70.0),))
    gap = (t > 45) & (t < 50)  # 5 s without wheels and steering, in a steady turn, no GNSS
    cols = {k: np.where(gap, np.nan, drive[k]) for k in ("v_rl", "v_rr", "steer")}
    res = run_ekf(_with_columns(drive, **cols), SEDAN, False)
    assert np.isfinite(res.x).all() and np.isfinite(res.var).all()
    err = np.hypot(res.x[:, E] - drive["ref_e"], res.x[:, N] - drive["ref_n"])
    # 5 s of constant speed and yaw rate prediction in a steady turn: metres, not tens
    out = (t > 40) & (t < 70)
    assert err[out].max() < 10.0
    assert np.mean(_nees(drive, res)[out] <= CHI2_3SIGMA_2D) >= 0.95
    # the missing data shows in the covariance
    assert res.var[gap, E].max() > res.var[t < 40, E].max()


def test_multipath_fix_is_rejected_and_a_persistent_jump_is_accepted():
    t = np.arange(0.0, 200.0, 0.01)
    v = _smooth_steps(t, [(0, 0.0), (2, 10.0)])
    drive = _kinematic_drive(t, v, np.zeros_like(t), seed=5, gnss_multipath_prob=0.0)
    ge = drive["gnss_e"].copy()
    fixes = np.flatnonzero(np.isfinite(ge))
    bad = fixes[np.searchsorted(t[fixes], 60.0)]
    ge[bad] += 30.0  # a 30 m multipath outlier at t = 60 s
    shifted = t[fixes] >= 120.0
    ge[fixes[shifted]] += 40.0  # from t = 120 s on the receiver's datum moves 40 m east
    res = run_ekf(_with_columns(drive, gnss_e=ge), SEDAN, False)
    assert res.gnss_flag[bad] == GNSS_REJECTED
    assert abs(res.x[bad, E] - drive["ref_e"][bad]) < 3.0
    # the jump is refused for max_rejects = 5 fixes, then believed: by t = 150 s the filter
    # follows the new datum within 3 m
    late = t >= 150.0
    assert np.abs(res.x[late, E] - (drive["ref_e"][late] + 40.0)).max() < 3.0


@pytest.mark.parametrize("name", ["ekf_wss_sas", "ekf_wss_sas_imu"])
def test_other_scenario_and_30pct_wrong_cornering_stiffness_give_sane_output(name):
    drive = sim_drive("urban_course", 0)  # another car (alphard_minivan), 10 Hz GNSS
    veh = load_vehicle(drive.meta["vehicle"])
    for car in (veh, veh.with_changes(cf=0.7 * veh.cf, cr=0.7 * veh.cr)):
        est = run_method(all_methods()[name], drive, car)
        err = np.hypot(est["e"] - drive["ref_e"], est["n"] - drive["ref_n"])
        # 10 Hz GNSS with a 1 m drifting error: the fused track stays near 1-2 m RMS
        assert math.sqrt(np.mean(err**2)) < 2.5
        moving = drive["ref_vx"] > 5.0
        beta_err = np.degrees(est["beta"] - drive["ref_beta"])[moving]
        # kinematic beta at urban lateral accelerations (< 4 m/s^2): within about a degree
        assert math.sqrt(np.mean(beta_err**2)) < 1.0


def test_missing_steering_column_names_it():
    t = np.arange(0.0, 5.0, 0.01)
    drive = drive_from_columns(
        {"t": t, "v_rl": np.full_like(t, 5.0), "v_rr": np.full_like(t, 5.0),
         "gnss_e": np.where(np.arange(t.size) % 100 == 0, 1.0, np.nan),
         "gnss_n": np.where(np.arange(t.size) % 100 == 0, 2.0, np.nan)}
    )  # fmt: skip
    with pytest.raises(InputError, match="steer"):
        run_method(all_methods()["ekf_wss_sas"], drive, SEDAN)


def test_vehicle_without_lr_is_refused_by_name():
    veh = Vehicle(name="x", source="x.toml", lf=1.2)
    drive = sim_drive("suburban_outages", 0)
    with pytest.raises(InputError, match="'lr'"):
        run_method(all_methods()["ekf_wss_sas"], drive, veh)


def test_vehicle_file_with_only_geometry_runs_on_typical_defaults():
    # lf, lr and track_rear are all the method needs; K_us and the slip gain fall back to a
    # typical car's (0.0025 rad/(m/s^2), 0.005 s^2/m), so the drive still calibrates.
    drive = sim_drive("suburban_outages", 0)
    bare = Vehicle(name="bare", source="bare.toml", lf=SEDAN.lf, lr=SEDAN.lr,
                   track_rear=SEDAN.track_rear, gnss_xyz=SEDAN.gnss_xyz)  # fmt: skip
    est = run_method(all_methods()["ekf_wss_sas"], drive, bare)
    assert est.params["understeer_gradient_rad_m_s2_sigma"] < 0.0015  # the drive taught it something
    err = np.hypot(est["e"] - drive["ref_e"], est["n"] - drive["ref_n"])
    assert math.sqrt(np.mean(err**2)) < 2.5  # GNSS 1 Hz with a 1 m drifting error


def test_a_vehicle_file_without_track_runs_and_says_what_it_assumed() -> None:
    """Rough vehicle files often lack the track: the EKF takes the front track, else a typical
    1.55 m, says so in the params, and still tracks the position (a 2 % track error scales
    the wheel-difference yaw rate by 2 %, which the GNSS updates correct)."""
    import math

    from sideslip.evaluate import metrics
    from sideslip.methods.registry import all_methods, run_method, why_not

    drive = sim_drive("demo")
    v = load_vehicle(drive.meta["vehicle"])
    rough = v.with_changes(track_rear=math.nan, track_front=math.nan)
    method = all_methods()["ekf_wss_sas"]
    assert why_not(method, drive, rough) is None
    est = run_method(method, drive, rough)
    assert est.params["track_rear_source"].startswith("assumed 1.55 m")
    assert metrics(drive, est.series)["pos_rmse_m"] < 3.0
    front_only = v.with_changes(track_rear=math.nan)
    assert run_method(method, drive, front_only).params["track_rear_m"] == v.track_front


def test_ekf_tuning_is_a_validated_frozen_dataclass_reached_by_name() -> None:
    import dataclasses

    with pytest.raises(ValueError, match=r"EkfTuning.gnss_tau_s = 0.0: expected > 0 s"):
        EkfTuning(gnss_tau_s=0.0)
    with pytest.raises(dataclasses.FrozenInstanceError):
        EkfTuning().wheel_sigma_m_s = 1.0  # type: ignore[misc]
    drive = sim_drive("suburban_outages", 0)
    est = run_method(all_methods()["ekf_wss_sas"], drive, SEDAN, {"gnss_tau_s": 30.0})
    assert est.params["settings"]["gnss_tau_s"] == 30.0
    # identified parameters: measured / true scales with their 1-sigma, units in the names;
    # the rear tyres' 0.5 % radius errors within 0.4 % (as the state test above)
    true = drive.meta["truth_sensor"]["wheel_scale_factor"]  # [FL, FR, RL, RR]
    assert est.params["wheel_speed_scale"] == pytest.approx(1.0 + 0.5 * (true[2] + true[3]),
                                                            abs=0.004)  # fmt: skip
    assert est.params["wheel_speed_scale_sigma"] > 0.0
    assert {"steer_scale", "steer_offset_rad", "understeer_gradient_rad_m_s2_sigma"} <= set(
        est.params)
    assert est.series["health"].shape == drive.t.shape
    assert np.isfinite(est.innovations["gnss_nis"]).sum() > 100


def test_the_filter_kernel_is_compiled_once_for_drives_from_a_file_and_from_memory(tmp_path):
    """A parquet file's columns arrive read-only, a drive built in memory is writable: the
    kernel gets read-only views of both (signals.kernel_input), so numba compiles one
    specialisation, not one per mix (nine 4 s compiles in one test run before), and the
    results are the same bit for bit."""
    from sideslip.drive import load_drive, save_drive
    from sideslip.methods.ekf_filter import ekf_loop

    drive = sim_drive("demo")
    vehicle = load_vehicle(drive.meta["vehicle"])
    in_memory = drive_from_columns({k: np.array(drive[k]) for k in drive.columns()} | {"t": drive.t},
                                   drive.meta)  # fmt: skip
    path = tmp_path / "demo.parquet"
    save_drive(drive, path)
    from_file = load_drive(path)
    before = set(ekf_loop.signatures) if ekf_loop.signatures else set()
    results = [run_method(name, d, vehicle).series["beta"]
               for d in (in_memory, from_file) for name in ("ekf_wss_sas", "ekf_wss_sas_imu")]  # fmt: skip
    assert len(set(ekf_loop.signatures) - before) <= 1 and len(ekf_loop.signatures) >= 1
    np.testing.assert_array_equal(results[0], results[2])
    np.testing.assert_array_equal(results[1], results[3])


@pytest.mark.commonroad
@pytest.mark.parametrize("name", ["ekf_wss_sas", "ekf_wss_sas_imu"])
def test_at_the_grip_limit_beta_std_covers_the_sliding_tyres(name: str) -> None:
    """cr_limit_ramp (CommonRoad's multi-body BMW ramping up to mu 0.6): the kinematic model
    misses a slip of up to 4 deg; its linear slip term put 75 / 70 % of the beta errors inside
    2 sigma.  Where the NIS test calls the model unusable the slip term grows up to three
    times (the brush model's sliding limit): 100 / 96 % (seeds 0 and 1).  Bound: issue 15's
    0.90; the model does fail here (beta RMSE above 1.5 deg)."""
    pytest.importorskip("vehiclemodels", reason="needs the optional commonroad extra")
    d = sim_drive("cr_limit_ramp", 0)
    est = run_method(name, d, load_vehicle(d.meta["vehicle"]))
    fast = d["ref_vx"] > 5.0
    err = np.abs(est["beta"] - d["ref_beta"])[fast]
    assert math.degrees(np.sqrt(np.mean(err**2))) > 1.5
    assert np.mean(err < 2 * est["beta_std"][fast]) >= 0.90
