"""Heading and gyro offset from GNSS Doppler course and the yaw gyro (seed 000, its ref [1]).

Least-squares fit of the integrated yaw rate to the Doppler course over the whole drive, with
iterative rejection of outliers (multipath), as in seed 000 ("we use least-squares fitting of
GNSS Doppler and IMU yaw-rate values ... a long time series ... removing outliers").

Model (heading of the body x axis, rad, unwrapped, from East counter-clockwise)::

    psi(t) = psi0 + (1 + s) I(t) - B(t),   I(t) = int_0^t w_h dt,   B(t) = int_0^t b(t') dt'

* ``w_h`` (rad/s): the z gyro projected on the vertical, ``wz / (cos(theta) cos(phi))`` (eq 3);
* ``b(t)`` (rad/s): gyro offset, measured minus true, piecewise linear between knots every
  ``knot_spacing_s`` (a random-walk prior on the knot differences lets a MEMS offset drift);
* ``s`` (-): gyro scale-factor correction, true rate = (1 + s) w_h - b (prior sigma 0.02), so a
  wrong gyro gain does not leak into the heading through every turn.

Parameter vector x = [psi0 (rad), s (-), b_0 ... b_M (rad/s)].  Measurements:

* Doppler course nu = atan2(v_n, v_e) at fresh GNSS samples (age 0) above ``min_speed``, turned
  by pi while reversing, minus the known part of the antenna's sideslip (``course_offset``:
  geometric lever-arm term and, on a second pass, the modelled slip; see ``doppler_slip``);
  1-sigma ``sigma_v / V`` (rad) with sigma_v from ``gnss_vel_std`` when present.
* Standstill: the gyro reads its offset alone, b(t) = wz (1-s block means).

Only low-lateral-acceleration samples are used (chosen by the caller), where the course equals
the heading up to a small, modelled sideslip.  Outliers: residuals beyond
``max(4 sigma_robust, 3 sigma_i)`` (sigma_robust = 1.4826 MAD) are dropped and the fit repeated
until the kept set no longer changes.  Residuals are re-wrapped about the prediction on every
pass, so a course sample off by 2 pi is an outlier, not a lap.

GNSS outages: the knots inside an outage are held by the random-walk prior (the offset carries
over), the heading is the integrated gyro.  Standstill: heading stays put (w_h - b ~ 0).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from sideslip import gnss
from sideslip.drive import Drive
from sideslip.errors import InputError
from sideslip.frames import wrap_angle
from sideslip.models.dead_reckoning import _cumtrapz

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]

HEADING_MIN_SPEED = 5.0  # m/s: Doppler course noise sigma_v/V is below ~1 deg above this
DEFAULT_VEL_STD = 0.1  # m/s: Doppler 1-sigma when the drive gives no gnss_vel_std
KNOT_SPACING_S = 60.0  # s between gyro-offset knots
DENSE_MAX_KNOTS = 128  # beyond (drives over ~2 h) the fit is solved sparse, O(knots)
BIAS_RW = 1.0e-4  # rad/s change of the offset per knot interval, 1-sigma (MEMS drift)
BIAS_PRIOR = 0.05  # rad/s, 1-sigma prior on the offset level (about 3 deg/s)
SCALE_PRIOR = 0.02  # 1-sigma prior on the gyro scale correction s
HEADING_CORR_S = 1.0  # s: one independent course residual per this time (for the 1-sigma of s)
SIGN_CHECK_SPACING_S = 1.0  # s: course changes over this long judge the gyro's sign (course noise)
# intervals the correlation needs: two unrelated series pass -0.5 by chance with probability
# about 1 % at 20 (a flipped gyro reads -0.96 or lower on every drive that turns)
SIGN_CHECK_MIN_INTERVALS = 20


@dataclass(frozen=True)
class CourseSamples:
    """Fresh Doppler course samples: rows, course (rad, heading sense), speed (m/s), sigma (rad)."""

    rows: IntArray
    course: FloatArray
    speed: FloatArray
    sigma: FloatArray


@dataclass(frozen=True)
class HeadingFit:
    """Result of :func:`fit_heading`.

    ``yaw`` (rad, unwrapped) and ``gyro_bias`` (rad/s, measured minus true) on every row;
    ``gyro_scale`` = 1 + s (multiplies the raw gyro); ``used`` the course samples kept (mask over
    the selected samples); ``good`` (mask over all samples) those within the outlier bound of
    the fitted heading; ``residual_std`` (rad) robust 1-sigma of the kept residuals.
    """

    yaw: FloatArray
    gyro_bias: FloatArray
    gyro_scale: float
    yaw0: float
    knots_t: FloatArray
    knots_bias: FloatArray
    used: NDArray[np.bool_]
    good: NDArray[np.bool_]
    residual_std: float
    iterations: int
    gyro_scale_sigma: float = float("inf")

    def params(self) -> dict[str, float | int]:
        # naming convention: scale factors as measured/true; ``gyro_scale_correction`` is the
        # multiplier applied to the raw gyro (true/measured)
        measured_over_true = 1.0 / self.gyro_scale
        return {
            "gyro_scale": measured_over_true,
            "gyro_scale_sigma": self.gyro_scale_sigma * measured_over_true**2,
            "gyro_scale_correction": self.gyro_scale,
            "gyro_bias_mean_rad_s": float(np.mean(self.knots_bias)),
            "gyro_bias_rad_s": float(np.mean(self.knots_bias)),
            "heading_samples_used": int(self.used.sum()),
            "heading_samples_rejected": int((~self.used).sum()),
            "heading_residual_std_deg": float(np.degrees(self.residual_std)),
            "heading_iterations": self.iterations,
        }


def course_samples(
    drive: Drive, signed_speed: FloatArray, min_speed: float = HEADING_MIN_SPEED
) -> CourseSamples:
    """Fresh Doppler samples above ``min_speed``; course turned by pi where ``signed_speed`` < 0.

    Taken from the GNSS layer (:func:`sideslip.gnss.course_samples`: Doppler only, the speed
    confirmed by ``signed_speed``, its course 1-sigma model and receiver-sigma gate).
    """
    cs = gnss.course_samples(drive, signed_speed, min_speed, use_positions=False)
    return CourseSamples(cs.rows, cs.course, cs.speed, cs.sigma)


def check_yaw_rate_sign(
    t: FloatArray, wz: FloatArray, samples: CourseSamples, path: str, min_turn_rad: float = 1.5,
    spacing_s: float = SIGN_CHECK_SPACING_S,
) -> float | None:
    """Fail when the yaw gyro turns the opposite way to the GNSS course
    (:func:`yaw_rate_course_correlation` below -0.5): :class:`InputError` naming column
    ``wz``; returns the correlation, or None where the drive cannot tell."""
    corr = yaw_rate_course_correlation(t, wz, samples, min_turn_rad, spacing_s)
    if corr is not None and corr < -0.5:
        raise InputError(
            path,
            f"yaw rate turns opposite to the GNSS course (correlation {corr:.2f}): expected wz "
            "> 0 in a left turn (ISO 8855, z up); is the gyro axis flipped?",
            column="wz",
        )
    return corr


def yaw_rate_course_correlation(
    t: FloatArray, wz: FloatArray, samples: CourseSamples, min_turn_rad: float = 1.5,
    spacing_s: float = SIGN_CHECK_SPACING_S,
) -> float | None:
    """How the yaw gyro's turns follow the GNSS course's.

    Compares course changes between fresh samples ``spacing_s`` or more apart (at most 2.5x
    that) with the integrated ``wz`` over the same interval: their correlation with both means
    removed (a raw gyro's bias adds the same turn to every interval).  Returns it, or None
    when the drive turns too little to judge (total |course change| below ``min_turn_rad``,
    or fewer than :data:`SIGN_CHECK_MIN_INTERVALS` intervals).  Over consecutive 10 Hz epochs
    a gentle drive's course noise hid the sign (a flipped gyro
    on the simulated highway: -0.49); over 1 s it reads -0.98.
    """
    rows = samples.rows
    if rows.size < 3:
        return None
    tc = t[rows]
    keep = [0]
    for i in range(1, rows.size):  # one sample per spacing_s
        if tc[i] - tc[keep[-1]] >= spacing_s:
            keep.append(i)
    k = np.asarray(keep)
    dt = np.diff(tc[k])
    dcourse = wrap_angle(np.diff(samples.course[k]))
    turned = _cumtrapz(t, np.nan_to_num(wz))
    dgyro = np.diff(turned[rows[k]])
    ok = (dt <= 2.5 * max(spacing_s, 0.4)) & (np.abs(dcourse) < 0.5)
    if ok.sum() < SIGN_CHECK_MIN_INTERVALS or np.abs(dcourse[ok]).sum() < min_turn_rad:
        return None
    a, b = dcourse[ok] - dcourse[ok].mean(), dgyro[ok] - dgyro[ok].mean()
    denom = np.sqrt(np.sum(a * a) * np.sum(b * b))
    return float(np.sum(a * b) / denom) if denom > 0 else 0.0


def knot_times(t0: float, t1: float, spacing: float) -> FloatArray:
    """Evenly spread knots covering [t0, t1] at most ``spacing`` apart (at least two)."""
    count = max(int(np.ceil((t1 - t0) / spacing)), 1) + 1
    return np.linspace(t0, t1, count)


def _hat_parts(t: FloatArray, knots: FloatArray) -> tuple[NDArray[np.intp], FloatArray, FloatArray]:
    """Interval j of each t (knots[j] <= t < knots[j+1], clipped) and its h = t - knots[j], Delta_j."""
    j = np.clip(np.searchsorted(knots, t, side="right") - 1, 0, knots.size - 2)
    h = np.clip(t - knots[j], 0.0, None)
    return j, h, knots[j + 1] - knots[j]


def _two_per_row(j: NDArray[np.intp], a: FloatArray, b: FloatArray, m: int) -> sp.csr_matrix:
    """(n, m) sparse matrix with ``a`` in column j and ``b`` in column j + 1 of each row."""
    n = j.size
    rows = np.repeat(np.arange(n), 2)
    cols = np.stack([j, j + 1], axis=1).ravel()
    vals = np.stack([a, b], axis=1).ravel()
    return sp.csr_matrix((vals, (rows, cols)), shape=(n, m))


def hat_values_sparse(t: FloatArray, knots: FloatArray) -> sp.csr_matrix:
    """(n, M) sparse values of the piecewise-linear hat functions on ``knots`` at ``t``."""
    j, h, dk = _hat_parts(np.clip(t, knots[0], knots[-1]), knots)
    w = np.clip(h / dk, 0.0, 1.0)
    return _two_per_row(j, 1.0 - w, w, knots.size)


def hat_values(t: FloatArray, knots: FloatArray) -> FloatArray:
    """(n, M) values of the piecewise-linear hat functions on ``knots`` at times ``t``."""
    return np.asarray(hat_values_sparse(t, knots).toarray(), dtype=float)


def knot_cumulative(knots: FloatArray) -> FloatArray:
    """(M, M) Q with (Q v)_k = int_{knots[0]}^{knots[k]} b dt, b piecewise linear through v."""
    m = knots.size
    half = 0.5 * np.diff(knots)
    step = np.zeros((m - 1, m))
    step[np.arange(m - 1), np.arange(m - 1)] = half
    step[np.arange(m - 1), np.arange(1, m)] += half
    return np.vstack([np.zeros((1, m)), np.cumsum(step, axis=0)])


def hat_integral_parts(t: FloatArray, knots: FloatArray) -> tuple[sp.csr_matrix, sp.csr_matrix]:
    """Sparse (R, D), each (n, M), with hat_integrals(t, knots) = R @ knot_cumulative(knots) + D.

    R picks the knot interval of each t; D holds the partial integral inside it (two
    entries a row), so the design of the heading fit never needs its dense (n, M) form.
    """
    j, h, dk = _hat_parts(t, knots)
    n, m = t.size, knots.size
    pick = sp.csr_matrix((np.ones(n), (np.arange(n), j)), shape=(n, m))
    return pick, _two_per_row(j, h - 0.5 * h * h / dk, 0.5 * h * h / dk, m)


def hat_integrals(t: FloatArray, knots: FloatArray) -> FloatArray:
    """(n, M) integrals from knots[0] to t of the hat functions on ``knots`` (exact)."""
    pick, part = hat_integral_parts(t, knots)
    return np.asarray(pick @ knot_cumulative(knots) + part.toarray(), dtype=float)


def _bias_integral_rows(t: FloatArray, knots: FloatArray, values: FloatArray) -> FloatArray:
    """B(t) = int_{knots[0]}^t b dt with b piecewise linear through (knots, values); O(n)."""
    at_knots = np.concatenate(([0.0], np.cumsum(0.5 * (values[1:] + values[:-1]) * np.diff(knots))))
    j = np.clip(np.searchsorted(knots, t, side="right") - 1, 0, knots.size - 2)
    h = np.clip(t - knots[j], 0.0, None)
    slope = (values[j + 1] - values[j]) / (knots[j + 1] - knots[j])
    out = at_knots[j] + values[j] * h + 0.5 * slope * h * h
    return np.asarray(out, dtype=float)


def knot_constraints(knots: FloatArray) -> sp.csr_matrix:
    """(M, 2 + 2M) E with E z = 0 iff z's integrals c equal Q kb (:func:`knot_cumulative`).

    z = [psi0, s, c_0..c_{M-1}, kb_0..kb_{M-1}]: c_0 = 0 and
    c_k - c_{k-1} - (kb_{k-1} + kb_k) Delta_{k-1} / 2 = 0 (the trapezoid of b), a band.
    """
    m = knots.size
    half = 0.5 * np.diff(knots)
    k = np.arange(1, m)
    rows = np.concatenate(([0], k, k, k, k))
    cols = np.concatenate(([2], 2 + k, 1 + k, 2 + m + k - 1, 2 + m + k))
    vals = np.concatenate(([1.0], np.ones(m - 1), -np.ones(m - 1), -half, -half))
    return sp.csr_matrix((vals, (rows, cols)), shape=(m, 2 + 2 * m))


@dataclass(frozen=True)
class _SparseSolution:
    """Solution of the heading fit's normal equations in z-space, and its factorisation."""

    x: FloatArray
    lu: object
    scale: FloatArray

    def var(self, i: int) -> float:
        """(N^-1)_ii of the x-space normal matrix (i < 2: psi0 or s)."""
        e = np.zeros(self.scale.size)
        e[i] = 1.0 / self.scale[i]
        return float(self.lu.solve(e)[i] / self.scale[i])  # type: ignore[attr-defined]


