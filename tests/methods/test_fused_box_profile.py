"""The box's place profiled with the tyres where the drive has no slow turns
(sideslip.methods.fused_box_profile): the scan and its verdict on analytic profiles, and the
smoother on the simulated race lap with antenna and IMU both elsewhere than the file says,
against the simulator's truth."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sideslip.evaluate import metrics
from sideslip.methods.fused import fuse
from sideslip.methods.fused_box_profile import BoxProfile, profile_box
from sideslip.methods.fused_settings import FusedSettings
from tests.methods.test_fused import two_sigma_share
from tests.methods.test_fused_box import _box_misplaced

OFF = FusedSettings(profile_box_lever=False)


def _profile(score, step: float = 0.5, reach: float = 2.0) -> tuple[BoxProfile, list[float]]:
    """:func:`profile_box` of ``score`` with the places it asked for, in order."""
    asked: list[float] = []

    def counted(d: float) -> float:
        asked.append(d)
        return float(score(d))

    return profile_box(counted, float(score(0.0)), step, reach, 3.0), asked


def test_a_parabola_is_found_at_its_vertex_with_its_curvature_sigma():
    """-2 log L = 50 (d - 0.8)^2 - 32: the scan stops a step past the gate on each side, the
    parabola through the grid minimum and its neighbours is this one, so the vertex (0.8 m)
    and the sigma (1 / sqrt(50)) come out exact; 32 below the file's place: moved."""
    prof, asked = _profile(lambda d: 50.0 * (d - 0.8) ** 2 - 32.0)
    assert prof.d_m == pytest.approx(0.8, abs=1e-9)
    assert prof.sigma_m == pytest.approx(1.0 / math.sqrt(50.0), rel=1e-9)
    assert prof.gain == pytest.approx(32.0)
    assert prof.applied and prof.spread_m == prof.sigma_m
    # -0.5 is 84.5 above the lowest, 1.5 is 24.5: the scan goes no further; 0.8 refined
    assert sorted(asked) == pytest.approx([-0.5, 0.5, 0.8, 1.0, 1.5], abs=1e-12)
    assert prof.params()["box_x_tyres_scan"][0] == [-0.5, pytest.approx(52.5)]


def test_a_flat_profile_is_scanned_to_its_reach_and_its_doubt_is_kept():
    """-2 log L = 2 d^2: every place out to 2 m lies within 9 of the lowest, so all are
    scored; nothing moves, and the doubt is the curvature's sigma (1 / sqrt 2 m)."""
    prof, asked = _profile(lambda d: 2.0 * d**2)
    assert sorted(asked) == [-2.0, -1.5, -1.0, -0.5, 0.5, 1.0, 1.5, 2.0]
    assert prof.d_m == 0.0 and not prof.applied
    assert prof.spread_m == pytest.approx(1.0 / math.sqrt(2.0), rel=1e-9)
    assert "kept, its doubt (0.71 m) in beta_std" in prof.note()


def test_each_side_is_scanned_however_far_the_other_fell():
    """A profile measured on the race lap (box 1 m ahead, rough file, the scan keeping the
    antenna check's reading between antenna and IMU; -2 log L less the file's, linear in
    between): the side scanned first falls by 31 at -0.5 m, which puts the scan's 0 outside
    the gate of the lowest; the other side must still be scanned, and it falls by 79 at
    +1 m, the box's true place."""
    places = [-1.0, -0.5, 0.0, 0.5, 1.0, 1.5, 2.0]
    neg2ll = [49.4, -31.4, -11.2, -76.7, -78.9, -59.6, 0.0]
    prof, asked = _profile(lambda d: float(np.interp(d, places, neg2ll)))
    assert {0.5, 1.0, 1.5} <= set(asked)
    assert abs(prof.d_m - 1.0) < 0.25 and prof.applied


def test_a_minimum_inside_the_gate_counts_its_distance_in_the_doubt():
    """-2 log L = 4 (d - 0.5)^2 - 1: the minimum 0.5 m ahead is 1 below the file's place,
    inside the gate: kept, with the doubt hypot(sigma 0.5, distance 0.5)."""
    prof, _ = _profile(lambda d: 4.0 * (d - 0.5) ** 2 - 1.0)
    assert not prof.applied
    assert prof.d_m == pytest.approx(0.5)
    assert prof.spread_m == pytest.approx(math.hypot(0.5, 0.5), rel=1e-9)


def test_a_profile_still_falling_at_its_reach_is_not_taken():
    """-2 log L = -20 d: the lowest place is the reach (2 m), which the profile does not bend
    up around: no sigma, not moved however large the fall (40), and the doubt is the whole
    distance."""
    prof, _ = _profile(lambda d: -20.0 * d)
    assert prof.d_m == 2.0 and math.isinf(prof.sigma_m)
    assert prof.gain == pytest.approx(40.0) and not prof.applied
    assert prof.spread_m == 2.0
    assert prof.params()["box_x_tyres_m_sigma"] is None
    assert "no minimum inside the scan: kept, its doubt (2.00 m)" in prof.note()


