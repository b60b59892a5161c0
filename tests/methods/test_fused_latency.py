"""The tyres' profile of a Doppler latency the tyre-free fits leave open
(sideslip.methods.fused_latency): the search on analytic profiles, and fused on simulated
drives whose receiver stamps its epochs late, against the simulator's truth."""

from __future__ import annotations

import dataclasses
import math

import pytest

from sideslip.evaluate import metrics
from sideslip.gnss_latency import LatencyEstimate
from sideslip.methods.fused import fuse
from sideslip.methods.fused_latency import MAX_EXTENSIONS, latency_grid, profile_latency
from sideslip.methods.fused_settings import FusedSettings
from sideslip.simulate import SensorConfig, simulate
from sideslip.simulate.run import _lookup  # the scenario's own sensor overrides
from sideslip.vehicle import load_vehicle
from tests.methods.test_fused import two_sigma_share

OFF = FusedSettings(profile_doppler_latency=False)


def _fit(latency_s: float, sigma_s: float) -> LatencyEstimate:
    return LatencyEstimate(latency_s, sigma_s, 1.0, 100)


def _quadratic(tau0: float, sigma0: float, calls: list[float]):
    """-2 log L of a latency known to sigma0 around tau0 (the exact Gaussian case)."""

    def score(tau: float) -> float:
        calls.append(tau)
        return -1000.0 + ((tau - tau0) / sigma0) ** 2

    return score


def test_a_gaussian_profile_is_found_at_its_minimum_with_its_sigma():
    """On an exactly quadratic -2 log L the parabola through the grid's best point and its
    neighbours is the profile itself: the minimum and its sigma come out to rounding, after
    the grid (0.05 s steps up to the fits' 0.08 + 2.5 x 0.051 s) and one refining run."""
    calls: list[float] = []
    score = _quadratic(0.112, 0.01, calls)
    profile = profile_latency(score, score(0.0), _fit(0.08, 0.05), 2.5, 0.05, 5, 3.0)
    assert profile is not None
    assert profile.latency_s == pytest.approx(0.112, abs=1e-9)
    assert profile.sigma_s == pytest.approx(0.01, rel=1e-6)
    assert profile.found
    assert profile.gain == pytest.approx((0.112 / 0.01) ** 2, rel=1e-9)
    assert len(calls) == 1 + 5 + 1  # the stamps, the grid 0.05 ... 0.25, the refinement
    timing = profile.timing()
    assert timing.latency_s == profile.latency_s
    assert timing.sigma_s == pytest.approx(math.hypot(0.01, 0.01))  # with the fits' floor
    scan = profile.params()["gnss_doppler_latency_tyres_scan"]
    assert scan[0] == [0.0, 0.0] and len(scan) == 7


def test_a_profile_rising_from_the_stamps_takes_nothing():
    """On time: the stamps score best, no latency is taken and the sigma stays unknown."""
    calls: list[float] = []
    score = _quadratic(-0.02, 0.01, calls)
    profile = profile_latency(score, score(0.0), _fit(0.01, 0.05), 2.5, 0.05, 5, 3.0)
    assert profile is not None
    assert profile.latency_s == 0.0 and not profile.found
    assert profile.gain == 0.0


def test_a_minimum_beyond_the_range_is_followed_by_the_extension():
    """The fits put the latency at 0.02 +- 0.02 s (range up to 0.076 s: the grid 0.05, 0.1);
    the profile's minimum is at 0.17 s: the grid is extended while its last point is best,
    up to MAX_EXTENSIONS steps, and the parabola there finds it."""
    calls: list[float] = []
    score = _quadratic(0.17, 0.02, calls)
    profile = profile_latency(score, score(0.0), _fit(0.02, 0.02), 2.5, 0.05, 5, 3.0)
    assert profile is not None
    assert MAX_EXTENSIONS == 2
    assert max(calls) >= 0.2  # 0.15 and 0.2 added
    assert profile.latency_s == pytest.approx(0.17, abs=1e-9)
    assert profile.found


def test_a_shallow_minimum_inside_the_gate_is_not_taken():
    """A latency that lowers -2 log L by less than z_gate^2 (here 4 < 9) is not taken."""
    calls: list[float] = []
    score = _quadratic(0.1, 0.05, calls)
    profile = profile_latency(score, score(0.0), _fit(0.1, 0.05), 2.5, 0.05, 5, 3.0)
    assert profile is not None
    assert profile.latency_s == pytest.approx(0.1, abs=1e-9)
    assert profile.gain == pytest.approx(4.0)
    assert not profile.found


def test_the_grid_is_capped_and_empty_where_the_fits_say_early():
    """A fit that says nothing (sigma of hours) spans 0 to the longest latency taken in at
    most max_points wider steps; a fit well below 0 leaves nothing to score."""
    grid, step = latency_grid(_fit(-365.0, 466.0), 2.5, 0.05, 5)
    assert grid == pytest.approx([0.1, 0.2, 0.3, 0.4, 0.5]) and step == pytest.approx(0.1)
    assert latency_grid(_fit(-0.2, 0.02), 2.5, 0.05, 5)[0] == []


