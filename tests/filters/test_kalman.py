"""Generic Kalman numerics: analytic scalar cases, Joseph form, DARE, whiteness test."""

from __future__ import annotations

import numpy as np
import pytest

from sideslip.filters.kalman import (
    autocorrelation,
    cholesky,
    cholesky_nb,
    nis,
    normalised_innovations,
    predict,
    predict_nb,
    predict_sparse_nb,
    rts_smooth,
    rts_smooth_nb,
    steady_state,
    update_joseph,
    update_robust_scalar,
    update_robust_scalar_nb,
    update_scalar_nb,
    update_vector_nb,
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


# ------------------------------------------------------------------------------------------
# every numba kernel against its plain-numpy reference (seeded random SPD problems)
# ------------------------------------------------------------------------------------------
def _spd(rng: np.random.Generator, n: int) -> np.ndarray:
    L = rng.normal(size=(n, n))
    return L @ L.T + 0.5 * np.eye(n)


@pytest.mark.parametrize("n", [1, 3, 8, 14])
def test_scalar_joseph_kernel_matches_numpy_reference(n: int) -> None:
    rng = np.random.default_rng(10 + n)
    for _ in range(5):
        P = _spd(rng, n)
        x = rng.normal(size=n)
        h = rng.normal(size=n)
        r = float(rng.uniform(0.01, 2.0))
        z = float(rng.normal())
        xr, Pr, _, Sr = update_joseph(x, P, [z], h[None, :], [[r]])
        xn, Pn = x.copy(), P.copy()
        s = update_scalar_nb(xn, Pn, z - float(h @ x), h, r)
        # same equations in a different order of operations: round-off only
        np.testing.assert_allclose(xn, xr, rtol=1e-10, atol=1e-12)
        np.testing.assert_allclose(Pn, Pr, rtol=1e-9, atol=1e-11)
        assert s == pytest.approx(Sr[0, 0], rel=1e-12)
        assert np.array_equal(Pn, Pn.T)


def test_scalar_update_with_no_information_leaves_state_unchanged() -> None:
    x, P = np.array([1.0, 2.0]), np.zeros((2, 2))
    s = update_scalar_nb(x, P, 5.0, np.array([1.0, 0.0]), 0.0)
    assert s == 0.0
    np.testing.assert_array_equal(x, [1.0, 2.0])


@pytest.mark.parametrize("m", [1, 2, 3])
def test_vector_kernel_with_correlated_noise_matches_batch_update(m: int) -> None:
    rng = np.random.default_rng(20 + m)
    n = 6
    P, x = _spd(rng, n), rng.normal(size=n)
    H = rng.normal(size=(m, n))
    R = 0.3 * _spd(rng, m)  # correlated components: not a sequence of independent scalars
    z = rng.normal(size=m)
    xr, Pr, _, Sr = update_joseph(x, P, z, H, R)
    xn, Pn = x.copy(), P.copy()
    S = update_vector_nb(xn, Pn, z - H @ x, H, R)
    np.testing.assert_allclose(xn, xr, rtol=1e-9, atol=1e-11)
    np.testing.assert_allclose(Pn, Pr, rtol=1e-8, atol=1e-10)
    np.testing.assert_allclose(S, Sr, rtol=1e-12)


def test_sparse_predict_matches_dense_predict() -> None:
    rng = np.random.default_rng(4)
    n = 14
    F = np.eye(n)
    F[0, 2], F[0, 3], F[1, 2], F[2, 4] = 0.3, 0.01, -0.2, 0.01  # a typical EKF Jacobian
    F[11, 11] = 0.99
    P, Q, x_next = _spd(rng, n), 0.01 * _spd(rng, n), rng.normal(size=n)
    xs, Ps = np.zeros(n), P.copy()
    predict_sparse_nb(xs, Ps, x_next, F, Q)
    _, Pr = predict(np.zeros(n), P, F, Q)
    np.testing.assert_allclose(Ps, Pr, rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(xs, x_next)


@pytest.mark.parametrize("n", [1, 4, 14])
def test_cholesky_kernel_matches_numpy(n: int) -> None:
    rng = np.random.default_rng(30 + n)
    A = _spd(rng, n)
    np.testing.assert_allclose(cholesky_nb(A), cholesky(A), rtol=1e-12, atol=1e-12)


def test_cholesky_kernel_of_semidefinite_matrix_reproduces_it() -> None:
    v = np.array([1.0, 2.0, -1.0])
    A = np.outer(v, v)  # rank one
    L = cholesky_nb(A)
    np.testing.assert_allclose(L @ L.T, A, atol=1e-12)


@pytest.mark.parametrize(
    ("gate", "huber", "expect_w"), [(np.inf, np.inf, 1.0), (np.inf, 1.0, None), (4.0, np.inf, 0.0)]
)
def test_robust_update_kernel_matches_reference_and_weights(gate: float, huber: float, expect_w: float | None) -> None:
    rng = np.random.default_rng(7)
    n = 4
    P, x, h = _spd(rng, n), rng.normal(size=n), rng.normal(size=n)
    r = 0.2
    innov = 4.0 * float(np.sqrt(h @ P @ h + r))  # a 4-sigma residual
    xr, Pr, sr, nr, wr = update_robust_scalar(x, P, innov, h, r, gate, huber)
    xn, Pn = x.copy(), P.copy()
    s, nis_k, w = update_robust_scalar_nb(xn, Pn, innov, h, r, gate, huber)
    assert nis_k == pytest.approx(16.0, rel=1e-12) == nr
    assert s == pytest.approx(sr, rel=1e-12)
    assert w == pytest.approx(wr, rel=1e-12)
    if expect_w is not None:
        assert w == expect_w
    else:  # Huber weight at 4 sigma with a 1-sigma threshold: 1/4
        assert w == pytest.approx(0.25, rel=1e-12)
    np.testing.assert_allclose(xn, xr, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(Pn, Pr, rtol=1e-9, atol=1e-11)


def test_nis_scalar_and_vector_forms() -> None:
    np.testing.assert_allclose(nis([2.0, np.nan, 1.0], [4.0, 1.0, 0.0]), [1.0, np.nan, np.nan])
    S = np.array([[[2.0, 0.5], [0.5, 1.0]]] * 2)
    nu = np.array([[1.0, -1.0], [np.nan, 0.0]])
    ref = float(nu[0] @ np.linalg.solve(S[0], nu[0]))
    out = nis(nu, S)
    assert out[0] == pytest.approx(ref) and np.isnan(out[1])


def _random_walk_filter(rng: np.random.Generator, n_rows: int) -> tuple[np.ndarray, ...]:
    """A seeded 2-state constant-velocity filter run, storing priors and posteriors."""
    dt = 0.1
    F = np.array([[1.0, dt], [0.0, 1.0]])
    Q = np.array([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]]) * 0.5
    H = np.array([[1.0, 0.0]])
    R = np.array([[0.4]])
    xt = np.zeros(2)
    x, P = np.zeros(2), np.eye(2)
    truth = np.empty((n_rows, 2))
    xm, Pm, xp, Pp = (np.empty((n_rows, 2)), np.empty((n_rows, 2, 2)), np.empty((n_rows, 2)),
                      np.empty((n_rows, 2, 2)))  # fmt: skip
    Lq = np.linalg.cholesky(Q)
    for k in range(n_rows):
        if k > 0:
            xt = F @ xt + Lq @ rng.normal(size=2)
            x, P = predict(x, P, F, Q)
        xm[k], Pm[k] = x, P
        z = H @ xt + np.sqrt(R[0, 0]) * rng.normal(size=1)
        x, P, _, _ = update_joseph(x, P, z, H, R)
        xp[k], Pp[k] = x, P
        truth[k] = xt
    Fs = np.broadcast_to(F, (n_rows, 2, 2)).copy()
    return xp, Pp, xm, Pm, Fs, truth


def test_rts_kernel_matches_numpy_and_beats_the_filter_on_truth() -> None:
    rng = np.random.default_rng(11)
    xp, Pp, xm, Pm, Fs, truth = _random_walk_filter(rng, 2000)
    xs, Ps = rts_smooth(xp, Pp, xm, Pm, Fs)
    xn, Pn = rts_smooth_nb(xp, Pp, xm, Pm, Fs)
    np.testing.assert_allclose(xn, xs, rtol=1e-9, atol=1e-10)
    np.testing.assert_allclose(Pn, Ps, rtol=1e-9, atol=1e-12)
    # the smoother uses the future too: its error is smaller than the filter's, and its own
    # covariance describes it (2000 rows, NEES per state near 1; 0.8-1.25 is ~5 sigma wide
    # for the effective ~400 independent samples)
    e_f = np.mean((xp - truth) ** 2, axis=0)
    e_s = np.mean((xs - truth) ** 2, axis=0)
    assert np.all(e_s < 0.8 * e_f)
    nees = np.mean((xs[:, 0] - truth[:, 0]) ** 2 / Ps[:, 0, 0])
    assert 0.75 < nees < 1.3


@pytest.mark.parametrize("n", [2, 5])
def test_scratch_space_kernels_match_the_allocating_ones(n: int) -> None:
    from sideslip.filters.kalman import predict_nb, predict_ws_nb, update_scalar_ws_nb

    rng = np.random.default_rng(40 + n)
    work = np.empty((2 * n + 2, n))
    for _ in range(5):
        P = _spd(rng, n)
        x = rng.normal(size=n)
        F = np.eye(n) + 0.1 * rng.normal(size=(n, n))
        Q = _spd(rng, n) * 0.01
        Gu = rng.normal(size=n)
        x1, P1, x2, P2 = x.copy(), P.copy(), x.copy(), P.copy()
        predict_nb(x1, P1, F, Q, Gu)
        predict_ws_nb(x2, P2, F, Q, Gu, work)
        np.testing.assert_allclose(x2, x1, rtol=1e-14, atol=1e-14)
        np.testing.assert_allclose(P2, P1, rtol=1e-13, atol=1e-14)
        h = rng.normal(size=n)
        innov, r = float(rng.normal()), float(rng.uniform(0.01, 2.0))
        s1 = update_scalar_nb(x1, P1, innov, h, r)
        s2 = update_scalar_ws_nb(x2, P2, innov, h, r, work)
        assert s2 == pytest.approx(s1, rel=1e-13)
        np.testing.assert_allclose(x2, x1, rtol=1e-12, atol=1e-13)
        np.testing.assert_allclose(P2, P1, rtol=1e-12, atol=1e-13)
