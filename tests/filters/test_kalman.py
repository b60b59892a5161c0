"""Every compiled Kalman kernel against its plain-numpy reference (seeded random SPD problems)."""

from __future__ import annotations

import numpy as np
import pytest

from sideslip.filters import kalman
from sideslip.filters.kalman import (
    NX_UNROLLED,
    cholesky_nb,
    pack_upper_nb,
    predict_nb,
    predict_rows_ws_nb,
    predict_sparse_nb,
    predict_ws_nb,
    rts_smooth_nb,
    rts_step_ws_nb,
    rts_workspace,
    unpack_upper_nb,
    update_robust_pair_ws_nb,
    update_robust_scalar_nb,
    update_robust_scalar_ws_nb,
    update_scalar_nb,
    update_scalar_ws_nb,
    update_vector_nb,
    workspace,
)
from sideslip.filters.reference import (
    cholesky,
    predict,
    rts_smooth,
    update_joseph,
    update_robust_pair,
    update_robust_scalar,
)
from sideslip.models.fused_process import NX_CORE, f_rows, process


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














def _spd(rng: np.random.Generator, n: int) -> np.ndarray:
    L = rng.normal(size=(n, n))
    return L @ L.T + 0.5 * np.eye(n)


@pytest.mark.parametrize("n", [1, 3, 8, 14, 15, 18])
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


@pytest.mark.parametrize("n", [1, 4, 14, 15, 18])
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


@pytest.mark.parametrize("n", [2, 5, 15, 18])
def test_scratch_space_kernels_match_the_allocating_ones(n: int) -> None:
    rng = np.random.default_rng(40 + n)
    work = workspace(n)
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


def _transition(rng: np.random.Generator) -> np.ndarray:
    """The fused estimator's process Jacobian at a random state (a typical sparse EKF F)."""
    x = rng.normal(0, 0.1, NX_CORE)
    x[3] = 15.0
    return process(x, np.array([0.1, 0.0, 0.0, 0.2, 2.0, 2.0]), 0.05, 0.01, 60.0)[1]


def test_row_sparse_prediction_equals_dense() -> None:
    rng = np.random.default_rng(0)
    P, F, q = _spd(rng, NX_CORE), _transition(rng), rng.uniform(0, 1e-3, NX_CORE)
    Pn, tmp = np.zeros_like(P), np.zeros_like(P)
    predict_rows_ws_nb(P, F, f_rows(NX_CORE), q, Pn, tmp)
    np.testing.assert_allclose(Pn, F @ P @ F.T + np.diag(q), rtol=1e-12, atol=1e-12)
    assert np.array_equal(Pn, Pn.T)


