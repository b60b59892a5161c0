"""Health of the methods without a covariance (observer_health) and its gap term."""

from __future__ import annotations

import numpy as np
import pytest

from sideslip.methods.observer_health import blocked_consistency, stale_health
from sideslip.methods.registry import run_method
from sideslip.vehicle import load_vehicle
from tests.conftest import sim_drive
from tests.methods.robust_drives import with_sensor_gaps

MINE = ("obs_bicycle", "obs_kinematic", "obs_modified", "obs_modified_nocomp", "roll_index",
        "roll_dfc", "kinematic_integration", "doppler_slip", "doppler_slip_noroll")


def test_stale_health_rises_over_a_gap_and_ignores_the_normal_rate() -> None:
    t = np.arange(0.0, 10.0, 0.01)
    fresh = (np.arange(t.size) % 2 == 0) & ~((t > 3.0) & (t < 6.0))  # 50 Hz, 3 s hole
    h = stale_health(t, fresh)
    assert np.all(h[t < 3.0] == 0.0)  # every other row fresh: the normal rate, no gap
    # 0.5 s into the hole, past the 0.1 s normal-gap allowance: 0.5 x (0.5 - 0.1) / 1 s
    assert h[np.searchsorted(t, 3.5)] == pytest.approx(0.5 * (0.5 - 0.1), abs=0.01)
    assert np.all(h[(t > 4.2) & (t < 6.0)] == 0.5)
    assert np.all(h[t > 6.1] == 0.0)


def test_blocked_consistency_flags_a_burst_of_large_residuals() -> None:
    # chi^2(1) NIS everywhere, ten times larger for 3 s: the burst (and only about it) flagged
    rng = np.random.default_rng(0)
    t = np.arange(0.0, 60.0, 0.01)
    z = rng.standard_normal(t.size)
    z[(t > 30) & (t < 33)] *= np.sqrt(10.0)
    health, inflation, summary = blocked_consistency(t, z * z, np.ones(t.size), 2.0, False)
    burst = (t > 30.5) & (t < 32.5)
    quiet = (t < 25) | (t > 38)
    assert np.all(health[burst] > 0) and np.mean(inflation[burst]) > 5.0
    assert np.mean(health[quiet] > 0) < 0.02
    assert 0.0 < summary["flagged_share"] < 0.15


def test_every_method_flags_held_sensor_samples_and_stays_finite() -> None:
    # three 1.5 s holes in the IMU and wheel speeds and a 20 s GNSS outage (robust_drives):
    # outputs finite, health in [0, 1], and at least 0.5 once a hole has lasted 1.2 s
    drive = with_sensor_gaps(sim_drive("demo"))
    vehicle = load_vehicle("midsize_sedan")
    imu = np.isfinite(drive["wz"])
    last = np.maximum.accumulate(np.where(imu, np.arange(imu.size), 0))
    deep = (~imu) & (drive.t - drive.t[last] > 1.2) & (drive["ref_vx"] > 6.0)
    assert deep.sum() > 20
    for m in MINE:
        est = run_method(m, drive, vehicle)
        h = est["health"]
        assert np.all(np.isfinite(h)) and h.min() >= 0.0 and h.max() <= 1.0, m
        assert np.all(h[deep] >= 0.5 - 1e-9), m
        assert "health" in est.params, m
