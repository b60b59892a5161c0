"""The tyre-free check of the GNSS antenna's longitudinal lever arm against the Doppler
(sideslip.methods.fused_lever), on simulated drives whose antenna is not where the vehicle
file says, against the simulator's truth."""

from __future__ import annotations

import dataclasses
import math

import pytest

from sideslip.evaluate import metrics
from sideslip.methods.fused import fuse
from sideslip.methods.fused_lever import ImuAlternative, LeverCheck
from sideslip.methods.fused_settings import FusedSettings
from sideslip.simulate import SensorConfig, simulate
from sideslip.simulate.run import _lookup  # the scenario's own sensor overrides
from sideslip.vehicle import load_vehicle
from tests.conftest import sim_drive
from tests.methods.test_fused import two_sigma_share

OFF = FusedSettings(check_doppler_lever=False)


def _misplaced(name: str, offset_m: float):
    """Scenario ``name`` (seed 0, its own receiver) with the antenna ``offset_m`` ahead of the
    vehicle file's gnss_xyz (negative: behind)."""
    cfg = SensorConfig().with_overrides(_lookup(name).sensor_overrides)
    return simulate(name, seed=0, config=cfg.with_overrides({"gnss_lever_offset_x": offset_m}))


@pytest.mark.parametrize("offset_m", [0.5, -0.5])
def test_a_misplaced_antenna_is_found_and_moved_and_beta_follows_the_truth(offset_m):
    """race_lap (nonlinear tyres at up to ~1 g, body roll, 10 Hz Doppler) with the antenna
    0.5 m ahead of / behind the file's: r dl_x reads as slip (measured, seed 0: beta RMSE
    0.357 / 0.229 deg with the file's antenna).  The tyre-free pass puts the antenna within
    0.2 m of the truth (measured +0.605 +- 0.061 and -0.348 +- 0.029 m: the tyre-free
    kinematics' own model error, +0.06 to +0.21 m at a true 0 on our drives, is a bias the
    sigma does not carry, hence a fixed bound rather than k sigma), far beyond the gate, and
    with the tyres the moved antenna predicts the Doppler better (measured: -2 log L down by
    134 for +0.5 m, beyond the gate's 9), so it is moved, and beta's RMSE falls to under a
    third (measured 0.037 / 0.044 deg) with every error inside 2 sigma."""
    drive = _misplaced("race_lap", offset_m)
    v = load_vehicle(drive.meta["vehicle"])
    kept = fuse(drive, v, smooth=True, settings=OFF)
    moved = fuse(drive, v, smooth=True)
    p = moved.params
    assert abs(p["gnss_lever_x_tyre_free_m"] - offset_m) < 0.2, p["gnss_lever_x_tyre_free_m"]
    assert p["gnss_lever_x_applied_m"] == p["gnss_lever_x_tyre_free_m"]
    assert p["gnss_lever_x_neg2ll_gain"] > 9.0
    assert "moved by it" in p["assumed"]["gnss_lever_x"]
    assert "gnss_lever_x" not in kept.params["assumed"]
    # the IMU moved instead explains the Doppler worse than the antenna moved (measured
    # -2 log L +13 / +5): the IMU stays where the file says
    assert p["imu_lever_x_applied_m"] == 0.0
    rmse_kept = metrics(drive, kept.series)["beta_rmse_deg"]
    rmse_moved = metrics(drive, moved.series)["beta_rmse_deg"]
    assert rmse_moved < rmse_kept / 3.0, (rmse_moved, rmse_kept)
    assert two_sigma_share(drive, moved) >= 0.95


def test_a_right_antenna_is_kept_and_the_estimate_is_unchanged():
    """dlc_bank with the antenna where the file says: the pass finds no offset beyond its
    gate (measured +0.084 +- 0.081 m), so the file's antenna is kept and beta is the same as
    without the check, to the last bit."""
    drive = sim_drive("dlc_bank")
    v = load_vehicle(drive.meta["vehicle"])
    checked = fuse(drive, v, smooth=True)
    p = checked.params
    assert p["gnss_lever_x_applied_m"] == 0.0
    assert abs(p["gnss_lever_x_tyre_free_m"]) < 3.0 * p["gnss_lever_x_tyre_free_m_sigma"]
    assert "the file's kept" in p["assumed"]["gnss_lever_x"]
    plain = fuse(drive, v, smooth=True, settings=OFF)
    assert (checked["beta"] == plain["beta"]).all()