def _solve_sparse(G: sp.spmatrix, E: sp.csr_matrix, rhs: FloatArray, m: int) -> _SparseSolution:
    """min |Z z - v|^2 + fixed terms subject to E z = 0, through the sparse KKT system.

    ``G`` = Z^T Z + fixed terms (z-space), ``rhs`` = Z^T v + fixed terms.  The same solution
    as the dense x-space normal equations, in O(knots) instead of O(knots^3); the z columns
    are scaled to unit diagonal as in :func:`_solve_normal`.  ``m``: the knots, z = [psi0, s,
    c (m), kb (m), nuisance]; x = [psi0, s, kb, nuisance].
    """
    from scipy.sparse.linalg import splu

    n_z, n_c = G.shape[0], E.shape[0]
    # a variable nothing observes (psi0 without a course sample) is set to 0, as the dense
    # solve's minimum-norm fallback does
    # (only psi0 and s: the integrals c have no diagonal of their own at the last knot but are
    # fixed by E; the knots' offsets always have their priors)
    unseen = np.zeros(n_z, dtype=bool)
    unseen[:2] = G.diagonal()[:2] <= 0.0
    if unseen.any():
        G = G + sp.diags(unseen.astype(float))
    d = np.sqrt(np.clip(G.diagonal(), 1e-300, None))
    scale = np.concatenate((d, np.ones(n_c)))
    Dinv = sp.diags(1.0 / scale)
    K = (Dinv @ sp.bmat([[G, E.T], [E, None]]) @ Dinv).tocsc()
    lu = splu(K)
    sol = lu.solve(np.concatenate((rhs, np.zeros(n_c))) / scale) / scale
    x = np.concatenate((sol[:2], sol[2 + m:n_z]))
    return _SparseSolution(np.asarray(x, dtype=float), lu, scale)


