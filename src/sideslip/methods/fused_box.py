"""The GNSS antenna's place along the car from the low-speed turns, where the rear axle does
not slide sideways.

The antenna check of :mod:`sideslip.methods.fused_lever` and its IMU alternative see only the
antenna's place *relative to the IMU*.  A sensor box that carries both (a phone, a dashboard
logger, a receiver with its own IMU) and that the vehicle file puts at the CG when it sits a
metre ahead moves neither against the other: the kinematics and the Doppler agree on the
lateral velocity of a point ``d`` ahead of the CG, and the smoother reads ``r d`` as slip
(measured: race lap with the box 1 m ahead 0.028 -> 0.619 deg with 69 % of its errors inside
2 sigma; urban_course 1 m behind 0.034 -> 0.776 deg).  Only where the CG is follows from the
car: at low lateral acceleration the rear axle's lateral velocity is its slip angle times the
speed, and in a turn at walking pace that is small against ``r d``.  So on the Doppler epochs
of turns below ``speed_max`` (the Doppler turned into the body frame by the smoother's
heading, its roll-rate part taken out with the file's antenna height):

    v_lat_antenna - (x_antenna + l_r) r = d r + k a_y v + c

``d`` is the antenna's distance ahead of the file's, ``k a_y v`` the rear slip velocity of a
linear tyre of unknown stiffness (``alpha_r = m l_f a_y / (L C_r)``, so no stiffness is
needed), ``c`` a constant (the heading's and the Doppler's offsets).  At speed the slip term
and ``r`` are the same regressor (``a_y v = r v^2``), so only the slow turns decide ``d``, and
the sigma is the jackknife's over ``block_s`` blocks of the drive (the epochs of one turn are
not independent).  Drives without ``min_blocks`` blocks of such turns (a race lap, a highway)
are not judged.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sideslip.drive import Drive
from sideslip.estimate import Estimate
from sideslip.signals import hold
from sideslip.vehicle import Vehicle

__all__ = ["BoxCheck", "antenna_from_slow_turns"]


@dataclass(frozen=True)
class BoxCheck:
    """The antenna ``d_m`` ahead of the file's (m) with its jackknife 1-sigma, from ``rows``
    Doppler epochs in ``blocks`` blocks; moved where beyond ``z_gate`` sigmas."""

    d_m: float
    sigma_m: float
    rows: int
    blocks: int
    z_gate: float

    @property
    def applied(self) -> bool:
        return bool(math.isfinite(self.sigma_m) and abs(self.d_m) > self.z_gate * self.sigma_m)

    def note(self) -> str:
        if not math.isfinite(self.sigma_m):
            return f"not judged: {self.blocks} blocks of slow turns with Doppler ({self.rows} epochs)"
        found = (
            f"the slow turns put the antenna {self.d_m:+.3f} +- {self.sigma_m:.3f} m ahead of the "
            f"installation's ({self.rows} Doppler epochs in {self.blocks} blocks"
        )
        if self.applied:
            return f"{found}): antenna and IMU moved by it"
        return f"{found}, within {self.z_gate:g} sigma): kept"

    def params(self) -> dict[str, Any]:
        judged = math.isfinite(self.sigma_m)
        return {
            "box_x_slow_turns_m": self.d_m if judged else None,
            "box_x_slow_turns_m_sigma": self.sigma_m if judged else None,
            "box_x_applied_m": self.d_m if self.applied else 0.0,
        }


def antenna_from_slow_turns(
    drive: Drive,
    vehicle: Vehicle,
    est: Estimate,
    speed_min: float,
    speed_max: float,
    accel_max: float,
    block_s: float,
    min_blocks: int,
    z_gate: float,
    latency_s: float = 0.0,
) -> BoxCheck:
    """:class:`BoxCheck` of the antenna of ``vehicle`` from ``est`` (the smoother's heading
    ``yaw``, yaw rate ``r`` and speed ``vx``) and the drive's Doppler on the epochs between
    ``speed_min`` and ``speed_max`` (m/s) with ``|a_y|`` below ``accel_max`` (m/s^2).  Each
    Doppler epoch is compared with the car ``latency_s`` before its stamp (the latency the
    estimate took it with): a late Doppler lags the heading by ``r tau``, ``v r tau`` of
    lateral velocity, which in the slow turns reads as an antenna about ``v tau`` behind
    (urban_course with the Doppler 200 ms late and the installation right: -0.87 +- 0.07 m
    without this, +0.01 +- 0.10 m with the 0.208 s the estimate identified)."""
    t = drive.t
    series = est.series
    if "yaw" not in series or "gnss_ve" not in drive or "gnss_vn" not in drive:
        return BoxCheck(math.nan, math.inf, 0, 0, z_gate)
    wx_row = hold(np.asarray(drive["wx"], dtype=float), t)[0] if "wx" in drive else np.zeros(t.size)
    rows_of_car = {
        "yaw": np.unwrap(np.asarray(series["yaw"], dtype=float)),
        "r": np.asarray(series["r"], dtype=float),
        "vx": np.asarray(series["vx"], dtype=float),
        "ay": hold(np.asarray(drive["ay"], dtype=float), t)[0],
        "wx": wx_row,
    }
    if latency_s != 0.0:  # the car when the epoch was measured
        rows_of_car = {k: np.interp(t - latency_s, t, v) for k, v in rows_of_car.items()}
    psi, r, vx, ay, wx = (rows_of_car[k] for k in ("yaw", "r", "vx", "ay", "wx"))
    ve, vn = np.asarray(drive["gnss_ve"], dtype=float), np.asarray(drive["gnss_vn"], dtype=float)
    x_a, _, z_a = (float(c) for c in vehicle.gnss_xyz)
    lateral = -ve * np.sin(psi) + vn * np.cos(psi) + wx * z_a  # the antenna's, less roll rate
    y = lateral - (x_a + vehicle.lr) * r
    use = (
        np.isfinite(y) & np.isfinite(ay) & (vx > speed_min) & (vx < speed_max)
        & (np.abs(ay) < accel_max)
    )  # fmt: skip
    rows = int(use.sum())
    block = np.floor((t[use] - t[0]) / block_s).astype(np.int64)
    blocks = np.unique(block)
    if blocks.size < min_blocks:
        return BoxCheck(math.nan, math.inf, rows, int(blocks.size), z_gate)
    A = np.column_stack([r[use], ay[use] * vx[use], np.ones(rows)])
    b = y[use]

    def fit(keep: NDArray[np.bool_] | slice) -> float:
        coef, *_ = np.linalg.lstsq(A[keep], b[keep], rcond=None)
        return float(coef[0])

    d = fit(slice(None))
    # the jackknife over blocks (a turn's epochs are one piece of evidence)
    leave_out = np.array([fit(block != k) for k in blocks])
    nb = blocks.size
    sigma = math.sqrt((nb - 1) / nb * float(np.sum(np.square(leave_out - leave_out.mean()))))
    if not (math.isfinite(d) and math.isfinite(sigma)):
        return BoxCheck(math.nan, math.inf, rows, int(nb), z_gate)
    return BoxCheck(d, sigma, rows, int(nb), z_gate)