def test_a_steady_turn_does_not_decide_the_lever_arm_and_the_file_is_kept():
    """step_steer (one long steady turn) with the antenna 0.5 m behind the file's: where the
    yaw rate is constant r dl_x cannot be told from v_y without the tyres, so the pass's sigma
    is wide (measured 0.197 m) and the file's antenna is kept rather than moved on a guess."""
    drive = _misplaced("step_steer", -0.5)
    p = fuse(drive, load_vehicle(drive.meta["vehicle"]), smooth=True).params
    assert p["gnss_lever_x_tyre_free_m_sigma"] > 0.15
    assert p["gnss_lever_x_applied_m"] == 0.0


def test_the_filter_takes_the_smoothers_verdict_and_a_kept_antenna_changes_nothing():
    """The causal filter has no later samples to check against: it reports the smoother's
    check, and where that kept the file's antenna (dlc_bank, antenna where the file says)
    its estimate is the one without the check, to the last bit."""
    drive = sim_drive("dlc_bank")
    v = load_vehicle(drive.meta["vehicle"])
    est = fuse(drive, v, smooth=False)
    assert est.params["assumed"]["gnss_lever_x"].startswith("the smoother's check")
    assert est.params["gnss_lever_x_applied_m"] == 0.0
    plain = fuse(drive, v, smooth=False, settings=OFF)
    assert (est["beta"] == plain["beta"]).all()


def test_a_false_tyre_free_offset_is_not_confirmed_by_the_tyres_and_the_file_is_kept():
    """The 15-minute endurance drive (country roads and highway, antenna where the file
    says): the tyre-free kinematics' own model error reads as an antenna 0.21 +- 0.05 m ahead
    (measured), 0.05 m of it the inputs' timing: 2.4 sigma with the timing's uncertainty,
    inside the gate.  With the gate at 2 sigma it is found, and then the second test holds:
    with the tyres the moved antenna predicts the Doppler worse (measured: -2 log L up by
    209), so the file's is kept and beta is the one without the check (moving it took beta
    0.015 -> 0.040 deg)."""
    drive = simulate("endurance", seed=0, duration_s=900.0)
    v = load_vehicle(drive.meta["vehicle"])
    p = fuse(drive, v, smooth=True).params
    assert p["gnss_lever_x_tyre_free_m"] > 3.0 * p["gnss_lever_x_tyre_free_m_sigma"]
    assert p["gnss_lever_x_neg2ll_gain"] is None  # within the gate: no second test
    assert p["gnss_lever_x_applied_m"] == 0.0
    loose = fuse(drive, v, smooth=True, settings=FusedSettings(doppler_lever_z=2.0, check_imu_lever=False))
    q = loose.params
    assert q["gnss_lever_x_neg2ll_gain"] < 0.0
    assert q["gnss_lever_x_applied_m"] == 0.0
    assert "but with the tyres" in q["assumed"]["gnss_lever_x"]
    plain = fuse(drive, v, smooth=True, settings=OFF)
    assert (loose["beta"] == plain["beta"]).all()
    # read as the IMU's, the same offset passes the looser gate (measured: the IMU -0.176 m,
    # -2 log L 8.1 below the file's, 213 below the antenna moved), and moving the IMU that
    # little leaves beta where it was (measured 0.01440 against 0.01442 deg)
    imu = fuse(drive, v, smooth=True, settings=FusedSettings(doppler_lever_z=2.0))
    assert imu.params["imu_lever_x_applied_m"] == pytest.approx(-q["gnss_lever_x_tyre_free_m"])
    rmse = [metrics(drive, e.series)["beta_rmse_deg"] for e in (imu, plain)]
    assert abs(rmse[0] - rmse[1]) < 0.002, rmse


def test_the_gates_and_a_failed_pass():
    """The antenna moves only beyond z_gate sigmas and where the tyres' likelihood gains more
    than z_gate^2; a pass without a finite answer moves nothing; a non-positive gate is one
    clear error."""
    assert LeverCheck(0.31, 0.1, 3.0, gain=9.5).applied
    assert LeverCheck(0.31, 0.1, 3.0).found and not LeverCheck(0.31, 0.1, 3.0).applied
    assert not LeverCheck(0.31, 0.1, 3.0, gain=8.5).applied
    assert not LeverCheck(0.29, 0.1, 3.0, gain=100.0).applied
    assert not LeverCheck(-0.29, 0.1, 3.0, gain=100.0).found
    # the part the inputs' timing accounts for is taken out before the gate
    assert not LeverCheck(0.31, 0.1, 3.0, gain=100.0, timing_m=0.05).found
    assert LeverCheck(-0.31, 0.1, 3.0, gain=100.0, timing_m=0.05).applied
    failed = LeverCheck(math.nan, math.inf, 3.0)
    assert not failed.found and not failed.applied
    assert failed.params()["gnss_lever_x_tyre_free_m"] is None
    with pytest.raises(
        ValueError, match=r"FusedSettings.doppler_lever_z = 0.0: expected a finite number > 0"
    ):
        FusedSettings(doppler_lever_z=0.0)


