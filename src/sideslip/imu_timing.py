"""When a drive's IMU is stamped late against its GNSS Doppler and wheels, and the IMU moved back.

A logger that stamps the IMU's messages on arrival (a USB or CAN hop, a driver's buffer) or an
IMU whose internal low-pass delays its output puts every accelerometer and gyro sample later
than it was taken.  Against the Doppler the turns then come early: the Doppler's course rate
leads the lateral accelerometer, and :func:`sideslip.gnss_latency.identify_doppler_latency`'s
course-rate fit (``lateral_s``) reads the Doppler *early* by the IMU's lag, while its speed fit
against the wheels (``speed_s``) reads nothing.  A receiver is never early, so a decisive early
course-rate fit whose speed fit does not read early as well is the IMU's clock, and the IMU's
columns are moved back by it.  (Where the speed fit reads early too, the wheels are late with
the IMU, a whole CAN bus behind the receiver; nothing is moved, and
:class:`sideslip.doppler_timing.DopplerTiming.early` keeps its sigma in ``beta_std``.)

Measured (simulator, seed 0, every IMU sample 50 ms late, :mod:`benchmarks.input_faults`):
the fit reads race_lap 0.048 +- 0.006 s, cr_slalom 0.054 +- 0.011, cr_limit_slalom 0.057 +-
0.007 (the clean drive -0.007: a limit slalom's own offset); at a true 0 every decisive fit
of the 16 scenarios lies within 0.007 s of it, against the 0.03 s the rule needs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from sideslip.doppler_timing import DECISIVE_SIGMA_S, FLOOR_S, MIN_Z, timing_of
from sideslip.drive import Drive
from sideslip.gnss_latency import LatencyEstimate
from sideslip.vehicle import Vehicle

__all__ = ["IMU_COLUMNS", "ImuTiming", "choose_imu_lag", "drive_on_gnss_clock", "shift_imu"]

IMU_COLUMNS = ("ax", "ay", "az", "wx", "wy", "wz")
MAX_LAG_S = 0.5  # s: more than this is not a stamping delay but a misaligned log
GAP_FACTOR = 1.5  # two IMU samples further apart than this x their median spacing bound a gap


@dataclass(frozen=True)
class ImuTiming:
    """The lag (s) the IMU's samples are taken back by (0: left at their stamps), the 1-sigma
    (s) of what may remain of it, and a note saying why."""

    lag_s: float
    sigma_s: float
    note: str


def _early(value: float, sigma: float) -> bool:
    """A decisive fit (sigma at most :data:`DECISIVE_SIGMA_S`) reading the Doppler early by
    more than :data:`MIN_Z` of its sigma with :data:`FLOOR_S`."""
    return (
        math.isfinite(value) and math.isfinite(sigma) and sigma <= DECISIVE_SIGMA_S
        and value <= -MIN_Z * math.hypot(sigma, FLOOR_S)
    )  # fmt: skip


def choose_imu_lag(fit: LatencyEstimate | None) -> ImuTiming:
    """The IMU's lag from the Doppler's two timing fits (module docstring): the course-rate
    fit's early reading where it is decisive and the speed fit does not read early as well;
    otherwise 0."""
    if fit is None or not _early(fit.lateral_s, fit.lateral_sigma_s):
        return ImuTiming(0.0, 0.0, "not moved: the Doppler's course rate does not read the IMU late")
    if _early(fit.speed_s, fit.speed_sigma_s):
        return ImuTiming(
            0.0, 0.0, "not moved: the wheels read late with the IMU (the Doppler early against both)"
        )
    lag = min(-fit.lateral_s, MAX_LAG_S)
    sigma = math.hypot(fit.lateral_sigma_s, FLOOR_S)
    note = (
        f"moved back {lag:.3f} +- {sigma:.3f} s: the Doppler's course rate reads the IMU that late "
        "while its speed agrees with the wheels (an IMU stamped on arrival); |r| times the sigma is "
        "in beta_std"
    )
    return ImuTiming(lag, sigma, note)


def shift_imu(drive: Drive, lag_s: float) -> Drive:
    """``drive`` with every IMU column (:data:`IMU_COLUMNS`) taken ``lag_s`` earlier: each
    sample row holds the column linearly interpolated between its own samples at the row's
    time plus ``lag_s``.  Rows whose time plus the lag falls in a gap of the column (two
    samples further apart than :data:`GAP_FACTOR` x their median spacing) or past its last
    sample are NaN, as the drive's other gaps."""
    names = [n for n in IMU_COLUMNS if n in drive]
    if lag_s <= 0.0 or not names:
        return drive
    t = drive.t
    data = dict(drive.data)
    for name in names:
        stored = np.asarray(drive.data[name])
        col = stored.astype(float)
        rows = np.flatnonzero(np.isfinite(col))
        out = np.full(t.size, np.nan, dtype=stored.dtype if stored.dtype.kind == "f" else float)
        if rows.size >= 2:
            ts, vs = t[rows], col[rows]
            when = ts + lag_s
            j = np.clip(np.searchsorted(ts, when, side="right") - 1, 0, ts.size - 2)
            step = ts[j + 1] - ts[j]
            gap = GAP_FACTOR * float(np.median(np.diff(ts)))
            inside = (when >= ts[j]) & (when <= ts[j + 1]) & (step < gap)
            frac = (when - ts[j]) / step
            out[rows] = np.where(inside, (1.0 - frac) * vs[j] + frac * vs[j + 1], np.nan)
        data[name] = out
    return replace(drive, data=data)


def drive_on_gnss_clock(drive: Drive, vehicle: Vehicle) -> tuple[Drive, ImuTiming | None]:
    """The drive with its IMU moved back by the lag its Doppler decides (:func:`choose_imu_lag`
    on :func:`sideslip.doppler_timing.timing_of`'s fit, shared with the receiver's own timing),
    and that timing; the drive itself and None without a Doppler or an IMU column."""
    if "gnss_ve" not in drive or "gnss_vn" not in drive or not any(n in drive for n in IMU_COLUMNS):
        return drive, None
    imu = choose_imu_lag(timing_of(drive, vehicle, 0.0).fit)
    return shift_imu(drive, imu.lag_s), imu
