"""Banded chain least squares: assembly, Cholesky, selected inverse, fixed-lag marginalisation.

Every result is compared with the dense textbook computation (H = J' W J built row by row,
numpy solve/inverse) on small random chains; agreement to ~1e-10 is round-off for these
well-conditioned problems (condition numbers ~1e2-1e3).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import cholesky_banded

from sideslip.filters.banded import (
    assemble_chain,
    cholesky_band,
    fixed_lag_chain,
    selected_inverse,
    solve_band,
    solve_chain,
)


def _random_chain(rng: np.random.Generator, n: int, nx: int, m: int) -> tuple:
    F = rng.normal(size=(n - 1, nx, nx))
    g = rng.normal(size=(n - 1, nx))
    wq = rng.uniform(0.5, 2.0, size=(n - 1, nx))
    Hu = rng.normal(size=(n, m, nx))
    zu = rng.normal(size=(n, m))
    wu = rng.uniform(0.0, 2.0, size=(n, m))
    wu[rng.uniform(size=(n, m)) < 0.3] = 0.0  # absent factors
    L0 = rng.normal(size=(nx, nx))
    lam0 = L0 @ L0.T + nx * np.eye(nx)
    eta0 = rng.normal(size=nx)
    return F, g, wq, Hu, zu, wu, lam0, eta0


def _dense(F, g, wq, Hu, zu, wu, lam0, eta0):
    """Textbook normal equations: every factor row j with weight w adds w j j' and w j z."""
    n, m, nx = Hu.shape
    size = n * nx
    H = np.zeros((size, size))
    b = np.zeros(size)
    H[:nx, :nx] += lam0
    b[:nx] += eta0
    for k in range(n):
        for i in range(m):
            row = np.zeros(size)
            row[k * nx : (k + 1) * nx] = Hu[k, i]
            H += wu[k, i] * np.outer(row, row)
            b += wu[k, i] * row * zu[k, i]
    for k in range(n - 1):
        for c in range(nx):
            row = np.zeros(size)
            row[k * nx : (k + 1) * nx] = -F[k, c]
            row[(k + 1) * nx + c] = 1.0
            H += wq[k, c] * np.outer(row, row)
            b += wq[k, c] * row * g[k, c]
    return H, b


def _band_to_dense(ab):
    p1, size = ab.shape
    H = np.zeros((size, size))
    for d in range(p1):
        idx = np.arange(size - d)
        H[idx + d, idx] = ab[d, : size - d]
        H[idx, idx + d] = ab[d, : size - d]
    return H


@pytest.mark.parametrize("nx", [1, 2, 3])
def test_assembled_band_equals_dense_normal_equations(nx):
    rng = np.random.default_rng(nx)
    problem = _random_chain(rng, 9, nx, 3)
    ab, rhs = assemble_chain(*problem)
    H, b = _dense(*problem)
    assert ab.shape == (2 * nx, 9 * nx)
    np.testing.assert_allclose(_band_to_dense(ab), H, atol=1e-12)
    np.testing.assert_allclose(rhs, b, atol=1e-12)


def test_banded_solution_and_selected_inverse_equal_dense():
    rng = np.random.default_rng(7)
    problem = _random_chain(rng, 12, 2, 3)
    ab, rhs = assemble_chain(*problem)
    H, b = _dense(*problem)
    x, cb = solve_chain(ab, rhs)
    np.testing.assert_allclose(x, np.linalg.solve(H, b), rtol=1e-10, atol=1e-10)
    sb = selected_inverse(cb)
    S = np.linalg.inv(H)
    for d in range(sb.shape[0]):
        np.testing.assert_allclose(sb[d, : S.shape[0] - d], np.diag(S, -d), rtol=1e-9, atol=1e-12)


def test_numba_cholesky_equals_lapack_and_solves():
    rng = np.random.default_rng(3)
    problem = _random_chain(rng, 15, 2, 2)
    ab, rhs = assemble_chain(*problem)
    ref = cholesky_banded(ab, lower=True)
    cb = ab.copy()
    assert cholesky_band(cb)
    np.testing.assert_allclose(cb, ref, rtol=1e-12, atol=1e-12)
    H, b = _dense(*problem)
    np.testing.assert_allclose(solve_band(cb, rhs), np.linalg.solve(H, b), rtol=1e-10, atol=1e-10)


def test_solve_chain_in_place_gives_the_same_solution_and_reuses_the_arrays():
    rng = np.random.default_rng(9)
    ab, rhs = assemble_chain(*_random_chain(rng, 20, 2, 3))
    x, cb = solve_chain(ab.copy(), rhs.copy())
    ab2, rhs2 = ab.copy(), rhs.copy()
    x2, cb2 = solve_chain(ab2, rhs2, overwrite=True)
    assert cb2 is ab2 and x2 is rhs2
    np.testing.assert_array_equal(x2, x)
    np.testing.assert_array_equal(cb2, cb)
    np.testing.assert_allclose(cb, cholesky_banded(ab, lower=True), rtol=1e-12, atol=1e-12)


