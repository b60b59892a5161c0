"""The fused estimator's process model: analytic Jacobian against central differences, and one
step against the exact kinematics of a steady turn."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sideslip.models.fused_process import (
    IBG,
    ICY,
    IE,
    IN,
    IPSI,
    IVX,
    IVY,
    NX_CORE,
    NX_GNSS_CAL,
    f_rows,
    process,
)


def _state(nx: int, rng: np.random.Generator) -> np.ndarray:
    x = rng.normal(0.0, 0.1, nx)
    x[IE], x[IN], x[IPSI], x[IVX], x[IVY] = 10.0, -5.0, 0.7, 22.0, 0.4
    x[ICY] = 0.8  # a few degrees of bank
    return x


@pytest.mark.parametrize("nx", [NX_CORE, NX_CORE + NX_GNSS_CAL])
@pytest.mark.parametrize("road_roll", [None, 0.05])
def test_jacobian_matches_central_differences(nx, road_roll):
    """navlie-style check: every entry of F against (f(x + h e_j) - f(x - h e_j)) / 2h; the
    model is smooth away from the attitude clamp, so h = 1e-6 agrees to 1e-6 absolute."""
    rng = np.random.default_rng(3)
    x = _state(nx, rng)
    u = np.array([0.2, 0.05, -0.03, 0.5, 3.0, 2.9] + ([] if road_roll is None else [road_roll]))
    dt = 0.05
    _, F = process(x, u, dt, 0.01, 60.0)
    num = np.zeros((nx, nx))
    h = 1e-6
    for j in range(nx):
        xp, xm = x.copy(), x.copy()
        xp[j] += h
        xm[j] -= h
        num[:, j] = (process(xp, u, dt, 0.01, 60.0)[0] - process(xm, u, dt, 0.01, 60.0)[0]) / (2 * h)
    np.testing.assert_allclose(F, num, atol=1e-6)
    # the sparse pattern the prediction uses covers every non-zero of F
    rows = f_rows(nx)
    for i in range(nx):
        cols = set(rows[i][rows[i] >= 0])
        assert set(np.flatnonzero(np.abs(F[i]) > 0)) <= cols


def test_steady_turn_step_follows_the_circle():
    """Analytic case: v = 20 m/s, r = 0.2 rad/s (R = 100 m), a_y = v r, no bias.  One 10 ms step
    moves heading by r dt and keeps v_y (the centripetal term cancels a_y), and the position
    advances along the circle to second order (error O(dt^3) = 1e-6 m)."""
    x = np.zeros(NX_CORE)
    x[IVX] = 20.0
    u = np.array([0.2, 0.0, 0.0, 0.0, 4.0, 4.0])
    dt = 0.01
    xn, _ = process(x, u, dt, 0.0, 60.0)
    assert xn[IPSI] == pytest.approx(0.2 * dt)
    assert xn[IVY] == pytest.approx(0.0, abs=1e-12)
    radius = 100.0
    assert xn[IE] == pytest.approx(radius * math.sin(0.2 * dt), abs=1e-6)
    assert xn[IN] == pytest.approx(radius * (1 - math.cos(0.2 * dt)), abs=1e-6)
    x[IBG] = 0.01  # a gyro bias is removed from the rate
    u2 = u.copy()
    u2[0] = 0.21
    assert process(x, u2, dt, 0.0, 60.0)[0][IPSI] == pytest.approx(0.2 * dt)


def test_a_steady_turn_with_suspension_roll_keeps_v_y_on_a_level_road():
    """Analytic case: the tyres' force per mass f = v r = 4 m/s^2 rolls the body by k_phi f
    (k_phi = 0.012 rad per m/s^2, CommonRoad's BMW file), and the body-fixed accelerometer
    reads f plus gravity through that roll, a_y = f (1 + g k_phi).  On a level road (c_y = 0)
    one step keeps v_y: the model takes f = a_y / (1 + g k_phi) out of the reading.  The
    first-order a_y (1 - g k_phi) left f (g k_phi)^2 = 0.055 m/s^2 of lateral acceleration,
    5.5e-4 m/s of v_y per 10 ms step, which c_y took up as a 0.3 deg bank."""
    k_phi, f, g = 0.012, 4.0, 9.80665
    x = np.zeros(NX_CORE)
    x[IVX] = 20.0
    u = np.array([0.2, 0.0, 0.0, 0.0, f * (1.0 + g * k_phi), f])
    xn, _ = process(x, u, 0.01, k_phi, 60.0)
    assert xn[IVY] == pytest.approx(0.0, abs=1e-12)


def test_road_bank_follows_the_roll_input_and_the_body_rate_turns_the_velocity():
    """The bank-rate input (the roll gyro less the suspension's roll rate) moves c_y by
    g cos(bank) rate dt; on a bank the body velocity turns with the gyro's own z rate (w_z,
    here 0.2 rad/s), not the heading rate r = w_z / cos(bank): steady v_y when a_y - c_y
    equals w_z v_x."""
    x = np.zeros(NX_CORE)
    x[IVX] = 20.0
    x[ICY] = 9.80665 * math.sin(math.radians(20.0))
    bank_rate = 0.1
    u = np.array([0.2, 0.0, 0.0, 0.0, x[ICY] + 0.2 * 20.0, 0.0, bank_rate])
    dt = 0.01
    xn, _ = process(x, u, dt, 0.0, 60.0)
    assert xn[ICY] - x[ICY] == pytest.approx(9.80665 * math.cos(math.radians(20.0)) * bank_rate * dt, rel=1e-9)
    assert xn[IVY] == pytest.approx(0.0, abs=1e-12)
    # without the input (a drive without wx) c_y is a random walk: unchanged by the step
    assert process(x, u[:6], dt, 0.0, 60.0)[0][ICY] == x[ICY]