@pytest.mark.parametrize("sigmas", [1.0, 3.0, 10.0])
def test_inflating_update_matches_reference_and_scales_the_variance(sigmas: float) -> None:
    """Beyond ``inflate_nis`` the variance is r * nis / inflate_nis: a 10-sigma outlier moves
    the state by a 16/100 share of the plain update's gain, a 1-sigma one at full weight."""
    rng = np.random.default_rng(2)
    P, x = _spd(rng, NX_CORE), np.zeros(NX_CORE)
    h = np.zeros(NX_CORE)
    h[3] = 1.0
    r, inflate = 0.01, 16.0
    innov = sigmas * float(np.sqrt(P[3, 3] + r))
    xr, Pr, _, nr, wr = update_robust_scalar(x, P, innov, h, r, np.inf, np.inf, inflate)
    x1, P1 = x.copy(), P.copy()
    _, d2, w = update_robust_scalar_ws_nb(x1, P1, innov, h, r, np.inf, np.inf, inflate, workspace(NX_CORE))
    assert d2 == pytest.approx(sigmas**2) == pytest.approx(nr)
    assert w == pytest.approx(min(1.0, inflate / sigmas**2)) == pytest.approx(wr)
    assert x1[3] == pytest.approx(P[3, 3] / (P[3, 3] + r / w) * innov)
    np.testing.assert_allclose(x1, xr, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(P1, Pr, rtol=1e-9, atol=1e-11)


@pytest.mark.parametrize("scale", [0.1, 20.0])
def test_pair_update_equals_the_two_row_joseph_update(scale: float) -> None:
    rng = np.random.default_rng(5)
    P, x = _spd(rng, NX_CORE), rng.normal(size=NX_CORE)
    H = rng.normal(size=(2, NX_CORE))
    r, inflate = 0.05, 16.0
    nu = scale * rng.normal(size=2)
    xr, Pr, d2r = update_robust_pair(x, P, H, nu, r, inflate)
    x1, P1 = x.copy(), P.copy()
    d2 = update_robust_pair_ws_nb(x1, P1, H, nu[0], nu[1], r, inflate, workspace(NX_CORE))
    S = H @ P @ H.T + r * np.eye(2)
    assert d2 == pytest.approx(float(nu @ np.linalg.solve(S, nu)), rel=1e-10) == pytest.approx(d2r)
    np.testing.assert_allclose(x1, xr, rtol=1e-9, atol=1e-11)
    np.testing.assert_allclose(P1, Pr, rtol=1e-8, atol=1e-10)


def test_packed_float32_storage_round_trips_to_single_precision() -> None:
    rng = np.random.default_rng(3)
    P = _spd(rng, NX_CORE)
    packed = np.zeros(NX_CORE * (NX_CORE + 1) // 2, dtype=np.float32)
    pack_upper_nb(P, packed)
    out = np.zeros_like(P)
    unpack_upper_nb(packed, out)
    np.testing.assert_allclose(out, P, rtol=1e-6)
    np.testing.assert_array_equal(out, out.T)


def test_rts_step_equals_the_textbook_smoother() -> None:
    """Simon 2006 eq 9.99 written densely with numpy, on the fused model's sparse F."""
    rng = np.random.default_rng(4)
    P, F = _spd(rng, NX_CORE), _transition(rng)
    x = rng.normal(size=NX_CORE)
    Q = np.diag(rng.uniform(1e-4, 1e-3, NX_CORE))
    xn, Pn = F @ x, F @ P @ F.T + Q
    xs_next, Ps_next = xn + rng.normal(0, 0.1, NX_CORE), Pn * 0.5
    C = P @ F.T @ np.linalg.inv(Pn)
    x_ref = x + C @ (xs_next - xn)
    P_ref = P + C @ (Ps_next - Pn) @ C.T
    x2, P2 = x.copy(), P.copy()
    rts_step_ws_nb(x2, P2, xn, Pn, F, f_rows(NX_CORE), xs_next, Ps_next, rts_workspace(NX_CORE))
    np.testing.assert_allclose(x2, x_ref, rtol=1e-8, atol=1e-10)
    np.testing.assert_allclose(P2, P_ref, rtol=1e-7, atol=1e-10)
    assert np.array_equal(P2, P2.T)


@pytest.mark.parametrize("n", NX_UNROLLED)
def test_unrolled_kernels_are_bit_identical_to_the_general_loop(n: int) -> None:
    """The dispatchers pass ``n`` as a literal for these sizes; the bodies called from Python
    take it at run time (the general loop): the same operations, so the same bits."""
    rng = np.random.default_rng(n)
    P, Pn, Ps_next = _spd(rng, n), _spd(rng, n), _spd(rng, n)
    x, xn, xs_next, h = (rng.normal(size=n) for _ in range(4))
    B = 0.1 * rng.normal(size=(n, n))
    F = np.eye(n) + np.diag(0.1 * rng.normal(size=n - 1), 1)
    rows = np.full((n, n), -1, dtype=np.int64)
    kalman.nonzero_columns_nb(F, rows)
    pairs = []
    x1, P1, x2, P2 = x.copy(), P.copy(), x.copy(), P.copy()
    kalman.rts_update_ws_nb(x1, P1, xn, Pn, B, xs_next, Ps_next, np.zeros((n, n)))
    kalman._rts_update_ws_nb_n(x2, P2, xn, Pn, B, xs_next, Ps_next, np.zeros((n, n)), n)
    pairs += [(x1, x2), (P1, P2)]
    w1, w2 = np.zeros((2, n)), np.zeros((2, n))
    s1 = kalman.cross_covariance_nb(P, h, 0.3, w1)
    s2 = kalman._cross_covariance_nb_n(P, h, 0.3, w2, n)
    w1[1], w2[1] = w1[0] / s1, w2[0] / s2
    P1, P2 = P.copy(), P.copy()
    kalman.joseph_rank1_nb(P1, w1, s1)
    kalman._joseph_rank1_nb_n(P2, w2, s2, n)
    pairs += [(np.array([s1]), np.array([s2])), (P1, P2)]
    L1, L2 = np.zeros((n, n)), np.zeros((n, n))
    kalman.cholesky_ws_nb(Pn, L1)
    kalman._cholesky_ws_nb_n(Pn, L2, n)
    B1, B2 = P.copy(), P.copy()
    kalman.cho_solve_rows_ws_nb(L1, B1)
    kalman._cho_solve_rows_ws_nb_n(L2, B2, n, n)
    pairs += [(L1, L2), (B1, B2)]
    q = rng.uniform(0, 1e-3, n)
    Q1, Q2 = np.zeros((n, n)), np.zeros((n, n))
    kalman.predict_rows_ws_nb(P, F, rows, q, Q1, np.zeros((n, n)))
    kalman._predict_rows_ws_nb_n(P, F, rows, q, Q2, np.zeros((n, n)), n)
    pairs.append((Q1, Q2))
    for a, b in pairs:
        np.testing.assert_array_equal(a, b)
    np.testing.assert_allclose(B1, np.linalg.solve(Pn, P), rtol=1e-9, atol=1e-12)
