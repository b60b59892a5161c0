"""kinematic_integration: the compiled holds, integral and drift health against numpy forms."""

from __future__ import annotations

import numpy as np

from sideslip.methods.kinematic_integration import (
    DRIFT_AY,
    HEALTH_FULL_RAD,
    _integrate,
    drift_health,
)
from sideslip.signals import hold


def _drive(seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    n = 6000
    t = np.cumsum(rng.uniform(0.009, 0.011, n))
    vx = 15.0 + 10.0 * np.sin(t / 7.0)  # dips below the 3 m/s gate and reverses
    vx[2500:2600] = -2.0
    ay = rng.normal(0.0, 1.0, n)
    wz = rng.normal(0.0, 0.1, n)
    ay[:5] = np.nan  # rows before the first sample
    ay[rng.random(n) < 0.2] = np.nan
    wz[3000:3200] = np.nan
    return t, ay, wz, vx


def _integrate_reference(t, ay, r, vx, v_gate):
    beta = np.zeros(t.size)
    for k in range(1, t.size):
        v = vx[k - 1]
        if v >= v_gate:
            b = beta[k - 1] + (t[k] - t[k - 1]) * (ay[k - 1] / v - r[k - 1])
            beta[k] = min(max(b, -1.5), 1.5)
    return beta


def _drift_reference(t, vx, v_gate):
    dt = np.diff(t, prepend=t[0])
    rate = np.where(vx >= v_gate, DRIFT_AY / np.maximum(vx, v_gate), 0.0) * dt
    c = np.cumsum(rate)
    reset = np.where(vx < v_gate, np.arange(t.size), -1)
    np.maximum.accumulate(reset, out=reset)
    drift = c - np.where(reset >= 0, c[np.maximum(reset, 0)], 0.0)
    health = np.clip(drift / HEALTH_FULL_RAD, 0.0, 1.0)
    return np.where(vx <= -0.1, 1.0, health)


def test_compiled_integral_holds_the_samples_as_signals_hold() -> None:
    for seed in (0, 1):
        t, ay, wz, vx = _drive(seed)
        beta, r, imu = _integrate(t, ay, wz, vx, 3.0)
        ay_held, _ = hold(ay, t)
        r_held, _ = hold(wz, t)
        np.testing.assert_array_equal(r, r_held)
        np.testing.assert_array_equal(imu, np.isfinite(ay) & np.isfinite(wz))
        np.testing.assert_array_equal(beta, _integrate_reference(t, ay_held, r_held, vx, 3.0))
        assert np.all(np.abs(beta) <= 1.5) and np.any(beta != 0.0)


def test_compiled_drift_health_equals_its_cumulative_sum_form() -> None:
    for seed, gate in ((0, 3.0), (1, 8.0)):
        t, _, _, vx = _drive(seed)
        h = drift_health(t, vx, gate)
        np.testing.assert_array_equal(h, _drift_reference(t, vx, gate))
        assert h.min() == 0.0 and h.max() == 1.0  # resets and a full drift both occur