def test_numba_cholesky_reports_an_indefinite_matrix():
    ab = np.array([[1.0, -1.0], [0.0, 0.0]])  # diag(1, -1)
    assert not cholesky_band(ab)


def test_unobservable_chain_raises_linalg_error():
    # No prior, no unary factors: x_0 is free, H is singular.
    F = np.ones((2, 1, 1))
    g = np.zeros((2, 1))
    wq = np.ones((2, 1))
    Hu = np.zeros((3, 1, 1))
    zu = np.zeros((3, 1))
    wu = np.zeros((3, 1))
    ab, rhs = assemble_chain(F, g, wq, Hu, zu, wu, np.zeros((1, 1)), np.zeros(1))
    with pytest.raises(np.linalg.LinAlgError):
        solve_chain(ab, rhs)


@pytest.mark.parametrize("lag", [0, 1, 3, 5, 20])
def test_fixed_lag_equals_batch_on_data_up_to_k_plus_lag(lag):
    # Exact marginalisation: the window estimate of x_k equals the batch solution of the
    # problem truncated at k + lag (mean and marginal variance).
    rng = np.random.default_rng(11 + lag)
    n, nx = 14, 2
    F, g, wq, Hu, zu, wu, lam0, eta0 = _random_chain(rng, n, nx, 3)
    F *= 0.5  # keep the random dynamics tame so the comparison is well conditioned
    x, var, cov, ok, _, _ = fixed_lag_chain(F, g, wq, Hu, zu, wu, lam0, eta0, lag)
    assert ok and cov.shape == (n, nx - 1)
    for k in range(n):
        e = min(k + lag, n - 1)
        ab, rhs = assemble_chain(
            F[:e], g[:e], wq[:e], Hu[: e + 1], zu[: e + 1], wu[: e + 1], lam0, eta0
        )
        xb, cb = solve_chain(ab, rhs)
        sb = selected_inverse(cb)
        np.testing.assert_allclose(x[k], xb[k * nx : (k + 1) * nx], rtol=1e-9, atol=1e-10)
        np.testing.assert_allclose(var[k], sb[0, k * nx : (k + 1) * nx], rtol=1e-9, atol=1e-12)
        # the beta-r style covariance of the state's two components: S[2k + 1, 2k]
        np.testing.assert_allclose(cov[k, 0], sb[1, k * nx], rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("lag", [0, 2, 5])
def test_fixed_lag_streamed_in_chunks_equals_one_pass(lag):
    # The prior handed from chunk to chunk carries everything: chunked == whole, to round-off.
    rng = np.random.default_rng(21)
    n, nx = 40, 2
    F, g, wq, Hu, zu, wu, lam0, eta0 = _random_chain(rng, n, nx, 3)
    F *= 0.5
    whole, var_whole, _, ok, _, _ = fixed_lag_chain(F, g, wq, Hu, zu, wu, lam0, eta0, lag)
    assert ok
    lam, eta = lam0, eta0
    parts, var_parts = [], []
    for a in range(0, n, 7):
        b = min(a + 7, n)
        e = min(b + max(lag, 1), n)  # one row beyond the chunk carries the dynamic factor
        x, var, _, ok, lam, eta = fixed_lag_chain(
            F[a : e - 1], g[a : e - 1], wq[a : e - 1], Hu[a:e], zu[a:e], wu[a:e], lam, eta, lag,
            b - a,
        )  # fmt: skip
        assert ok and x.shape == (b - a, nx)
        parts.append(x)
        var_parts.append(var)
    np.testing.assert_allclose(np.vstack(parts), whole, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(np.vstack(var_parts), var_whole, rtol=1e-10, atol=1e-14)


def test_single_state_chain_is_prior_plus_measurements():
    # One scalar state, prior N(1, 1) and one measurement z = 3 with weight 1: mean 2, var 1/2.
    F = np.zeros((0, 1, 1))
    g = np.zeros((0, 1))
    wq = np.zeros((0, 1))
    Hu = np.ones((1, 1, 1))
    ab, rhs = assemble_chain(F, g, wq, Hu, np.array([[3.0]]), np.ones((1, 1)), np.eye(1), np.ones(1))
    x, cb = solve_chain(ab, rhs)
    assert x[0] == pytest.approx(2.0)
    assert selected_inverse(cb)[0, 0] == pytest.approx(0.5)
