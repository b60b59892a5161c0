"""The smoother's second look at the Doppler: multipath bursts against the smoothed track.

The forward filter checks each Doppler epoch against the velocity the IMU carried forward
from the last epoch that agreed with it (``fused_engine._doppler_check``).  That check sees a
burst (a run of wrong epochs that agree with each other: multipath persists while the
reflecting geometry lasts) only until the carried velocity's variance has grown enough to
admit it, so the middle of a burst of several seconds goes in.  At the grip limit, where
nothing but a straight separates the heading from the slip, that middle turns the heading
and the slip with it: CommonRoad's limit ramp with the Ford Escort (seed 7, an 8.6 s run of
bursts in the steady turn) read beta 0.35 deg off with ``fused`` against 0.17 for the causal
filter, where beta itself is at most 0.3 deg.

The smoother has both sides of every epoch.  After its first pass each Doppler epoch's
distance from the antenna velocity the smoothed states predict
(``fused_engine.doppler_residuals``) is set against the drive's own residual scale: the
median distance over the drive (for a two-dimensional Gaussian error 1.1774 times its
per-axis sigma), never below the receiver's quoted sigma.  Epochs farther than ``gate``
times that scale, in runs of ``min_run`` or more in a row, are a burst, with the epoch on
either side of each run (where the burst's error rises through the gate and falls back); each
is taken again with the square of its distance per axis as its variance, and the smoother
runs once more (the drive's noise and antenna as read before: reading them again cost 40 %
of the 1 h bench drive's time, for no gain in the mean).
This is one step of iteratively reweighted least squares with a scale estimated from the
residuals (Huber 1981, *Robust Statistics*, Wiley, sec. 7.8; Holland and Welsch 1977,
Commun. Stat. Theory Methods 6(9)).  The scale comes from the drive, so a drive whose tyre
model or file is wrong throughout, which raises the residuals everywhere, does not read as a
burst (a scale fixed at the receiver's sigma took cr_circle with the right file from 0.035 to
0.062 deg); a lone outlier stays the forward gate's business, and a run must be at least two
epochs (five, half a second at 10 Hz, left the limit drives' shorter runs in and did worse).  Measured in
``benchmarks/results/fused_accuracy.md`` (session 27).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

__all__ = ["RAYLEIGH_MEDIAN", "burst_epochs", "residual_scale"]

RAYLEIGH_MEDIAN = math.sqrt(2.0 * math.log(2.0))  # median distance / per-axis sigma, 2-D Gaussian


def residual_scale(residual: NDArray[np.float64], sigma: NDArray[np.float64]) -> NDArray[np.float64]:
    """Per-axis scale (m/s) of each epoch's residual: the drive's median distance over
    :data:`RAYLEIGH_MEDIAN`, at least the epoch's own ``sigma``."""
    ok = np.isfinite(residual)
    typical = float(np.median(residual[ok])) / RAYLEIGH_MEDIAN if ok.any() else 0.0
    return np.maximum(sigma, typical)


def burst_epochs(
    residual: NDArray[np.float64], sigma: NDArray[np.float64], gate: float, min_run: int = 2,
    edge: int = 1,
) -> NDArray[np.bool_]:
    """Epochs (of the Doppler epochs' order; NaN residuals are no epoch and break no run)
    whose residual is beyond ``gate`` x :func:`residual_scale` in runs of at least
    ``min_run`` consecutive Doppler epochs, with ``edge`` epochs on either side of each run
    (where the burst's error rises through the gate and falls back through it)."""
    ok = np.isfinite(residual)
    out = np.zeros(residual.size, dtype=bool)
    where = np.flatnonzero(ok)
    if where.size == 0:
        return out
    far = residual[where] > gate * residual_scale(residual, sigma)[where]
    # runs of True in `far` (consecutive Doppler epochs)
    edges = np.diff(np.concatenate(([0], far.astype(np.int8), [0])))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    for a, b in zip(starts, ends, strict=True):
        if b - a >= min_run:
            out[where[max(a - edge, 0) : b + edge]] = True
    return out