def test_the_inputs_half_row_lag_is_taken_out_before_the_gate():
    """race_lap with the antenna where the file says.  With the rectangle rule the node
    inputs are the mean of their rows, half a row behind the interval they propagate over,
    so the tyre-free pass puts the antenna about v dt / 2 ahead (measured +0.163 +- 0.023 m,
    7 sigma from 0).  The part the timing accounts for is the speed, weighted by r^2 as the
    turns inform dl_x, times half the row interval (measured 0.108 m: 21.6 m/s x 5 ms):
    checked against the same sum over the reference speed and yaw rate (5 %: the nodes'
    block means against the rows), and with it taken out the file's antenna is kept (moving
    it took beta 0.037 -> 0.060 deg with 5 Hz Doppler, fused_accuracy.md).  With the
    trapezoidal rule (the default with Doppler) the pass reads +0.084 +- 0.019 m, the lag
    gone (0.079 m less); nothing is taken out, the timing's 0.108 m stays its uncertainty,
    and the file's antenna is kept."""
    import numpy as np

    drive = sim_drive("race_lap")
    vehicle = load_vehicle(drive.meta["vehicle"])
    r2 = np.square(drive["ref_r"])
    expected = float(np.sum(r2 * drive["ref_vx"]) / np.sum(r2)) * drive.dt_median / 2.0
    p = fuse(drive, vehicle, smooth=True, settings=FusedSettings(trapezoid_with_doppler=False)).params
    assert p["gnss_lever_x_timing_m"] == pytest.approx(expected, rel=0.05)
    assert abs(p["gnss_lever_x_tyre_free_m"]) > 3.0 * p["gnss_lever_x_tyre_free_m_sigma"]
    assert p["gnss_lever_x_applied_m"] == 0.0
    assert "of it the inputs' timing" in p["assumed"]["gnss_lever_x"]
    q = fuse(drive, vehicle, smooth=True).params
    assert q["gnss_lever_x_timing_m"] == 0.0
    assert q["gnss_lever_x_tyre_free_m"] < p["gnss_lever_x_tyre_free_m"] - 0.5 * expected
    assert q["gnss_lever_x_applied_m"] == 0.0


def test_the_causal_filter_takes_the_antenna_the_smoothers_check_finds():
    """fused_filter has no later samples to check the antenna against, so with its
    whole-drive calibrations it runs the smoother first and takes the antenna its check
    moved: race_lap with the antenna 0.5 m ahead of the file's, the smoother's check finds
    0.517 m (0.605 with the rectangle rule's half-row lag in it; bound: the truth within
    0.05 m, 2.5 of the pass's sigmas); beta measured 0.336 -> 0.138 deg (bound: under
    half), inside 2 sigma; strictly on-line it keeps the file's."""
    drive = _misplaced("race_lap", 0.5)
    v = load_vehicle(drive.meta["vehicle"])
    kept = fuse(drive, v, smooth=False, settings=OFF)
    moved = fuse(drive, v, smooth=False)
    assert moved.params["gnss_lever_x_applied_m"] == pytest.approx(0.5, abs=0.05)
    assert moved.params["assumed"]["gnss_lever_x"].startswith("the smoother's check")
    rmse_kept = metrics(drive, kept.series)["beta_rmse_deg"]
    rmse_moved = metrics(drive, moved.series)["beta_rmse_deg"]
    assert rmse_moved < 0.5 * rmse_kept, (rmse_moved, rmse_kept)
    assert two_sigma_share(drive, moved) >= 0.95
    online = fuse(drive, v, smooth=False, settings=FusedSettings(whole_drive_calibration=False))
    assert "gnss_lever_x" not in online.params["assumed"]


