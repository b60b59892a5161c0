"""Honest 1-sigmas for the parameters seed 000's pipeline identifies (K, delta G_y, SF, gyro scale).

A least-squares 1-sigma from the residual scatter assumes independent residuals.  The
residuals of the slip-gain fit (eq 20), the wheel-speed scale fit (eq 4) and the curves'
heading closures (eq 19) are not: a curve's residual is one model error seen on a hundred GNSS
epochs.  Two guards, both computed from the drive itself:

* a **block jackknife** (Künsch 1989; Efron & Tibshirani, *An Introduction to the Bootstrap*,
  1993, ch. 11): the data are cut into contiguous blocks (``block_s`` seconds, longer than the
  residuals' correlation), the fit is repeated leaving each block out, and the spread of the
  leave-one-out values gives the 1-sigma, whatever the residuals' correlation inside a block;
* a **Student-t factor** for few degrees of freedom (:func:`t_factor`), so that a 1-sigma
  estimated from a handful of blocks or curves keeps its 68 % coverage.

The reported 1-sigma is the larger of the formal (t-scaled) one and the jackknife's.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray
from scipy import stats

FloatArray = NDArray[np.float64]

MIN_BLOCKS = 4  # below, the jackknife is not formed (inf)


def t_factor(dof: int) -> float:
    """Student-t quantile t_dof(0.8413) over the Gaussian's 1 (1.84 at dof 1, 1.14 at 4)."""
    return float(stats.t.ppf(0.8413447, max(int(dof), 1)))


def time_blocks(t: FloatArray, block_s: float) -> NDArray[np.intp]:
    """Block label of each sample: floor((t - t_0) / ``block_s``), t in s."""
    if t.size == 0:
        return np.zeros(0, dtype=np.intp)
    return np.floor((t - t[0]) / block_s).astype(np.intp)


def block_jackknife_std(
    labels: NDArray[np.intp], estimate: Callable[[NDArray[np.bool_]], float]
) -> float:
    """Delete-one-block jackknife 1-sigma of ``estimate(mask)`` over the blocks in ``labels``.

    sigma^2 = (B - 1)/B sum_b (theta_(-b) - mean)^2.  Returns inf with fewer than
    :data:`MIN_BLOCKS` blocks or when a leave-one-out fit fails (non-finite).
    """
    blocks = np.unique(labels)
    if blocks.size < MIN_BLOCKS:
        return float("inf")
    vals = np.array([estimate(labels != b) for b in blocks], dtype=float)
    if not np.all(np.isfinite(vals)):
        return float("inf")
    b = blocks.size
    return float(np.sqrt((b - 1) / b * np.sum((vals - vals.mean()) ** 2)))


def block_jackknife_sums_std(
    labels: NDArray[np.intp], columns: FloatArray, estimate: Callable[[FloatArray], FloatArray]
) -> float:
    """:func:`block_jackknife_std` for an estimate that is a function of column sums, O(n).

    ``columns`` (k, n): per-sample terms whose sums over the kept samples determine the
    estimate (e.g. x y and x^2 for a slope through the origin); ``estimate`` maps the (k, B)
    leave-one-block-out sums (total minus each block's) to the B leave-one-out values.  Same
    value as the generic form up to round-off, without re-fitting the whole drive per block
    (which made the jackknife quadratic in the drive's length).
    """
    blocks, inv = np.unique(labels, return_inverse=True)
    if blocks.size < MIN_BLOCKS:
        return float("inf")
    cols = np.atleast_2d(np.asarray(columns, dtype=float))
    per_block = np.stack([np.bincount(inv, weights=c, minlength=blocks.size) for c in cols])
    loo = cols.sum(axis=1)[:, None] - per_block
    with np.errstate(divide="ignore", invalid="ignore"):
        vals = np.asarray(estimate(loo), dtype=float)
    if not np.all(np.isfinite(vals)):
        return float("inf")
    b = blocks.size
    return float(np.sqrt((b - 1) / b * np.sum((vals - vals.mean()) ** 2)))


def ratio_of_sums(loo: FloatArray) -> FloatArray:
    """Slope through the origin from the sums (sum x y, sum x^2): NaN where sum x^2 <= 0."""
    return np.where(loo[1] > 0, loo[0] / np.where(loo[1] > 0, loo[1], 1.0), np.nan)


def honest_std(formal: float, dof: int, jackknife: float) -> float:
    """max(formal x t_factor(dof), jackknife); a non-finite jackknife is ignored."""
    f = formal * t_factor(dof) if np.isfinite(formal) else float("inf")
    return float(max(f, jackknife)) if np.isfinite(jackknife) else f
