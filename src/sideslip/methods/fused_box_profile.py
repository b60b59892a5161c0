"""A sensor box's place along the car where the drive has no slow turns, profiled with the tyres.

:mod:`sideslip.methods.fused_box` places a box (antenna and IMU together) from the turns at
walking pace, where the rear axle barely slides.  A race lap or a highway has none, and the
box was then kept where the file says: with the box 1 m ahead of the file's, the race lap read
0.619 deg with 69 % of its errors inside 2 sigma, ``r d / v`` of slip the estimate did not know
it could carry (benchmarks/results/installation_offsets.md).

At speed the tyres still say something.  A box ``d`` ahead of where the file puts it reads
``r d`` more lateral velocity than the CG has; the axle relations then see a rear slip angle
``r d / v`` off, which grows as ``1 / v`` at a given ``a_y`` and follows the yaw rate in a
transient, where a stiffness error scales with ``a_y``.  :func:`profile_box` scores the drive's
Doppler with the tyres (``-2 log L`` of the forward filter's innovations, each run with the
noise it identifies itself, as :mod:`sideslip.methods.fused_latency` scores a latency) with
the box moved by ``d`` along x, on a grid of ``step_m`` from 0 outwards on each side until the
score has risen ``z_gate^2`` above its lowest point (or ``max_m`` is reached); a parabola
through the best point and its neighbours places the minimum, and its curvature the sigma.
The box is moved where the minimum lowers ``-2 log L`` below the file's place, and below the
scan's own 0, by more than ``z_gate^2`` (the installation checks' gate), on a drive whose
Doppler carries no multipath bursts.  The IMU keeps against the antenna the offset the antenna
check's tyre-free pass read (:func:`profile_box`), so one sensor off is one of the places
scored.

Where it is not moved, the place is still doubtful by the profile's own reading: the minimum
lies ``d_min`` from the file's place, known to ``sigma``, so ``beta_std`` carries
``hypot(sigma, d_min) |r| / v`` (:attr:`BoxProfile.spread_m`); where it is moved, ``sigma``.

Measured (simulator, seed 0, 11 own scenarios x the right / 30 %-soft / rough file, antenna
and IMU moved together and scored at 0, +-0.5 ... +-2 m; ``-2 log L`` against the file's
place): with the box 1 m ahead
the race lap falls by 64-71 at +1 m, banked_turn by 41-62, urban_highway by 52-190; with the
installation right no profile fell by more than 9 except urban_highway with the rough file
(22 at +0.5 m).  Many profiles are flat within a few units over a metre (two_turns_gyro_sf,
banked_track_turn, step_steer, the race lap with the box 1 m *behind*: 3-7): there the
spread, not the move, is the answer.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["BoxProfile", "profile_box"]

REFINE_MIN_M = 0.05  # a refined minimum this close to a scored place is not scored again (m)


@dataclass(frozen=True)
class BoxProfile:
    """The Doppler's ``-2 log L`` with the tyres at each box place scored (``scan``: (d m
    ahead of the file's place, -2 log L) pairs in order of d, 0 among them), the place
    ``d_m`` at the minimum with its 1-sigma ``sigma_m`` (m; inf where the profile does not
    bend up around it), the gate ``z_gate``, ``-2 log L`` at the installation the first
    checks settled on (``neg2ll_file``: the scan's 0 unless the scan keeps an offset between
    antenna and IMU that no check took; see :func:`profile_box`), and the Doppler epochs the
    file's run found in multipath bursts (``burst_epochs``): the scoring runs take every epoch
    as it comes (the Doppler's checks off, so that each place is scored on the same data), so
    on such a drive the bursts score too, and the box is not moved (cr_limit_slalom seed 1,
    71 burst epochs: the profile fell by 18 at +0.89 m with the box where the file says, and
    moving it took beta from 0.10 to 1.12 deg)."""

    scan: tuple[tuple[float, float], ...]
    d_m: float
    sigma_m: float
    z_gate: float
    neg2ll_file: float
    burst_epochs: int = 0

    @property
    def gain(self) -> float:
        """How far ``-2 log L`` falls to the minimum from the better of the file's place and
        the scan's 0: where the scan keeps an antenna-IMU offset the antenna check left
        undecided, its 0 is that check's IMU alternative, and a box move must beat that too
        (two_turns_gyro_sf with the IMU 1 m behind: antenna moved and IMU moved 33.5 and 32.2
        below the file's and 1.3 apart, so the check kept the file's; read
        against the file's alone, the box moved by +0.5 m between the two took beta from 0.062
        to 0.235 deg)."""
        return min(self.neg2ll_file, dict(self.scan)[0.0]) - min(n for _, n in self.scan)

    @property
    def applied(self) -> bool:
        """Moved: a minimum off the file's place that the profile bends up around and that
        beats the file's place by more than ``z_gate^2``, on a drive without multipath bursts."""
        return bool(
            self.d_m != 0.0 and math.isfinite(self.sigma_m) and self.gain > self.z_gate**2
            and not self.burst_epochs
        )  # fmt: skip

    @property
    def spread_m(self) -> float:
        """The box's 1-sigma about the place taken (m): the curvature's sigma, and where the
        file's place is kept, the distance from it to the minimum too."""
        sigma = self.sigma_m if math.isfinite(self.sigma_m) else 0.0
        return sigma if self.applied else math.hypot(sigma, self.d_m)

    def note(self) -> str:
        bent = math.isfinite(self.sigma_m)
        where = f"+- {self.sigma_m:.2f} m" if bent else "m (the end of the scan)"
        found = (
            f"no slow turns; the Doppler with the tyres puts the box {self.d_m:+.2f} {where} ahead "
            f"of the installation's, {self.gain:.1f} lower in -2 log L ({len(self.scan)} places scored)"
        )
        if self.applied:
            return f"{found}: antenna and IMU moved by it"
        if bent and self.gain > self.z_gate**2:
            why = f"{self.burst_epochs} Doppler epochs in multipath bursts score too"
        else:
            why = f"within {self.z_gate:g}^2" if bent else "no minimum inside the scan"
        return f"{found}, {why}: kept, its doubt ({self.spread_m:.2f} m) in beta_std"

    def params(self) -> dict[str, Any]:
        low = self.neg2ll_file
        return {
            "box_x_tyres_m": self.d_m,
            "box_x_tyres_m_sigma": self.sigma_m if math.isfinite(self.sigma_m) else None,
            "box_x_tyres_spread_m": self.spread_m,
            # [d m, -2 log L less the file's place's] of each run
            "box_x_tyres_scan": [[d, n - low] for d, n in self.scan],
        }


def _vertex(scan: dict[float, float], best: float) -> tuple[float, float]:
    """The vertex of the parabola through ``best`` and its scored neighbours and its sigma
    (``-2 log L`` rises by 1 at one sigma); (best, inf) where ``best`` is at an end of the
    scan or the parabola does not open upwards."""
    places = sorted(scan)
    k = places.index(best)
    if k == 0 or k + 1 == len(places):
        return best, math.inf
    three = np.array(places[k - 1 : k + 2])
    a, b, _ = np.polyfit(three, [scan[d] for d in three], 2)
    if not a > 0.0:
        return best, math.inf
    return float(np.clip(-b / (2.0 * a), three[0], three[2])), 1.0 / math.sqrt(float(a))


def profile_box(
    score: Callable[[float], float],
    neg2ll_file: float,
    step_m: float,
    max_m: float,
    z_gate: float,
    burst_epochs: int = 0,
    neg2ll_zero: float | None = None,
) -> BoxProfile:
    """Score the box ``d`` m ahead of the file's place (``score(d)``: the Doppler's ``-2 log
    L`` with the tyres; ``neg2ll_file`` at the installation the first checks settled on, and
    ``neg2ll_zero`` at ``d = 0`` where that is another installation, else None) outwards in
    steps of ``step_m`` on each side, one step at least, while that side's last score lies
    within ``z_gate^2`` of the lowest (at most ``max_m`` out), then refine the minimum by a
    parabola through it and its neighbours.

    The box moves antenna and IMU by the same ``d``; where no check moved either, the
    caller's ``score`` keeps between them the offset ``dl`` that the antenna check's tyre-free
    pass read, beyond that pass's gate or not (the antenna at ``d``, the IMU at ``d - dl``),
    so that one sensor off the file's place is one of the places scored.  Moving both by the
    same ``d`` from the file's places instead, an antenna alone 0.5 m ahead (dlc_bank, rough
    file: the pass read +0.44 m, inside its gate) was taken for a box +0.84 m ahead and the
    IMU moved with it (0.054 -> 0.123 deg), and an IMU alone 1 m ahead (demo: the pass read
    -0.57 m) for a box 1 m behind (0.017 -> 0.113; benchmarks/results/fused_accuracy.md,
    session 35)."""
    scan: dict[float, float] = {0.0: float(neg2ll_file if neg2ll_zero is None else neg2ll_zero)}
    gate = z_gate**2
    for side in (-1.0, 1.0):
        # one step at least on each side: a side is not skipped because the other fell
        # further (the race lap with the box 1 m ahead and the rough file fell by 31 at
        # -0.5 m and by 79 at +1 m)
        d = 0.0
        while abs(d) + step_m <= max_m + 1e-9:
            d = round(d + side * step_m, 9)
            scan[d] = float(score(d))
            if scan[d] > min(scan.values()) + gate:
                break
    best = min(scan, key=scan.__getitem__)
    vertex, sigma = _vertex(scan, best)
    if math.isfinite(sigma) and min(abs(vertex - d) for d in scan) > REFINE_MIN_M:
        scan[vertex] = float(score(vertex))
        if scan[vertex] < scan[best]:
            best = vertex
    return BoxProfile(tuple(sorted(scan.items())), best, sigma, z_gate, float(neg2ll_file), burst_epochs)
