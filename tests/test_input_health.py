"""Input health: rows where a method's inputs are gone or implausible, for every method."""

import numpy as np

from sideslip.input_health import clock_jump_health, dropout_health, wheel_speed_health
from sideslip.methods.registry import run_method
from sideslip.vehicle import load_vehicle
from tests.conftest import sim_drive
from tests.methods import robust_drives as rd


def test_dropout_is_flagged_after_the_allowed_silence_only():
    t = np.arange(0.0, 20.0, 0.01)
    x = np.sin(t)
    x[(t >= 5.0) & (t < 8.0)] = np.nan  # 3 s silence of a 100 Hz sensor (allowed: 0.2 s)
    h = dropout_health(x, t)
    assert h[(t >= 6.3) & (t < 8.0)].min() == 1.0  # 1.3 s into the gap: past 0.2 s + 1 s ramp
    assert h[t < 5.19].max() == 0.0 and h[t >= 8.0].max() == 0.0


def test_clock_jump_flags_the_following_seconds():
    t = np.r_[np.arange(0, 10, 0.01), 3600 + np.arange(0, 10, 0.01)]
    h = clock_jump_health(t)
    assert h[1000] == 1.0 and 0 < h[1200] < 1 and h[-1] == 0.0 and h[:1000].max() == 0.0


def test_locked_wheels_are_flagged_until_they_agree_with_the_accelerometer_again():
    # braking at 5 m/s^2 from 20 m/s; the wheels read 0 from 1.0 to 2.5 s (locked), then recover
    t = np.arange(0.0, 4.0, 0.01)
    v = 20.0 - 5.0 * t
    ax = np.full(t.size, -5.0)
    wheels = v.copy()
    lock = (t >= 1.0) & (t < 2.5)
    wheels[lock] = 0.0
    h = wheel_speed_health(wheels, t, ax)
    assert h[lock].min() == 1.0
    assert h[t >= 2.6].max() == 0.0 and h[t < 0.9].max() == 0.0


def test_noisy_1khz_wheel_speeds_are_not_flagged():
    # 0.05 m/s noise at 1 kHz differentiates to 70 m/s^2 sample to sample; judged over 0.1 s
    # spans with a 0.5 m/s allowance it is no event
    rng = np.random.default_rng(3)
    t = np.arange(0.0, 60.0, 0.001)
    v = 15.0 + np.sin(0.2 * t) + 0.05 * rng.standard_normal(t.size)
    h = wheel_speed_health(v, t, 0.2 * np.cos(0.2 * t))
    assert h.max() == 0.0


def test_every_method_flags_a_wheel_lock_and_a_dropout_through_run_method():
    vehicle = load_vehicle("midsize_sedan")
    lock = rd.with_wheel_lock(sim_drive("demo"))
    est = run_method("kinematic_integration", lock, vehicle)
    rows = (lock.t >= lock.t[0] + 40.0) & (lock.t < lock.t[0] + 41.5)
    assert est["health"][rows].max() > 0.5
    assert est.params["input_health"]["flagged_share"] < 0.05  # only the event, not the drive
    drop = rd.with_dropout(sim_drive("demo"))
    est = run_method("kinematic_integration", drop, vehicle)
    gap = (drop.t >= drop.t[0] + 51.5) & (drop.t < drop.t[0] + 60.0)
    assert est["health"][gap].min() == 1.0
