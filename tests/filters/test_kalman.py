"""Generic Kalman numerics: analytic scalar cases, Joseph form, DARE, whiteness test."""

from __future__ import annotations

import numpy as np
import pytest

from sideslip.filters.kalman import (
    autocorrelation,
    normalised_innovations,
    predict,
    predict_nb,
    steady_state,
    update_joseph,
    update_scalar_nb,
    whiteness,
)


def test_scalar_update_matches_hand_computation() -> None:
    # prior N(0, 4), measurement z = 2 with variance 1: K = 4/5, x+ = 1.6, P+ = 0.8
    x, P, innov, S = update_joseph([0.0], [[4.0]], [2.0], [[1.0]], [[1.0]])
    assert x[0] == pytest.approx(1.6, abs=1e-12)
    assert P[0, 0] == pytest.approx(0.8, abs=1e-12)
    assert innov[0] == pytest.approx(2.0)
    assert S[0, 0] == pytest.approx(5.0)


def test_predict_propagates_mean_and_covariance() -> None:
    F = np.array([[1.0, 0.1], [0.0, 1.0]])
    G = np.array([[0.005], [0.1]])
    x, P = predict([1.0, 2.0], np.eye(2), F, 0.01 * np.eye(2), G, [3.0])
    np.testing.assert_allclose(x, [1.0 + 0.2 + 0.015, 2.3])
    np.testing.assert_allclose(P, F @ F.T + 0.01 * np.eye(2))


def test_numba_kernels_match_numpy_and_sequential_equals_batch() -> None:
    rng = np.random.default_rng(1)
    n = 4
    L = rng.normal(size=(n, n))
    P0 = L @ L.T + n * np.eye(n)
    x0 = rng.normal(size=n)
    F = np.eye(n) + 0.1 * rng.normal(size=(n, n))
    Q = 0.1 * np.eye(n)
    Gu = rng.normal(size=n)
    xn, Pn = x0.copy(), P0.copy()
    predict_nb(xn, Pn, F, Q, Gu)
    xr, Pr = predict(x0, P0, F, Q, np.eye(n), Gu)
    np.testing.assert_allclose(xn, xr, rtol=1e-12)
    np.testing.assert_allclose(Pn, Pr, rtol=1e-12)
    # two independent scalar measurements one after the other == one 2-vector update
    H = rng.normal(size=(2, n))
    R = np.diag([0.3, 0.7])
    z = rng.normal(size=2)
    xb, Pb, _, _ = update_joseph(xr, Pr, z, H, R)
    xs, Ps = xr.copy(), Pr.copy()
    for i in range(2):
        update_scalar_nb(xs, Ps, float(z[i] - H[i] @ xs), H[i].copy(), float(R[i, i]))
    np.testing.assert_allclose(xs, xb, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(Ps, Pb, rtol=1e-10, atol=1e-12)


def test_joseph_form_keeps_covariance_symmetric_positive_with_suboptimal_round_off() -> None:
    # a nearly singular update (R tiny) is where the short form (I - K H) P loses symmetry
    P = np.array([[1e4, 1e4 - 1e-3], [1e4 - 1e-3, 1e4]])
    _, Pn, _, _ = update_joseph([0.0, 0.0], P, [1.0], [[1.0, 0.0]], [[1e-9]])
    assert np.allclose(Pn, Pn.T, rtol=0, atol=0)
    assert np.all(np.linalg.eigvalsh(Pn) > -1e-9)


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
