"""Least-squares numerics of the calibration: priors, nuisance windows, honest 1-sigma.

Every relation the calibration fits is (or is linearised to) ``y = X theta + e`` on a set of
gated rows.  The residuals ``e`` are not white: model error (tyres leaving their linear range,
bank, load transfer) is correlated over seconds.  The 1-sigma therefore comes from a
*cluster-robust* (sandwich) covariance with clusters of consecutive rows (blocks of
``BLOCK_S`` seconds): ``cov = B (sum_g X_g' W e_g e_g' W X_g + P^-1) B`` with
``B = (X' W X + P^-1)^-1``, scaled by ``G / (G - p)`` for ``G`` clusters and ``p`` parameters
(Cameron & Miller, "A practitioner's guide to cluster-robust inference", J. Human Resources
50(2), 2015, eq 11 and sec. VI.C).  ``P`` is the prior covariance: a parameter the rows do not
inform keeps its prior value and prior sigma, which is how the calibration tells what the drive
could not say (:func:`informed`).

Nuisance windows: the GNSS relations carry an unknown heading offset (and a slow gyro-bias
drift) that is constant (linear) over a window of ``WINDOW_S`` seconds.  They are removed by
projecting every column on the complement of [1, t - t_mid] within each window
(Frisch-Waugh-Lovell), which costs one pass over the rows.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]

BLOCK_S = 5.0  # s: rows closer than this share one cluster of the robust covariance
INFORMED_SHARE = 0.5  # a parameter is "informed" when its sigma is below this share of the prior's
MIN_CLUSTERS = 4  # fewer independent blocks than this: the relation is not used


@dataclass(frozen=True)
class LinearFit:
    """Result of :func:`fit_linear`: estimate, covariance, and how much data stood behind it.

    ``rows``: rows used; ``clusters``: independent blocks; ``residual_rms``: in the unit of y.
    """

    theta: FloatArray
    cov: FloatArray
    rows: int
    clusters: int
    residual_rms: float

    def sigma(self) -> FloatArray:
        return np.sqrt(np.maximum(np.diag(self.cov), 0.0))


def clusters_of(t: FloatArray, block_s: float | None = None, segment: IntArray | None = None) -> IntArray:
    """Cluster id per row: blocks of ``block_s`` seconds, split where ``segment`` changes.

    Default block: ``BLOCK_S``, shortened to a twelfth of the rows' time span (at least 1 s)
    so that a short manoeuvre still has enough blocks for a covariance.
    """
    if block_s is None:
        span = float(t[-1] - t[0]) if t.size > 1 else 0.0
        block_s = min(BLOCK_S, max(1.0, span / 12.0))
    block = np.floor((t - (t[0] if t.size else 0.0)) / block_s).astype(np.intp)
    if segment is None:
        return block
    change = np.flatnonzero((np.diff(block) != 0) | (np.diff(segment) != 0)) + 1
    ids = np.zeros(t.size, dtype=np.intp)
    ids[change] = 1
    return np.cumsum(ids)


def fit_linear(
    X: FloatArray,
    y: FloatArray,
    cluster: IntArray,
    prior_mean: FloatArray | None = None,
    prior_sd: FloatArray | None = None,
    weights: FloatArray | None = None,
) -> LinearFit:
    """Weighted least squares with an optional Gaussian prior and cluster-robust covariance.

    X (n, p), y (n,), cluster (n,) ids (any ints), weights (n,) relative (default 1).
    prior_mean / prior_sd (p,): prior_sd inf = no prior on that parameter.  The residual scale
    is estimated from the rows, so only relative weights matter.
    """
    n, p = X.shape
    w = np.ones(n) if weights is None else weights
    mean0 = np.zeros(p) if prior_mean is None else prior_mean
    sd0 = np.full(p, np.inf) if prior_sd is None else prior_sd
    if n == 0:
        cov0 = np.diag(np.where(np.isfinite(sd0), sd0**2, np.inf))
        return LinearFit(mean0.copy(), cov0, 0, 0, math.nan)
    # the residual scale of the rows, from an unregularised pass, sets the prior's weight
    XtW = X.T * w
    A = XtW @ X
    b = XtW @ y
    try:
        theta_ls = np.linalg.lstsq(A, b, rcond=None)[0]
    except np.linalg.LinAlgError:
        theta_ls = mean0.copy()
    res = y - X @ theta_ls
    s2 = float(np.sum(w * res**2) / max(n - p, 1)) or 1e-30
    prior_info = np.where(np.isfinite(sd0), 1.0 / np.where(np.isfinite(sd0), sd0, 1.0) ** 2, 0.0) * s2
    Pinv = np.diag(prior_info)
    H = A + Pinv
    try:
        Hinv = np.linalg.inv(H)
    except np.linalg.LinAlgError:
        Hinv = np.linalg.pinv(H)
    theta = Hinv @ (b + Pinv @ mean0)
    res = y - X @ theta
    # cluster sums of the scores X' W e (one pass: sort-free accumulation by id)
    _, inv = np.unique(cluster, return_inverse=True)
    g = int(inv.max()) + 1
    scores = np.zeros((g, p))
    np.add.at(scores, inv, X * (w * res)[:, None])
    meat = scores.T @ scores
    scale = g / (g - p) if g > p else math.inf
    cov = Hinv @ (meat * scale + Pinv * s2) @ Hinv if math.isfinite(scale) else np.full((p, p), np.inf)
    # parameters the rows cannot reach keep the prior's covariance
    cov = (
        np.where(np.isfinite(cov), cov, 0.0)
        if math.isfinite(scale)
        else np.diag(np.where(np.isfinite(sd0), sd0**2, np.inf))
    )
    rms = float(np.sqrt(np.mean(res**2)))
    return LinearFit(theta, cov, n, g, rms)


def informed(sigma: float, prior_sigma: float, share: float = INFORMED_SHARE) -> bool:
    """True when the drive shrank a parameter's 1-sigma below ``share`` of its prior's."""
    return bool(math.isfinite(sigma) and sigma < share * prior_sigma)


def window_ids(t: FloatArray, usable: NDArray[np.bool_], window_s: float, max_gap_s: float) -> IntArray:
    """Window id per row (-1 where not usable): runs of usable rows without a gap longer than
    ``max_gap_s``, cut into windows of at most ``window_s`` seconds."""
    ids = np.full(t.size, -1, dtype=np.intp)
    rows = np.flatnonzero(usable)
    if rows.size == 0:
        return ids
    ts = t[rows]
    new_run = np.concatenate([[True], np.diff(ts) > max_gap_s])
    run = np.cumsum(new_run) - 1
    run_start = ts[new_run][run]
    piece = np.floor((ts - run_start) / window_s).astype(np.intp)
    key = run * 100000 + piece
    _, ids_rows = np.unique(key, return_inverse=True)
    ids[rows] = ids_rows
    return ids


def window_means(window: NDArray[np.intp], columns: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Per-window means of ``columns`` (rows, k) and the windows' row counts."""
    used = window >= 0
    ids = window[used]
    n_win = int(ids.max()) + 1 if ids.size else 0
    count = np.bincount(ids, minlength=n_win).astype(float)
    means = np.column_stack(
        [np.bincount(ids, weights=columns[used, j], minlength=n_win) for j in range(columns.shape[1])]
    )
    return means / np.maximum(count, 1.0)[:, None], count