def _solve_normal(N: FloatArray, g: FloatArray) -> FloatArray:
    """Solve the normal equations N x = g (symmetric, positive definite thanks to the priors).

    The design is tall (GNSS epochs x ~2 + drive/60 s), so its Gram matrix is formed once per
    fit and only the rejected rows are taken out per pass (much cheaper than an SVD per pass).
    Columns are scaled to unit diagonal; an ill-conditioned system falls back to lstsq.
    """
    d = np.sqrt(np.clip(np.diag(N), 1e-300, None))
    Ns = N / np.outer(d, d)
    gs = g / d
    try:
        if np.linalg.cond(Ns) > 1e12:
            raise np.linalg.LinAlgError("ill-conditioned")
        L = np.linalg.cholesky(Ns)
        z = np.linalg.solve(L.T, np.linalg.solve(L, gs))
    except np.linalg.LinAlgError:
        z = np.linalg.lstsq(Ns, gs, rcond=None)[0]
    return np.asarray(z / d, dtype=float)


def fit_heading(
    t: FloatArray,
    rate_h: FloatArray,
    samples: CourseSamples,
    select: NDArray[np.bool_],
    course_offset: FloatArray | None = None,  # per sample (all samples, not only selected)
    still_rows: IntArray | None = None,
    wz_raw: FloatArray | None = None,
    nuisance: FloatArray | None = None,  # per sample (all samples)
    nuisance_sigma: float = float("inf"),
    knot_spacing_s: float = KNOT_SPACING_S,
    bias_rw: float = BIAS_RW,
    max_iter: int = 10,
) -> HeadingFit:
    """Fit psi0, s and the offset knots to the Doppler course; see the module docstring.

    ``rate_h``: vertical-projected raw gyro rate w_h on every row (rad/s, NaN-free).
    ``select``: which of ``samples`` may enter the fit (e.g. low lateral acceleration).
    ``course_offset``: rad per sample, subtracted from the course (antenna sideslip model).
    ``still_rows``/``wz_raw``: standstill rows and the raw gyro, for offset pseudo-measurements.
    ``nuisance``: a regressor per sample whose coefficient (prior 1-sigma ``nuisance_sigma``)
    joins the fit, e.g. the yaw acceleration for the transient sideslip the caller's model
    leaves out; where it moves with the integrated gyro (a slalom) it takes ``s``'s place, so
    ``s`` falls back to its prior instead of absorbing the model's error.
    With no usable course sample, the heading is the integrated gyro from 0 with the
    standstill offset (or 0) and the fit reports ``residual_std`` = inf.
    """
    t = np.asarray(t, dtype=float)
    knots = knot_times(float(t[0]), float(t[-1]), knot_spacing_s)
    M = knots.size
    integ = _cumtrapz(t, rate_h)
    idx = np.flatnonzero(select)
    rows = samples.rows[idx]
    y = samples.course[idx] - (course_offset[idx] if course_offset is not None else 0.0)
    sig = samples.sigma[idx]
    i_meas = integ[rows]
    n_aux = 1 if nuisance is not None else 0
    aux = nuisance[idx] if nuisance is not None else np.zeros(idx.size)
    # the design [1, i, -hat_integrals] / sigma = Z @ T with Z sparse (a few entries a row)
    # and T = [[I2, 0], [0, Q], [0, I_M]]: every product below is O(epochs + M^2), never the
    # dense (epochs, M) matrix (whose Gram matrix made the fit quadratic in the drive's length)
    pick, part = hat_integral_parts(t[rows], knots)
    sparse_path = M > DENSE_MAX_KNOTS
    Q = knot_cumulative(knots) if not sparse_path else np.zeros((0, M))
    inv_sig = sp.diags(1.0 / sig)
    columns = [sp.csr_matrix(np.column_stack([np.ones(rows.size), i_meas]) / sig[:, None]),
               -(inv_sig @ pick), -(inv_sig @ part)]
    if n_aux:
        columns.append(sp.csr_matrix((aux / sig)[:, None]))
    Z = sp.hstack(columns).tocsr()
    T = np.zeros((2 + 2 * M + n_aux, 2 + M + n_aux) if not sparse_path else (0, 0))
    if not sparse_path:
        T[0, 0] = T[1, 1] = 1.0
        T[2:2 + M, 2:2 + M] = Q
        T[2 + M:2 + 2 * M, 2:2 + M] = np.eye(M)
        if n_aux:
            T[-1, -1] = 1.0

    def gram(z: sp.csr_matrix) -> FloatArray:
        return np.asarray(T.T @ (z.T @ z).toarray() @ T, dtype=float)

    def predict(x: FloatArray) -> FloatArray:
        kb = x[2:2 + M]
        cum = (Q @ kb if not sparse_path else
               np.concatenate(([0.0], np.cumsum(0.5 * (kb[1:] + kb[:-1]) * np.diff(knots)))))
        out = x[0] + x[1] * i_meas - (pick @ cum + part @ kb)
        return np.asarray(out + (x[-1] * aux if n_aux else 0.0), dtype=float)
    # standstill pseudo-measurements of the offset: 1-s block means of the raw gyro
    st_hat = sp.csr_matrix((0, M))
    st_y = np.zeros(0)
    st_sig = np.zeros(0)
    if still_rows is not None and wz_raw is not None and still_rows.size > 10:
        blocks = np.floor((t[still_rows] - t[0]) / 1.0).astype(np.intp)
        _uniq, inv, counts = np.unique(blocks, return_inverse=True, return_counts=True)
        sums = np.bincount(inv, weights=wz_raw[still_rows])
        tsum = np.bincount(inv, weights=t[still_rows])
        keep = counts >= 5
        means = sums[keep] / counts[keep]
        tb = tsum[keep] / counts[keep]
        noise = float(np.std(wz_raw[still_rows])) if still_rows.size > 1 else 1e-3
        st_hat = hat_values_sparse(tb, knots)
        st_y = means
        st_sig = np.full(means.size, max(noise, 1e-5)) / np.sqrt(counts[keep]) + 2e-5
    # priors: offset level, random walk between knots, scale correction
    P = np.zeros((M + 1 + n_aux, 2 + M + n_aux))
    p_sig = np.zeros(M + 1 + n_aux)
    P[0, 1] = 1.0
    p_sig[0] = SCALE_PRIOR
    P[1, 2] = 1.0
    p_sig[1] = BIAS_PRIOR
    for j in range(M - 1):
        P[2 + j, 2 + j] = -1.0
        P[2 + j, 3 + j] = 1.0
        p_sig[2 + j] = bias_rw * np.sqrt((knots[j + 1] - knots[j]) / knot_spacing_s)
    if n_aux:
        P[-1, -1] = 1.0
        p_sig[-1] = nuisance_sigma if np.isfinite(nuisance_sigma) else 1e6
    p_y = np.zeros(M + 1 + n_aux)

    used = np.ones(rows.size, dtype=bool)
    x = np.zeros(2 + M + n_aux)
    if still_rows is not None and st_y.size:
        x[2:2 + M] = float(np.median(st_y))
    # initial unwrap: the course relative to the integrated gyro drifts slowly
    d = np.unwrap(wrap_angle(y - i_meas)) + i_meas if rows.size else y
    resid_std = np.inf
    iterations = 0
    S = sp.diags(1.0 / st_sig) @ st_hat
    Pw = sp.csr_matrix(P / p_sig[:, None])
    N_fixed_sp = (Pw.T @ Pw + sp.block_diag([sp.csr_matrix((2, 2)), S.T @ S,
                                             sp.csr_matrix((n_aux, n_aux))])).tocsr()
    g_fixed = np.asarray(Pw.T @ (p_y / p_sig), dtype=float)
    g_fixed[2:2 + M] += S.T @ (st_y / st_sig)
    if sparse_path:
        # x = Sel z: psi0, s, the knots' offsets kb (and the nuisance) out of
        # z = [psi0, s, c, kb(, nuisance)]
        n_x = 2 + M + n_aux
        sel = sp.csr_matrix((np.ones(n_x), (np.arange(n_x), np.concatenate(
            ([0, 1], 2 + M + np.arange(M + n_aux))))), shape=(n_x, 2 + 2 * M + n_aux))
        G_fixed = sel.T @ N_fixed_sp @ sel
        E = knot_constraints(knots)
        if n_aux:
            E = sp.hstack([E, sp.csr_matrix((E.shape[0], n_aux))]).tocsr()
        N_all = np.zeros((0, 0))
        N = N_all
    else:
        N_fixed = np.asarray(N_fixed_sp.toarray(), dtype=float)
        N_all = gram(Z)
    solution: _SparseSolution | None = None
    for iterations in range(1, max_iter + 1):  # noqa: B007
        v_used = Z.T @ np.where(used, (d - i_meas) / sig, 0.0)
        if sparse_path:
            Zu = Z[used] if rows.size else Z
            solution = _solve_sparse(G_fixed + Zu.T @ Zu, E, sel.T @ g_fixed + v_used, M)
            x = solution.x
        else:
            out = ~used
            N = N_fixed + N_all - (gram(Z[out]) if out.any() else 0.0)
            x = _solve_normal(N, g_fixed + T.T @ v_used)
        if rows.size == 0:
            break
        pred = predict(x) + i_meas
        res = wrap_angle(y - pred)
        d = pred + res  # re-wrap about the prediction
        kept = res[used]
        resid_std = 1.4826 * float(np.median(np.abs(kept - np.median(kept)))) if kept.size else np.inf
        new_used = np.abs(res) <= np.maximum(4.0 * max(resid_std, 1e-4), 3.0 * sig)
        if new_used.sum() < 3 or np.array_equal(new_used, used):
            break
        used = new_used
    psi0, s = float(x[0]), float(x[1])
    kb = x[2:2 + M]
    # 1-sigma of s: the normal matrix's inverse, scaled by the kept residuals' excess over
    # their assumed sigma and by sqrt(epochs per HEADING_CORR_S) for their correlation
    s_sigma = float("inf")
    if rows.size and used.sum() > 3:
        try:
            cov_ss = solution.var(1) if solution is not None else float(np.linalg.inv(N)[1, 1])
        except (np.linalg.LinAlgError, RuntimeError):
            cov_ss = float("inf")
        z = (wrap_angle(y - (predict(x) + i_meas)) / sig)[used]
        excess = max(float(np.mean(z * z)), 1.0)
        span = max(float(t[rows[-1]] - t[rows[0]]), 1e-6)
        corr = max(float(used.sum()) / span * HEADING_CORR_S, 1.0)
        s_sigma = float(np.sqrt(max(cov_ss, 0.0) * excess * corr))
    yaw = psi0 + (1.0 + s) * integ - _bias_integral_rows(t, knots, kb)
    bias = np.interp(t, knots, kb)
    y_all = samples.course - (course_offset if course_offset is not None else 0.0)
    res_all = wrap_angle(y_all - yaw[samples.rows])
    bound = np.maximum(4.0 * max(resid_std if np.isfinite(resid_std) else 0.0, 1e-4), 3.0 * samples.sigma)
    good = np.abs(res_all) <= bound
    # report the offset in raw-gyro units: w_true = (1+s) w - b  ->  offset = b / (1+s)
    return HeadingFit(
        yaw=np.asarray(yaw, dtype=float),
        gyro_bias=np.asarray(bias / (1.0 + s), dtype=float),
        gyro_scale=1.0 + s,
        yaw0=psi0,
        knots_t=knots,
        knots_bias=kb / (1.0 + s),
        used=used,
        good=good,
        residual_std=resid_std,
        iterations=iterations,
        gyro_scale_sigma=s_sigma,
    )
