"""Kalman diagnostics: the discrete Riccati steady state, NIS and the whiteness test."""

from __future__ import annotations

import numpy as np
import pytest

from sideslip.filters.diagnostics import (
    autocorrelation,
    nis,
    normalised_innovations,
    steady_state,
    whiteness,
)
from sideslip.filters.reference import predict, update_joseph


def test_steady_state_scalar_random_walk_is_analytic() -> None:
    # x_{k+1} = x_k + w (var q), z = x + v (var r): P- = (q + sqrt(q^2 + 4 q r)) / 2
    q, r = 0.2, 1.5
    ss = steady_state([[1.0]], [[1.0]], [[q]], [[r]])
    pm = 0.5 * (q + np.sqrt(q * q + 4 * q * r))
    assert ss.P_prior[0, 0] == pytest.approx(pm, rel=1e-10)
    assert ss.P_post[0, 0] == pytest.approx(pm * r / (pm + r), rel=1e-10)
    assert ss.K[0, 0] == pytest.approx(pm / (pm + r), rel=1e-10)


def test_steady_state_is_the_limit_of_the_recursion() -> None:
    F = np.array([[0.9, 0.1], [0.0, 1.0]])
    H = np.array([[1.0, 0.0]])
    Q = np.diag([0.01, 0.001])
    R = np.array([[0.1]])
    x, P = np.zeros(2), np.eye(2)
    for _ in range(2000):
        x, P = predict(x, P, F, Q)
        x, P, _, _ = update_joseph(x, P, [0.0], H, R)
    ss = steady_state(F, H, Q, R)
    np.testing.assert_allclose(P, ss.P_post, rtol=1e-8)


def test_normalised_innovations_divides_by_sigma_and_keeps_nan() -> None:
    z = normalised_innovations([2.0, np.nan, 1.0, 3.0], [4.0, 1.0, 0.0, np.nan])
    assert z[0] == pytest.approx(1.0)
    assert np.isnan(z[1]) and np.isnan(z[2]) and np.isnan(z[3])


def test_whiteness_accepts_white_noise_and_rejects_ar1() -> None:
    rng = np.random.default_rng(7)
    e = rng.normal(size=5000)
    w = whiteness(e, lags=20)
    # white noise: p-value uniform on [0, 1]; this seed gives a typical draw (fixed, so not flaky)
    assert w.white and w.p_value > 0.05
    assert w.nis_mean == pytest.approx(1.0, abs=0.05)  # 5000 samples: sd of the mean ~0.02
    ar = np.empty_like(e)
    ar[0] = e[0]
    for k in range(1, e.size):
        ar[k] = 0.5 * ar[k - 1] + e[k]
    c = whiteness(ar, lags=20)
    assert not c.white and c.p_value < 1e-10
    # lag-1 autocorrelation of AR(1) is its coefficient (0.5; sampling sd ~ 1/sqrt(n) = 0.014)
    assert c.rho[0] == pytest.approx(0.5, abs=0.05)
    assert c.colour > 10 * w.colour


def test_whiteness_short_sequence_is_inconclusive() -> None:
    w = whiteness([0.1, -0.2, 0.3], lags=20)
    assert w.white and w.p_value == 1.0 and w.n == 3
    assert autocorrelation(np.zeros(50), 5).tolist() == [0.0] * 5


def test_nis_scalar_and_vector_forms() -> None:
    np.testing.assert_allclose(nis([2.0, np.nan, 1.0], [4.0, 1.0, 0.0]), [1.0, np.nan, np.nan])
    S = np.array([[[2.0, 0.5], [0.5, 1.0]]] * 2)
    nu = np.array([[1.0, -1.0], [np.nan, 0.0]])
    ref = float(nu[0] @ np.linalg.solve(S[0], nu[0]))
    out = nis(nu, S)
    assert out[0] == pytest.approx(ref) and np.isnan(out[1])
