"""Compiled per-row passes of the seed-002 graph (:mod:`sideslip.methods.factor_graph`): the
chain factors from the single-track model's matrices, and the reported 1-sigma.

Each is one loop over the drive's rows with no temporaries (the numpy form of the same
arithmetic made several full-length passes); the factors are those of the factor graph's
module docstring (Leanza, Reina, Blanco-Claraco 2021, seed 002, eqs 6-7, 16).
"""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import NDArray

from sideslip.models.single_track import single_track_row

FloatArray = NDArray[np.float64]


@numba.njit(cache=True)
def chain_factors(
    t: FloatArray,
    v_dyn: FloatArray,
    v_meas: FloatArray,
    model: FloatArray,
    delta: FloatArray,
    low: NDArray[np.bool_],
    gap: NDArray[np.bool_],
    wz: NDArray[np.floating],
    ay: NDArray[np.floating],
    sigmas: FloatArray,
    reference_dt: float,
    low_speed_inflation: float,
    prior_beta: float,
    prior_yaw_rate: float,
    low_speed_beta: float,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    """The chain factors of :func:`sideslip.methods.factor_graph.build_graph` in one pass over
    the rows (layout of :class:`~sideslip.methods.factor_graph.SideslipGraph`; the low-speed
    factor's value is filled by the caller).

    ``model`` = [m, I_z, l_f, l_r, c_f, c_r, v_min]: the single-track matrices
    (:func:`sideslip.models.single_track.single_track_row`) row by row, A and B at the
    dynamics' speed ``v_dyn``, C and D at the a_y factor's ``v_meas`` (both clamped at v_min),
    never stored for the whole drive.

    Dynamic factor k: F = I + dt A_k, g = dt B_k delta_k (forward Euler, paper eq 6), sigmas
    ``sigmas[:2]`` x sqrt(dt / reference_dt), x ``low_speed_inflation`` below the speed gate;
    across a time gap F = 0, g = 0 and the prior's sigmas (a restart).  Unary factors: yaw
    rate r_k = wz_k (sigma ``sigmas[2]``), a_y: C_k x_k = ay_k - D_k delta_k above the gate
    (``sigmas[3]``), low-speed beta (``low_speed_beta``) below it; sigma inf where absent.
    """
    n = t.size
    m, iz, lf, lr, cf, cr, v_min = model[0], model[1], model[2], model[3], model[4], model[5], model[6]
    A = np.empty((2, 2))
    B = np.empty((2, 2))
    C = np.empty((2, 2))
    D = np.empty((2, 2))
    F = np.empty((n - 1, 2, 2))
    g = np.empty((n - 1, 2))
    sigma_q = np.empty((n - 1, 2))
    for k in range(n - 1):
        if gap[k]:
            F[k] = 0.0
            g[k] = 0.0
            sigma_q[k, 0] = prior_beta
            sigma_q[k, 1] = prior_yaw_rate
            continue
        dt = t[k + 1] - t[k]
        single_track_row(m, iz, lf, lr, cf, cr, max(abs(v_dyn[k]), v_min), A, B, C, D)
        for i in range(2):
            for j in range(2):
                F[k, i, j] = dt * A[i, j] + (1.0 if i == j else 0.0)
            g[k, i] = dt * B[i, 0] * delta[k]
        scale = np.sqrt(dt / reference_dt)
        for i in range(2):
            sigma_q[k, i] = sigmas[i] * scale
            if low[k]:
                sigma_q[k, i] *= low_speed_inflation
    Hu = np.zeros((n, 3, 2))
    zu = np.zeros((n, 3))
    sigma_u = np.full((n, 3), np.inf)
    for k in range(n):
        single_track_row(m, iz, lf, lr, cf, cr, max(abs(v_meas[k]), v_min), A, B, C, D)
        Hu[k, 0, 1] = 1.0
        Hu[k, 1, 0] = C[1, 0]
        Hu[k, 1, 1] = C[1, 1]
        Hu[k, 2, 0] = 1.0
        if np.isfinite(wz[k]):
            zu[k, 0] = wz[k]
            sigma_u[k, 0] = sigmas[2]
        if low[k]:
            sigma_u[k, 2] = low_speed_beta
        elif np.isfinite(ay[k]):
            zu[k, 1] = ay[k] - D[1, 0] * delta[k]
            sigma_u[k, 1] = sigmas[3]
    return F, g, sigma_q, Hu, zu, sigma_u


@numba.njit(cache=True)
def one_sigma(
    x: FloatArray,
    var: FloatArray,
    inflation: FloatArray,
    delta: FloatArray,
    v: FloatArray,
    lf: float,
    lr: float,
    stiffness_rel_sigma: float,
    health: FloatArray,
    limit_rel_sigma: float,
    offset_beta_sigma: float,
) -> tuple[FloatArray, FloatArray]:
    """1-sigma of beta and r, one pass per row: the solver's variances (clipped at 0) times
    the consistency ``inflation`` (empty: none), plus for beta (s x the larger axle slip
    angle)^2 with alpha_f = delta - beta - lf r / V, alpha_r = lr r / V - beta at the a_y
    factor's speed V and s = hypot(stiffness_rel_sigma, health x limit_rel_sigma) (``health``
    empty: 0; :mod:`sideslip.methods.factor_graph`)."""
    n = x.shape[0]
    beta_std = np.empty(n)
    r_std = np.empty(n)
    inflate = inflation.size > 0
    limit = health.size > 0 and limit_rel_sigma > 0.0
    for k in range(n):
        vb = var[k, 0] if not var[k, 0] < 0.0 else 0.0
        vr = var[k, 1] if not var[k, 1] < 0.0 else 0.0
        if inflate:
            vb = vb * inflation[k]
            vr = vr * inflation[k]
        rel2 = stiffness_rel_sigma * stiffness_rel_sigma
        if limit:
            rel2 += (health[k] * limit_rel_sigma) ** 2
        if rel2 > 0.0:
            alpha_r = lr * x[k, 1] / v[k] - x[k, 0]
            alpha_f = delta[k] - x[k, 0] - lf * x[k, 1] / v[k]
            a = max(abs(alpha_f), abs(alpha_r))
            vb += rel2 * a * a
        vb += offset_beta_sigma * offset_beta_sigma
        beta_std[k] = np.sqrt(vb)
        r_std[k] = np.sqrt(vr)
    return beta_std, r_std


@numba.njit(cache=True)
def band_marginals(cb: FloatArray, nx: int) -> tuple[FloatArray, FloatArray]:
    """Marginal variances (N, nx) and the covariance of each state's first two components
    (N,) from the lower Cholesky band ``cb`` of the chain's normal matrix: the Takahashi
    recursion of :func:`sideslip.filters.banded.selected_inverse` with the same arithmetic,
    keeping only the p + 1 columns of the inverse's band it still reads (a ring) instead of
    the whole band, so the memory is that of the outputs."""
    p = cb.shape[0] - 1
    n = cb.shape[1]
    w = p + 1
    ring = np.zeros((p + 1, w))  # ring[d, col % w] = S[col + d, col]
    var = np.empty((n // nx, nx))
    cov = np.empty(n // nx)
    for j in range(n - 1, -1, -1):
        m = min(p, n - 1 - j)
        ljj = cb[0, j]
        col = j % w
        for a in range(1, m + 1):
            i = j + a
            s = 0.0
            for c in range(1, m + 1):
                k = j + c
                if i >= k:
                    sik = ring[i - k, k % w]
                else:
                    sik = ring[k - i, i % w]
                s += cb[c, j] * sik
            ring[a, col] = -s / ljj
        for a in range(m + 1, p + 1):
            ring[a, col] = 0.0
        s = 0.0
        for c in range(1, m + 1):
            s += cb[c, j] * ring[c, col]
        ring[0, col] = 1.0 / (ljj * ljj) - s / ljj
        var[j // nx, j % nx] = ring[0, col]
        if j % nx == 0:
            cov[j // nx] = ring[1, col]
    return var, cov