def test_the_gain_is_read_against_the_installation_the_first_checks_settled_on():
    """Where the scan's 0 is another installation (the antenna check's untaken offset kept
    between antenna and IMU), the gain is read against the better of it and the settled one:
    the scan's 0 scoring 5 above the settled one, the minimum 0.5 m ahead is 20 below."""
    parabola = lambda d: 100.0 * (d - 0.5) ** 2 - 20.0  # noqa: E731
    prof = profile_box(parabola, 0.0, 0.5, 2.0, 3.0, neg2ll_zero=parabola(0.0))
    assert dict(prof.scan)[0.0] == pytest.approx(5.0)
    assert prof.neg2ll_file == 0.0 and prof.gain == pytest.approx(20.0)
    assert prof.applied and prof.d_m == pytest.approx(0.5)
    assert prof.params()["box_x_tyres_scan"][1] == [0.0, pytest.approx(5.0)]
    # the scan's 0 (the antenna check's IMU alternative) 25 below the settled installation:
    # the minimum beats it by 5 only, inside the gate
    shallow = lambda d: 20.0 * (d - 0.5) ** 2 - 30.0  # noqa: E731
    prof = profile_box(shallow, 0.0, 0.5, 2.0, 3.0, neg2ll_zero=shallow(0.0))
    assert prof.gain == pytest.approx(5.0) and not prof.applied


def test_a_drive_with_multipath_bursts_is_not_moved_by_its_profile():
    """The scoring runs take every Doppler epoch (the checks off, so each place is scored on
    the same data): where the file's run found epochs in multipath bursts, they score too,
    and even a deep minimum moves nothing; its doubt is carried."""
    parabola = lambda d: 50.0 * (d - 0.8) ** 2 - 32.0  # noqa: E731
    prof = profile_box(parabola, parabola(0.0), 0.5, 2.0, 3.0, burst_epochs=71)
    assert prof.gain == pytest.approx(32.0) and not prof.applied
    assert prof.spread_m == pytest.approx(math.hypot(1.0 / math.sqrt(50.0), 0.8), rel=1e-9)
    assert "71 Doppler epochs in multipath bursts score too: kept" in prof.note()


def test_a_box_ahead_on_the_race_lap_is_found_by_the_tyres_and_moved():
    """The simulated race lap (no turn below 9 m/s: the slow-turn check does not judge) with
    IMU and antenna 1 m ahead of where the file says.  Without the profile the smoother reads
    r d / v as slip: 0.619 deg with 69 % of its errors inside 2 sigma (measured).  The Doppler
    with the tyres falls by 85 at +0.84 m, 51 below the scan's 0 (measured); the box moves to
    +0.84 m (measured; bound: the truth within 0.25 m, half the scan's step) and beta falls
    under 0.15 deg (measured 0.101) with at least 95 % inside 2 sigma (measured 100 %).  The
    causal filter takes the same installation."""
    drive, vehicle = _box_misplaced("race_lap", 1.0)
    before = fuse(drive, vehicle, smooth=True, settings=OFF)
    est = fuse(drive, vehicle, smooth=True)
    p = est.params
    assert abs(p["box_x_applied_m"] - 1.0) < 0.25, p["box_x_applied_m"]
    assert p["box_x_applied_m"] == p["box_x_tyres_m"]
    # the IMU keeps the antenna check's reading against the antenna (+0.097 m, measured)
    assert p["box_imu_x_m"] == p["box_x_applied_m"] - p["gnss_lever_x_tyre_free_m"]
    assert "antenna and IMU moved by it" in p["assumed"]["box_x"]
    rmse = [metrics(drive, e.series)["beta_rmse_deg"] for e in (before, est)]
    assert rmse[1] < 0.15 < 0.5 < rmse[0], rmse
    assert two_sigma_share(drive, before) < 0.8 and two_sigma_share(drive, est) >= 0.95
    causal = fuse(drive, vehicle, smooth=False)
    assert causal.params["box_x_applied_m"] == p["box_x_applied_m"]


def test_a_box_behind_on_the_race_lap_is_not_found_but_its_doubt_is_carried():
    """The race lap with IMU and antenna 1 m behind the file's place: the tyres' profile is
    shallow (lowest at -0.8 m, 7.9 below the scan's 0; measured), so nothing moves and beta
    stays 0.648 deg (measured) but beta_std carries the profile's doubt (0.82 m times
    |r| / v): the errors inside 2 sigma go from 74 % (measured) to at least 90 % (measured
    100 %).  With the file right the lap stays as it was (0.028 deg) with its doubt no wider
    than 0.5 m (measured 0.16 m)."""
    drive, vehicle = _box_misplaced("race_lap", -1.0)
    est = fuse(drive, vehicle, smooth=True)
    p = est.params
    assert p["box_x_applied_m"] == 0.0 and "kept, its doubt" in p["assumed"]["box_x"]
    before = fuse(drive, vehicle, smooth=True, settings=OFF)
    assert np.array_equal(est["beta"], before["beta"])
    assert np.all(est["beta_std"] >= before["beta_std"])
    assert two_sigma_share(drive, before) < 0.8 and two_sigma_share(drive, est) >= 0.9
    right, file = _box_misplaced("race_lap", 0.0)
    q = fuse(right, file, smooth=True)
    assert q.params["box_x_applied_m"] == 0.0 and q.params["box_x_tyres_spread_m"] < 0.5
    assert metrics(right, q.series)["beta_rmse_deg"] < 0.05
