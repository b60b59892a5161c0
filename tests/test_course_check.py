"""The course's error beyond its stated sigma, read against the gyro (sideslip.course_check),
and kkf's beta_std with it on a 20 Hz positions-only receiver with multipath bursts."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sideslip.course_check import course_excess_variance, courses_per_error, independent_lag_s
from sideslip.drive import Drive
from sideslip.methods.registry import run_method
from sideslip.simulate import simulate
from sideslip.simulate.run import _lookup
from sideslip.simulate.sensors import SensorConfig
from sideslip.vehicle import load_vehicle

DEG = math.pi / 180.0


def _turning(rate_hz: float, seconds: float = 120.0) -> tuple[np.ndarray, ...]:
    """100 Hz rows with a weaving yaw rate (0.3 rad/s peak, 8 s period), the true heading, and
    the rows of a course receiver at ``rate_hz``."""
    t = np.arange(0.0, seconds, 0.01)
    r = 0.3 * np.sin(2.0 * math.pi * t / 8.0)
    psi = np.concatenate(([0.0], np.cumsum(r[:-1] * 0.01)))
    rows = np.arange(0, t.size, round(100 / rate_hz))
    return t, r, psi, rows


def test_white_course_noise_beyond_its_stated_sigma_is_read_where_it_occurs() -> None:
    """Doppler-like courses (independent epochs at 10 Hz) stated at 0.5 deg; from 60 s on
    their true noise is 3 deg.  Truth: the noise drawn.  The window's mean of d^2 / 2 over 20
    pairs scatters by about sqrt(2 / 20) = 32 % in variance, so the bounds are: the median
    sigma read within 10 % of 3 deg after 60 s, and under 0.3 deg of excess sigma before."""
    t, r, psi, rows = _turning(10.0)
    rng = np.random.default_rng(1)
    true_sigma = np.where(t[rows] < 60.0, 0.5 * DEG, 3.0 * DEG)
    course = psi[rows] + true_sigma * rng.standard_normal(rows.size)
    stated = np.full(rows.size, 0.5 * DEG)
    out = course_excess_variance(t, rows, course, stated, r, baseline_s=0.0)
    late = t[rows] > 62.0
    early = t[rows] < 58.0
    read = np.sqrt(out.excess_var + stated**2)
    assert np.median(read[late]) == pytest.approx(3.0 * DEG, rel=0.10)
    assert np.degrees(np.median(np.sqrt(out.excess_var[early]))) < 0.3
    summary = out.summary()
    assert 0.4 < summary["share_beyond_stated"] < 0.6
    assert summary["largest_empirical_sigma_deg"] > 3.0


def test_overlapping_baselines_need_pairs_one_baseline_apart() -> None:
    """A 20 Hz receiver's courses over a 1 s baseline: each course error is the mean of the
    20 fix-to-fix errors inside its baseline, so neighbours share 19 of 20.  Truth: those
    errors' marginal sigma (2 deg, stated as 0.2).  Pairs a baseline apart read it within
    15 %; consecutive pairs see only the one-step change and read about a quarter of it (measured 1.85 and
    0.48 deg)."""
    t, r, psi, rows = _turning(20.0)
    rng = np.random.default_rng(2)
    steps = rng.standard_normal(rows.size + 19)
    err = np.convolve(steps, np.ones(20) / 20.0, mode="valid")  # moving mean over 20 steps
    err *= 2.0 * DEG / err.std()
    course = psi[rows] + err
    stated = np.full(rows.size, 0.2 * DEG)
    apart = course_excess_variance(t, rows, course, stated, r, baseline_s=1.0)
    consecutive = course_excess_variance(t, rows, course, stated, r, baseline_s=0.0)
    assert np.nanmedian(apart.empirical_sigma) == pytest.approx(2.0 * DEG, rel=0.15)
    assert np.nanmedian(consecutive.empirical_sigma) < 0.5 * 2.0 * DEG


def test_a_turn_the_gyro_measures_is_no_course_error_and_gaps_break_pairs() -> None:
    """Courses exactly the heading (no noise), the gyro exactly the yaw rate: nothing beyond
    the stated sigma.  An outage of 5 s leaves its pairs out; too few samples give none."""
    t, r, psi, rows = _turning(10.0)
    keep = (t[rows] < 40.0) | (t[rows] > 45.0)
    rows = rows[keep]
    out = course_excess_variance(t, rows, psi[rows], np.full(rows.size, 0.1 * DEG), r, 0.0)
    assert np.all(out.excess_var < (0.01 * DEG) ** 2)
    one = course_excess_variance(t, rows[:1], psi[rows[:1]], np.array([0.1 * DEG]), r, 0.0)
    assert one.excess_var.tolist() == [0.0] and np.isnan(one.empirical_sigma[0])


def test_independent_lag_follows_the_receiver() -> None:
    t = np.arange(0.0, 10.0, 0.01)
    base = {"wz": np.zeros(t.size), "gnss_e": np.zeros(t.size), "gnss_n": np.zeros(t.size)}
    assert independent_lag_s(Drive(t, base), t[::5]) == 1.0  # 20 Hz fixes: the 1 s baseline
    assert independent_lag_s(Drive(t, base), t[::100]) == 2.0  # 1 Hz: two fix intervals
    doppler = {**base, "gnss_ve": np.zeros(t.size), "gnss_vn": np.zeros(t.size)}
    assert independent_lag_s(Drive(t, doppler), t[::10]) == 0.0


@pytest.mark.parametrize("seed", [0, 1])
def test_kkf_beta_std_covers_multipath_bursts_of_a_positions_only_receiver(seed: int) -> None:
    """dlc_bank (the simulator's nonlinear model) with a 20 Hz receiver without Doppler and
    multipath bursts (one every 10 s on average, 3 m per axis, while the receiver states 1 m):
    kkf's beta = course - heading takes every burst.  Truth: the simulator's beta.  Measured:
    0.86 / 0.83 of the errors inside 2 beta_std without the check, 0.94 / 0.92 with it; since
    kkf weighs the overlapping 1 s courses as the one error they share (2026-12-07), 0.92 /
    0.89 without, 0.97 / 0.96 with: the check adds at least 0.03 on both seeds."""
    config = SensorConfig().with_overrides(_lookup("dlc_bank").sensor_overrides)
    receiver = {"gnss_rate_hz": 20.0, "gnss_doppler": False}
    config = config.with_overrides({**receiver, "gnss_burst_rate_hz": 0.1, "gnss_burst_pos_std": 3.0})
    d = simulate("dlc_bank", seed=seed, config=config)
    vehicle = load_vehicle(d.meta["vehicle"])
    fast = d["ref_vx"] > 5.0
    shares = {}
    for on in (False, True):
        est = run_method("kkf", d, vehicle, {"course_check": on})
        err = np.abs(np.angle(np.exp(1j * (est["beta"] - d["ref_beta"]))))[fast]
        shares[on] = float(np.mean(err < 2.0 * est["beta_std"][fast]))
        assert est.params["course_check"]["applied"] is on
    assert shares[True] >= 0.90
    assert shares[True] >= shares[False] + 0.03
    assert est.params["course_check"]["share_beyond_stated"] > 0.1


def test_courses_per_error_counts_the_courses_that_share_one_baseline() -> None:
    # 20 Hz fixes differenced over 1 s: 20 courses per error; consecutive 1 Hz fixes share one
    # fix with the next course: 2; Doppler epochs are each their own: 1
    t = np.arange(0.0, 10.0, 0.01)
    course = np.full(t.size, np.nan)
    course[::5] = 0.0
    pos = {"wz": np.zeros(t.size), "gnss_e": np.zeros(t.size), "gnss_n": np.zeros(t.size)}
    assert courses_per_error(Drive(t, pos), t, course, 0.05) == pytest.approx(20.0)
    slow = np.full(t.size, np.nan)
    slow[::100] = 0.0
    assert courses_per_error(Drive(t, pos), t, slow, 1.0) == pytest.approx(2.0)
    doppler = {**pos, "gnss_ve": np.zeros(t.size), "gnss_vn": np.zeros(t.size)}
    assert courses_per_error(Drive(t, doppler), t, course, 0.05) == 1.0