def _late(name: str, latency_s: float):
    cfg = SensorConfig().with_overrides(_lookup(name).sensor_overrides)
    drive = simulate(name, seed=0, config=cfg.with_overrides({"gnss_latency_s": latency_s}))
    return drive, load_vehicle(drive.meta["vehicle"])


def test_a_late_doppler_the_fits_leave_open_is_found_by_the_tyres():
    """step_steer (one steer step at constant speed) with every GNSS epoch 100 ms late.  No
    speed changes, one turn at one speed: the tyre-free fits read +0.10 +- 0.06 s, which they
    do not apply, and the antenna check read the lag as an antenna 1.08 m behind (the IMU
    alternative then moved the IMU: beta 0.549 deg, measured).  The tyres' profile puts the
    latency at the truth (measured 0.100 s; bound 0.02 s, two rows of the drive and twice
    the profile's sigma of 0.013 s), beating the installation alternatives, and beta falls
    to 0.028 deg (measured; bound 0.1: three times the on-time drive's 0.032) with the
    errors inside 2 sigma.  The causal filter takes the same latency (measured 0.448 ->
    0.058 deg)."""
    drive, vehicle = _late("step_steer", 0.1)
    before = fuse(drive, vehicle, smooth=True, settings=OFF)
    est = fuse(drive, vehicle, smooth=True)
    p = est.params
    assert abs(p["gnss_doppler_latency_s"] - 0.1) < 0.02, p["gnss_doppler_latency_s"]
    assert "the tyre-free fits left it open" in p["gnss_doppler_latency_note"]
    assert "the Doppler late explains the offset better" in p["assumed"]["imu_lever_x"]
    rmse = [metrics(drive, e.series)["beta_rmse_deg"] for e in (before, est)]
    assert rmse[1] < 0.1 < 0.4 < rmse[0], rmse
    assert two_sigma_share(drive, est) >= 0.95
    causal = fuse(drive, vehicle, smooth=False)
    assert causal.params["gnss_doppler_latency_s"] == p["gnss_doppler_latency_s"]
    assert metrics(drive, causal.series)["beta_rmse_deg"] < 0.15


def test_an_on_time_doppler_takes_no_latency_from_the_tyres():
    """The same drive on time: the fits leave it open as well (-0.006 +- 0.059 s), the
    profile rises from the stamps (+25 at 50 ms, measured), nothing is taken and the
    estimate is the one without the profile, to the bit."""
    drive, vehicle = _late("step_steer", 0.0)
    est = fuse(drive, vehicle, smooth=True)
    p = est.params
    assert p["gnss_doppler_latency_tyres_s"] == 0.0
    assert p["gnss_doppler_latency_s"] == 0.0
    scan = p["gnss_doppler_latency_tyres_scan"]
    assert all(n > 9.0 for tau, n in scan if tau > 0.0), scan
    before = fuse(drive, vehicle, smooth=True, settings=OFF)
    assert (est.series["beta"] == before.series["beta"]).all()


def test_an_imu_ahead_read_as_a_late_doppler_keeps_its_errors_inside_two_sigma():
    """two_turns_gyro_sf with the IMU 1 m ahead of the file's place: tyre-free the offset is
    one of an IMU 1 m ahead, an antenna 1 m behind, or a Doppler about 40 ms late, and the
    tyres score the Doppler 36 ms late 5.5 below the IMU moved: within the gate, so they do
    not tell the two apart.  The late Doppler is taken (beta 0.277 deg against 0.038 with
    the IMU moved, measured) and the IMU's beta counts in full in beta_std: the errors stay
    inside 2 sigma (measured 100 %; 62 % with likelihood weights)."""
    drive_right = simulate("two_turns_gyro_sf", seed=0)
    vehicle = load_vehicle(drive_right.meta["vehicle"])
    x, y, z = vehicle.imu_xyz
    drive = simulate("two_turns_gyro_sf", seed=0, vehicle=dataclasses.replace(vehicle, imu_xyz=(x + 1.0, y, z)))
    est = fuse(drive, vehicle, smooth=True)
    assert two_sigma_share(drive, est) >= 0.95
    assert metrics(drive, est.series)["beta_rmse_deg"] < 0.4


def test_multipath_the_doppler_check_lets_in_differently_does_not_pass_for_latency():
    """urban_highway seed 2, on time, 108 multipath epochs; the fits leave the latency open
    (+0.017 +- 0.056 s).  Scored with the Doppler's check against the inertial propagation,
    which lets different epochs in at different latencies, the profile fell by 141 at 31 ms
    and fused took it (beta 0.015 -> 0.036 deg, measured).  Scored without it the profile
    rises from the stamps (+66 at 50 ms, measured): nothing is taken and the estimate is the
    one without the profile."""
    drive = simulate("urban_highway", seed=2)
    vehicle = load_vehicle(drive.meta["vehicle"])
    est = fuse(drive, vehicle, smooth=True)
    p = est.params
    assert p["gnss_doppler_latency_s"] == 0.0
    assert all(n > 9.0 for tau, n in p["gnss_doppler_latency_tyres_scan"] if tau > 0.0)
    assert metrics(drive, est.series)["beta_rmse_deg"] < 0.025
