"""Linear single-track model: steady-state gains, discretisation, per-axle vs per-tyre forms."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from sideslip.models.single_track import (
    continuous,
    discretise,
    sideslip_gain,
    steady_state,
    van_loan,
    yaw_rate_gain,
)
from sideslip.vehicle import G, load_vehicle


@pytest.mark.parametrize("speed", [5.0, 15.0, 30.0])
def test_steady_state_yaw_gain_is_v_over_l_plus_kus_v2(speed):
    v = load_vehicle("blazer_suv")
    model = continuous(v, speed)
    gains = steady_state(model)
    expected = speed / (v.wheelbase + v.understeer_gradient_tyres * speed**2)
    assert gains[1, 0] == pytest.approx(expected, rel=1e-10)
    assert yaw_rate_gain(v, speed) == pytest.approx(expected, rel=1e-12)
    assert gains[0, 0] == pytest.approx(sideslip_gain(v, speed), rel=1e-10)


def test_bank_input_steady_state_needs_no_steer_on_a_neutral_car():
    # A car on a bank at constant speed, no steer: lateral balance m g sin(bank) held by tyres.
    v = load_vehicle("midsize_sedan")
    model = continuous(v, 20.0)
    gains = steady_state(model)
    bank = 0.05
    beta, r = gains[:, 1] * bank
    # gravity-free lateral acceleration a_y = C x + D u must equal V r in steady state
    ay = model.C[1] @ np.array([beta, r]) + model.D[1, 1] * bank
    assert ay == pytest.approx(20.0 * r, abs=1e-9)


def test_discrete_response_matches_continuous_integration():
    v = load_vehicle("seed003_sedan")
    model = continuous(v, 22.0)
    dt = 0.01
    Ad, Bd = discretise(model.A, model.B, dt)
    u = np.array([0.02, 0.01])
    x = np.zeros(2)
    for _ in range(150):
        x = Ad @ x + Bd @ u
    sol = solve_ivp(lambda _t, s: model.A @ s + model.B @ u, (0, 1.5), [0, 0], rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(x, sol.y[:, -1], rtol=1e-7, atol=1e-10)


def test_van_loan_matches_numerical_integral():
    v = load_vehicle("seed003_sedan")
    A = continuous(v, 15.0).A
    Qc = np.diag([1e-4, 4e-4])
    Ad, Qd = van_loan(A, Qc, 0.05)
    # numerical integral of exp(As) Qc exp(A's) over [0, dt]
    from scipy.linalg import expm

    s = np.linspace(0, 0.05, 2001)
    vals = np.array([expm(A * si) @ Qc @ expm(A * si).T for si in s])
    Qnum = np.trapezoid(vals, s, axis=0)
    np.testing.assert_allclose(Ad, expm(A * 0.05), rtol=1e-12)
    np.testing.assert_allclose(Qd, Qnum, rtol=1e-6)


def test_seed002_per_axle_and_seed003_per_tyre_forms_are_the_same_model():
    v = load_vehicle("seed003_sedan")
    speed = 20.0
    m, iz, lf, lr = v.mass, v.yaw_inertia, v.lf, v.lr
    cf_t, cr_t = 2000 * 180 / math.pi, 1600 * 180 / math.pi  # per tyre, seed 003 Table 1
    a003 = np.array(
        [
            [-2 * (cf_t + cr_t) / (m * speed), 2 * (cr_t * lr - cf_t * lf) / (m * speed**2) - 1],
            [2 * (cr_t * lr - cf_t * lf) / iz, -2 * (cf_t * lf**2 + cr_t * lr**2) / (iz * speed)],
        ]
    )
    b003 = np.array([2 * cf_t / (m * speed), 2 * cf_t * lf / iz])
    cf, cr = 2 * cf_t, 2 * cr_t  # seed 002: per axle
    a002 = np.array(
        [
            [-(cf + cr) / (m * speed), (cr * lr - cf * lf) / (m * speed**2) - 1],
            [(cr * lr - cf * lf) / iz, -(cf * lf**2 + cr * lr**2) / (iz * speed)],
        ]
    )
    model = continuous(v.with_changes(cf=cf, cr=cr), speed)
    np.testing.assert_allclose(a003, a002, rtol=1e-12)
    np.testing.assert_allclose(model.A, a002, rtol=1e-12)
    np.testing.assert_allclose(model.B[:, 0], b003, rtol=1e-12)
    # the preset rounds the converted stiffness to 1 N/rad: same model to 2e-5
    np.testing.assert_allclose(continuous(v, speed).A, a002, rtol=2e-5)
    assert model.B[0, 1] == pytest.approx(-G / speed)