def project_windows(window: IntArray, t: FloatArray, columns: FloatArray, slope: bool = True) -> FloatArray:
    """Remove per-window offset (and slope in t) from every column of ``columns`` (n, k).

    ``window`` (n,) ids >= 0.  Windows with fewer than 3 rows (2 without slope) are zeroed.
    Frisch-Waugh-Lovell: fitting the projected columns equals fitting with per-window nuisance.
    """
    cols = np.asarray(columns, dtype=float)
    if cols.ndim == 1:
        cols = cols[:, None]
    out = np.zeros_like(cols)
    if window.size == 0:
        return out
    g = int(window.max()) + 1
    cnt = np.bincount(window, minlength=g).astype(float)
    tm = np.bincount(window, weights=t, minlength=g) / np.maximum(cnt, 1)
    tc = t - tm[window]
    stt = np.bincount(window, weights=tc * tc, minlength=g)
    enough = cnt[window] >= (3 if slope else 2)
    for k in range(cols.shape[1]):
        c = cols[:, k]
        mean = np.bincount(window, weights=c, minlength=g) / np.maximum(cnt, 1)
        r = c - mean[window]
        if slope:
            st = np.bincount(window, weights=tc * r, minlength=g)
            beta = np.where(stt > 1e-12, st / np.where(stt > 1e-12, stt, 1.0), 0.0)
            r = r - beta[window] * tc
        out[:, k] = np.where(enough, r, 0.0)
    return out


def fit_robust(
    X: FloatArray,
    y: FloatArray,
    cluster: IntArray,
    prior_mean: FloatArray | None = None,
    prior_sd: FloatArray | None = None,
    k_sigma: float = 5.0,
) -> tuple[LinearFit, NDArray[np.bool_]]:
    """:func:`fit_linear` after dropping outliers (GNSS multipath): rows whose residual of a
    first fit exceeds ``k_sigma`` robust sigmas (1.4826 MAD).  Returns the fit and the kept rows."""
    first = fit_linear(X, y, cluster, prior_mean, prior_sd)
    if X.shape[0] == 0:
        return first, np.zeros(0, dtype=bool)
    res = y - X @ first.theta
    mad = 1.4826 * float(np.median(np.abs(res - np.median(res))))
    keep = np.abs(res) <= k_sigma * max(mad, 1e-12)
    if keep.all():
        return first, keep
    return fit_linear(X[keep], y[keep], cluster[keep], prior_mean, prior_sd), keep


def halves_sigma(
    X: FloatArray,
    y: FloatArray,
    t: FloatArray,
    prior_mean: FloatArray,
    prior_sd: FloatArray,
    sd: FloatArray,
) -> FloatArray:
    """``sd`` (a fit's 1-sigma per parameter) widened by how far the drive's two halves (rows
    before and after the median of ``t``) disagree beyond their own noise: what a relation
    leaves out that does not average over the drive (sideslip changes, a walking bias) shows
    as a spread between the halves.  Unchanged with 10 rows or fewer in a half."""
    half = t < np.median(t)
    if half.sum() <= 10 or (~half).sum() <= 10:
        return sd
    f1, _ = fit_robust(X[half], y[half], clusters_of(t[half]), prior_mean, prior_sd)
    f2, _ = fit_robust(X[~half], y[~half], clusters_of(t[~half]), prior_mean, prior_sd)
    d = f1.theta - f2.theta
    noise = np.diag(f1.cov) + np.diag(f2.cov)
    return np.sqrt(sd**2 + np.maximum(0.0, d * d - noise) / 4.0)