def _imu_misplaced(name: str, offset_m: float):
    """Scenario ``name`` (seed 0) with the IMU ``offset_m`` ahead of the vehicle file's
    imu_xyz (the file returned says where it is not)."""
    vehicle = load_vehicle(sim_drive(name).meta["vehicle"])
    x, y, z = vehicle.imu_xyz
    return simulate(name, seed=0, vehicle=dataclasses.replace(vehicle, imu_xyz=(x + offset_m, y, z))), vehicle


def test_a_misplaced_imu_is_moved_and_the_antenna_is_left_where_the_file_says():
    """race_lap with the IMU 1 m ahead of where the file says.  Tyre-free, the pass sees only
    the antenna's place relative to the IMU: an antenna -0.92 +- 0.06 m ahead of the file's
    (measured), and the antenna's own rule moved the antenna (beta 0.568 deg, measured).
    With the tyres the IMU moved by +0.92 m predicts the Doppler better than the file's
    installation and than the antenna moved, each with its own identified noise (measured
    -2 log L -401 and -47), so the IMU moves (bound: within 0.15 m of the truth, 2.5 of the
    pass's sigmas) and beta is as good as with the IMU where the file says (measured 0.027
    against 0.028; bound 0.06 deg, a tenth of the misplaced run's error)."""
    drive, vehicle = _imu_misplaced("race_lap", 1.0)
    est = fuse(drive, vehicle, smooth=True)
    p = est.params
    assert p["imu_lever_x_applied_m"] == pytest.approx(1.0, abs=0.15)
    assert p["gnss_lever_x_applied_m"] == 0.0
    assert p["assumed"]["imu_lever_x"].startswith("moved +0.9")
    assert metrics(drive, est.series)["beta_rmse_deg"] < 0.06
    assert two_sigma_share(drive, est) >= 0.95
    # the causal filter takes the smoother's verdict (measured 0.160 deg against 0.539)
    causal = fuse(drive, vehicle, smooth=False)
    assert causal.params["imu_lever_x_applied_m"] == p["imu_lever_x_applied_m"]
    assert causal.params["assumed"]["imu_lever_x"].startswith("the smoother's check, moved")
    assert metrics(drive, causal.series)["beta_rmse_deg"] < 0.25
    assert two_sigma_share(drive, causal) >= 0.95


def test_the_imu_against_the_antenna_and_the_likelihood_weights():
    """The IMU moves only where it beats the file's installation by more than z_gate^2 and
    the moved antenna too; each installation's weight is exp(-n / 2) normalised over the
    ones in play (the file's not where the antenna's check moved the antenna)."""

    def share(n, key):
        return math.exp(-n[key] / 2.0) / sum(math.exp(-v / 2.0) for v in n.values())

    # the antenna check kept the file's; the IMU 12 better than it: moved
    a = ImuAlternative(-0.9, 100.0, 120.0, 88.0, False, 3.0)
    assert a.applied and a.chosen == "imu" and a.params()["imu_lever_x_applied_m"] == 0.9
    n = {"file": 100.0, "antenna": 120.0, "imu": 88.0}
    assert a.weights() == pytest.approx({k: share(n, k) for k in n})
    assert a.note().startswith("moved +0.900 m")
    # 8 better than the file's: inside the gate, the file's kept, most weight on the IMU
    b = ImuAlternative(-0.9, 100.0, 120.0, 92.0, False, 3.0)
    assert not b.applied and b.chosen == "file" and b.params()["imu_lever_x_applied_m"] == 0.0
    assert b.weights()["imu"] > 0.9
    # beyond the gate against the file's but the moved antenna explains it better: kept
    c = ImuAlternative(-0.45, 100.0, 79.3, 84.1, False, 3.0)
    assert not c.applied and c.chosen == "file"
    assert "the file's kept (the IMU +0.450 m" in c.note()
    # the antenna moved, 5 better than the IMU: the antenna stays; the file's not in play
    d = ImuAlternative(0.5, 100.0, 60.0, 65.0, True, 3.0)
    assert not d.applied and d.chosen == "antenna"
    assert set(d.weights()) == {"antenna", "imu"}
    assert d.weights()["imu"] == pytest.approx(1.0 / (1.0 + math.exp(2.5)))
    # ... and 5 worse than the IMU: the IMU moves, the antenna's weight as large
    e = ImuAlternative(0.5, 100.0, 65.0, 60.0, True, 3.0)
    assert e.applied and e.chosen == "imu"
    assert e.weights()["antenna"] == pytest.approx(d.weights()["imu"])
