"""A GNSS Doppler latency that the tyre-free fits leave open, profiled with the tyres.

A Doppler velocity stamped ``tau`` late is the antenna's velocity ``tau`` earlier: in the body
frame it lags by ``tau a`` (the body's acceleration), in a turn ``tau v r`` sideways, which the
smoother reads as slip.  :func:`sideslip.gnss_latency.identify_doppler_latency` times the
Doppler without tyres (its speed against the wheels, its course rate against the lateral
accelerometer), and where those fits decide it the epochs are moved
(:mod:`sideslip.doppler_timing`).  On a short drive of a few turns at one speed they do not
(step_steer, 100 ms late: +0.10 +- 0.06 s, kept at the stamps: fused 0.82 deg), and tyre-free
``tau v r`` at one speed is also what an antenna ``v tau`` behind reads (the antenna check and
its IMU alternative then move a sensor for it: two_turns_gyro_sf 100 ms late, the IMU moved by
1.46 m, 0.54 deg; benchmarks/results/doppler_latency.md).

The tyres tell a late Doppler from a misplaced sensor: the axle forces answer the steering at
once, the Doppler's slip ``tau`` later.  :func:`profile_latency` scores the drive's Doppler
with the tyres (``-2 log L`` of the forward filter's innovations, each run with the noise it
identifies itself, as the installation checks score theirs) with the epochs taken ``tau``
before their stamps, over a grid of ``tau`` inside the tyre-free fits' range (their estimate
+- ``range_sigmas`` sigma, within 0 and the longest latency taken); a parabola through the
best point and its neighbours places the minimum, and its curvature the sigma (``-2 log L``
rises by 1 at one sigma).  The latency is taken where it lowers ``-2 log L`` below the
stamps' by more than ``z_gate^2`` (the installation checks' gate) and beats every
installation those checks propose (:class:`sideslip.methods.fused_lever.ImuAlternative`).

Measured (simulator, seed 0, right file; ``-2 log L`` against the stamps at 0.05 / 0.10 /
0.15 s): step_steer 100 ms late -24.7 / -50.3 / -25.0, two_turns_gyro_sf 100 ms late
-44.7 / -105.6 / -58.8, cr_limit_ramp 100 ms late -24.2 / -46.8 / -12.0; on time every
profile rises from the stamps (step_steer +25.0 / +71.5 / +193.4).  The tyres here are the
smoother's linear-in-stiffness axle relations, whose forces follow the slip at once; real
tyres build their force over a relaxation length, which could pass for a latency.  With the
simulator's tyres lagging over 1 m (``simulate(..., tyre_relaxation_m=1.0)``) the on-time
profiles still rose from the stamps (step_steer +27.7 at 25 ms, dlc_bank +53.8, race_lap
+745) and the late ones still had their minimum at the true 100 ms.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from sideslip.doppler_timing import FLOOR_S, MAX_LATENCY_S, DopplerTiming
from sideslip.gnss_latency import LatencyEstimate

__all__ = ["LatencyProfile", "latency_grid", "profile_latency"]

# a refined minimum this close to a grid point is not scored again (s; the rows of a 100 Hz
# drive are 0.01 s apart, and the epochs are taken at the nearest row)
REFINE_MIN_S = 0.005
MAX_EXTENSIONS = 2  # grid steps added beyond the range where its upper end is the best


@dataclass(frozen=True)
class LatencyProfile:
    """The Doppler's ``-2 log L`` with the tyres at each latency scored (``scan``: (tau s,
    -2 log L) pairs, the stamps' (0) first), the latency at the minimum with its 1-sigma (s),
    and the gate ``z_gate`` (``-2 log L`` must fall by ``z_gate^2`` below the stamps')."""

    scan: tuple[tuple[float, float], ...]
    latency_s: float
    sigma_s: float
    z_gate: float
    fit: LatencyEstimate

    @property
    def neg2ll_stamps(self) -> float:
        return self.scan[0][1]

    @property
    def neg2ll(self) -> float:
        """``-2 log L`` at :attr:`latency_s`."""
        return min(n for _, n in self.scan)

    @property
    def gain(self) -> float:
        """How far ``-2 log L`` falls from the stamps to the latency."""
        return self.neg2ll_stamps - self.neg2ll

    @property
    def found(self) -> bool:
        """A latency beyond the gate: later than the stamps, ``gain > z_gate^2``, and a
        minimum the profile bends up around (a finite sigma)."""
        return bool(self.latency_s > 0.0 and math.isfinite(self.sigma_s) and self.gain > self.z_gate**2)

    def timing(self) -> DopplerTiming:
        """The epochs' timing where this latency is taken (its sigma with the fits' floor)."""
        note = (
            f"each GNSS epoch taken this long before its stamp: the tyre-free fits left it open "
            f"({self.fit.latency_s:+.3f} +- {self.fit.sigma_s:.3f} s); the Doppler with the tyres "
            f"falls by {self.gain:.1f} in -2 log L against the stamps (sideslip.methods.fused_latency)"
        )
        return DopplerTiming(self.latency_s, math.hypot(self.sigma_s, FLOOR_S), note, self.fit)

    def params(self) -> dict[str, Any]:
        low = self.neg2ll_stamps
        return {
            "gnss_doppler_latency_tyres_s": self.latency_s,
            "gnss_doppler_latency_tyres_sigma_s": self.sigma_s,
            # [tau s, -2 log L less the stamps'] of each run
            "gnss_doppler_latency_tyres_scan": [[tau, n - low] for tau, n in self.scan],
        }


def latency_grid(
    fit: LatencyEstimate, range_sigmas: float, step_s: float, max_points: int
) -> tuple[list[float], float]:
    """The latencies (s, above 0) to score first and the grid's step: the fits' estimate +-
    ``range_sigmas`` of their sigma (with the floor), clipped to (0, MAX_LATENCY_S], in steps
    of ``step_s`` (wider where that would take more than ``max_points`` points).  Empty where
    the range lies at or below 0."""
    sigma = math.hypot(fit.sigma_s, FLOOR_S)
    hi = min(MAX_LATENCY_S, fit.latency_s + range_sigmas * sigma)
    lo = max(0.0, fit.latency_s - range_sigmas * sigma)
    if not (math.isfinite(hi) and hi >= 0.5 * step_s):
        return [], step_s
    lo = step_s * math.floor(lo / step_s)
    step = max(step_s, (hi - lo) / max_points)
    count = max(1, math.ceil((hi - lo) / step - 1e-9))
    start = 1 if lo == 0.0 else 0
    return [lo + k * step for k in range(start, count + 1)], step


def profile_latency(
    score: Callable[[float], float],
    neg2ll_stamps: float,
    fit: LatencyEstimate,
    range_sigmas: float,
    step_s: float,
    max_points: int,
    z_gate: float,
) -> LatencyProfile | None:
    """Score the grid of :func:`latency_grid` (``score(tau)``: the Doppler's ``-2 log L`` with
    the tyres, the epochs taken ``tau`` s before their stamps; ``neg2ll_stamps`` the same at
    0), extend it by up to :data:`MAX_EXTENSIONS` steps while its last point is the best, and
    refine the minimum by a parabola through it and its neighbours.  None where the grid is
    empty."""
    grid, step = latency_grid(fit, range_sigmas, step_s, max_points)
    if not grid:
        return None
    scan: dict[float, float] = {0.0: float(neg2ll_stamps)}
    for tau in grid:
        scan[tau] = float(score(tau))
    for _ in range(MAX_EXTENSIONS):
        top = max(scan)
        if min(scan, key=scan.__getitem__) != top or top + step > MAX_LATENCY_S + 1e-9:
            break
        scan[top + step] = float(score(top + step))
    best = min(scan, key=scan.__getitem__)
    sigma = math.inf
    if best > 0.0:
        taus = sorted(scan)
        k = taus.index(best)
        if k + 1 < len(taus):
            three = np.array(taus[k - 1 : k + 2])
            a, b, _ = np.polyfit(three, [scan[t] for t in three], 2)
            if a > 0.0:
                vertex = float(np.clip(-b / (2.0 * a), three[0], three[2]))
                sigma = 1.0 / math.sqrt(a)
                if abs(vertex - best) > REFINE_MIN_S:
                    scan[vertex] = float(score(vertex))
                    best = min(scan, key=scan.__getitem__)
        else:
            # the minimum at the longest latency taken: the slope to its neighbour, as if
            # the parabola had its vertex there
            below = taus[k - 1]
            rise = scan[below] - scan[best]
            if rise > 0.0:
                sigma = (best - below) / math.sqrt(rise)
    items = sorted(scan.items())
    ordered = [(0.0, scan[0.0])] + [(t, n) for t, n in items if t > 0.0]
    return LatencyProfile(tuple(ordered), best, sigma, z_gate, fit)
