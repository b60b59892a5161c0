"""Self-check of the slip model against the Doppler sideslip (doppler_health)."""

from __future__ import annotations

import numpy as np
import pytest

from sideslip.methods.doppler_health import doppler_health, fit_slip_lag


def test_slip_lag_recovered_when_present_and_rejected_when_absent() -> None:
    # innovation = tau x rate term + course noise (0.3 deg at 10 Hz), slalom-like rate term
    rng = np.random.default_rng(2)
    t = np.arange(0.0, 120.0, 0.1)
    rate = 0.02 * np.sin(2 * np.pi * 0.5 * t)  # rad/s
    noise = np.radians(0.3) * rng.standard_normal(t.size)
    lag = fit_slip_lag(t, rate, 0.2 * rate + noise)
    assert lag.applied and lag.tau_s == pytest.approx(0.2, abs=3 * lag.tau_s_sigma)
    assert lag.tau_s_sigma < 0.05
    none = fit_slip_lag(t, rate, noise)
    assert not none.applied and "not significant" in none.note
    lead = fit_slip_lag(t, rate, -0.2 * rate + noise)  # a lead is not a lag
    assert not lead.applied


def test_health_and_inflation_where_the_model_is_off_and_reversing_flagged() -> None:
    # 10 Hz Doppler epochs, course noise 0.2 deg, model right except a 1 deg error for 10 s
    rng = np.random.default_rng(3)
    t = np.arange(0.0, 100.0, 0.01)
    rows = np.arange(0, t.size, 10)
    sig = np.full(rows.size, np.radians(0.2))
    model = np.zeros(rows.size)
    truth = np.where((t[rows] > 40) & (t[rows] < 50), np.radians(1.0), 0.0)
    dopp = truth + sig * rng.standard_normal(rows.size)
    std = np.full(t.size, np.radians(0.1))
    forward = np.ones(t.size, bool)
    reversing = t > 95.0
    forward &= ~reversing
    out = doppler_health(t, rows, dopp, model, sig, std, forward, reversing)
    off = (t > 41) & (t < 49)
    good = (t < 35) | ((t > 55) & (t < 95))
    # inside the bad stretch the 1-sigma grows to cover the 1 deg error (2 sigma > 1 deg)
    assert np.median(out.beta_std[off]) > np.radians(0.5)
    assert np.all(out.health[off] > 0)
    assert np.mean(out.health[good] > 0) < 0.05
    assert np.all(out.health[reversing] == 1.0)
    assert np.isfinite(out.innovation[rows[:-60]]).all()
