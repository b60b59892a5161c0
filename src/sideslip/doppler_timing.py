"""When a drive's GNSS Doppler is late, and by how much to move its epochs.

A logger that stamps the receiver's messages on arrival stamps every epoch late, by 50-200 ms;
a Doppler velocity stamped tau late lags the heading by r tau, which in a turn reads as
sideslip (seed 000's slip from the Doppler course: 100 ms late took urban_course from 0.024 to
0.73 deg, the race lap from 0.23 to 1.36).  :func:`sideslip.gnss_latency.identify_doppler_latency`
times the Doppler without any tyre model; :func:`choose_doppler_latency` decides whether the
drive has decided it, and :func:`drive_on_receiver_time` hands the GNSS methods that do not
time the receiver themselves a drive whose epochs sit at their stamps less that latency
(:func:`sideslip.methods.registry.run_method`, which adds |r| times the latency's sigma to
their ``beta_std``; ``fused`` applies the same choice inside).
"""

from __future__ import annotations

import math
import threading
import weakref
from dataclasses import dataclass, replace

import numpy as np

from sideslip import doppler_latency_lateral, gnss_latency
from sideslip.drive import Drive
from sideslip.gnss_latency import LatencyEstimate, identify_doppler_latency
from sideslip.vehicle import Vehicle

__all__ = [
    "DopplerTiming", "antenna_geometry", "choose_doppler_latency", "doppler_fit",
    "drive_on_receiver_time", "forget_timings", "shift_gnss",
]  # fmt: skip

# a Doppler latency is applied only when this decisive ...  (was 0.015 s, set when the speed
# fit stood alone; with the course-rate fit beside it the fits are centred on the truth:
# 16 scenarios x seeds 0-1 at 0 / 0.1 / 0.2 s late, every fit within 1.3 of its sigma of the
# truth, none at a true 0 beyond 0.7 sigma (measured 2026-12-07).  0.05 s lets a drive of a
# few turns apply what it decides: a 0.2 s late Doppler on cr_limit_ramp, 0.196 +- 0.046 s
# read, fused 2.09 -> 0.11 deg; doppler_latency.md)
MAX_SIGMA_S = 0.05
# ... and a fit this decisive that is not late says "on time" (0 with the larger of its value
# and sigma); a less decisive one that is not late leaves the prior's rms
DECISIVE_SIGMA_S = 0.015
MIN_Z = 3.0  # ... and this many sigma above 0 (receivers are late, not early), the sigma with
# a floor for the fit's systematic error, which a long drive does not average away (the 1 h
# bench drive, on time: +0.015 +- 0.004 s; 17 simulated drives within 0.015 s)
FLOOR_S = 0.01
MAX_LATENCY_S = 0.5  # s: the most a receiver's epoch is taken earlier


@dataclass(frozen=True)
class DopplerTiming:
    """The latency (s) a drive's GNSS epochs are taken with (0: at their stamps), the 1-sigma
    (s) of what may remain, a note saying why, and the fit (None where nothing was fitted)."""

    latency_s: float
    sigma_s: float
    note: str
    fit: LatencyEstimate | None

    @property
    def early(self) -> bool:
        """The decisive fit reads the Doppler early against the IMU by more than
        :data:`MIN_Z` sigma: not applied (receivers are late, not early), but the inputs
        disagree in time by about that much; ``sigma_s`` holds it.  (An IMU stamped late
        while the wheels are on time is moved back before the receiver is timed,
        :mod:`sideslip.imu_timing`; this remains where the wheels read late with it.)"""
        fit = self.fit
        if fit is None or self.latency_s != 0.0 or fit.sigma_s > DECISIVE_SIGMA_S:
            return False
        return fit.latency_s <= -MIN_Z * math.hypot(fit.sigma_s, FLOOR_S)


def choose_doppler_latency(fit: LatencyEstimate | None, prior_sigma_s: float) -> DopplerTiming:
    """The latency to take the epochs with, from the tyre-free fit: where the fit decides it
    (sigma at most :data:`MAX_SIGMA_S`) and it is late by more than :data:`MIN_Z` sigma (the
    fit's, with :data:`FLOOR_S`), that latency with that sigma; a decisive fit (sigma at most
    :data:`DECISIVE_SIGMA_S`) that is not late leaves 0 with the larger of the sigma and the
    fit's value.  Otherwise the epochs stay at their stamps and the sigma is the root mean
    square of the latency about 0 under the fit combined with the prior N(0,
    ``prior_sigma_s``): the prior's sigma where the drive tells nothing, up to about the
    fit's value where it tells something but not enough to move the epochs.

    The guards keep a fit that the drive does not inform from moving the epochs: the speed
    fit alone read race_lap (limit slip) and urban_highway (few speed changes) +0.04 to +0.3 s
    at a true 0, with sigmas of 0.05-0.15 s; a negative value means the wheels' clock is late
    (a filtered CAN speed), not the receiver's."""
    if fit is None:
        note = (
            "not identified: too few usable Doppler epochs above 3 m/s (the speed fit needs"
            f" {gnss_latency.MIN_FIXES}, the course-rate fit {doppler_latency_lateral.MIN_EPOCHS}"
            " from a receiver at 5 Hz or faster)"
        )
        return DopplerTiming(0.0, prior_sigma_s, note, None)
    sigma = math.hypot(fit.sigma_s, FLOOR_S)
    late = fit.latency_s >= MIN_Z * sigma and fit.sigma_s <= MAX_SIGMA_S
    if not late and fit.sigma_s > DECISIVE_SIGMA_S:
        rms = 0.0
        if prior_sigma_s > 0.0:
            rms = math.hypot(fit.posterior_mean(prior_sigma_s), fit.posterior_sigma(prior_sigma_s))
        return DopplerTiming(0.0, rms, "not applied: the drive does not decide it", fit)
    if not late:
        timing = DopplerTiming(
            0.0, max(abs(fit.latency_s), sigma), "not applied: not late beyond the fit's errors", fit
        )
        if timing.early:
            note = (
                f"not applied: the Doppler reads {-fit.latency_s:.3f} +- {fit.sigma_s:.3f} s early "
                "against the gyro (receivers are late, not early: the IMU and the wheels stamped "
                "late?); |r| times that is in beta_std"
            )
            timing = replace(timing, note=note)
        return timing
    tau = min(fit.latency_s, MAX_LATENCY_S)
    return DopplerTiming(tau, sigma, "each GNSS epoch taken this long before its stamp", fit)


def shift_gnss(drive: Drive, latency_s: float) -> Drive:
    """``drive`` with every GNSS sample (every ``gnss_*`` column) moved to the row nearest its
    stamp less ``latency_s``; samples that would fall before the first row are dropped, and
    of two samples that meet on one row the later stays."""
    names = [k for k in drive.data if k.startswith("gnss_")]
    if latency_s == 0.0 or not names:
        return drive
    t = drive.t
    data = dict(drive.data)
    for name in names:
        col = np.asarray(drive.data[name])
        rows = np.flatnonzero(np.isfinite(col))
        when = t[rows] - latency_s
        keep = when >= t[0] - 0.5 * drive.dt_median
        at = np.clip(np.searchsorted(t, when[keep]), 0, t.size - 1)
        before = np.clip(at - 1, 0, t.size - 1)
        at = np.where(np.abs(t[before] - when[keep]) < np.abs(t[at] - when[keep]), before, at)
        moved = np.full(t.size, np.nan, dtype=col.dtype)
        moved[at] = col[rows[keep]]
        data[name] = moved
    return replace(drive, data=data)


# the last drives timed: id -> (weak reference to the drive, geometry, timing), so that the
# methods of one `sideslip estimate` run time a drive once
_TIMED: dict[int, tuple[weakref.ref[Drive], tuple[float, float, float], LatencyEstimate | None]] = {}
_TIMED_MAX = 4
_TIMED_LOCK = threading.Lock()  # a Dask worker's threads run methods side by side


def forget_timings() -> None:
    """Drop the drives timed so far (a benchmark times each run from scratch)."""
    with _TIMED_LOCK:
        _TIMED.clear()


def antenna_geometry(vehicle: Vehicle) -> tuple[float, float, float]:
    """The antenna ahead of and above the IMU, and the CG's distance to the rear axle (m):
    the geometry :func:`sideslip.gnss_latency.identify_doppler_latency` takes."""
    ahead = float(vehicle.gnss_xyz[0] - vehicle.imu_xyz[0])
    above = float(vehicle.gnss_xyz[2] - vehicle.imu_xyz[2])
    return ahead, above, float(vehicle.lr)


def timing_of(drive: Drive, vehicle: Vehicle, prior_sigma_s: float) -> DopplerTiming:
    """:func:`choose_doppler_latency` for ``drive`` (fitted once per drive and vehicle
    geometry while the drive lives)."""
    return choose_doppler_latency(doppler_fit(drive, antenna_geometry(vehicle)), prior_sigma_s)


def doppler_fit(drive: Drive, geometry: tuple[float, float, float]) -> LatencyEstimate | None:
    """:func:`sideslip.gnss_latency.identify_doppler_latency` for ``drive`` with the antenna
    ``geometry`` (:func:`antenna_geometry`), fitted once per drive and geometry while the
    drive lives: the IMU's timing, the receiver's and ``fused`` share it (a third of a second
    per hour of drive)."""
    with _TIMED_LOCK:
        hit = _TIMED.get(id(drive))
    if hit is not None and hit[0]() is drive and hit[1] == geometry:
        fit = hit[2]
    else:
        fit = identify_doppler_latency(drive, *geometry)
        with _TIMED_LOCK:
            while len(_TIMED) >= _TIMED_MAX:
                _TIMED.pop(next(iter(_TIMED)))
            _TIMED[id(drive)] = (weakref.ref(drive), geometry, fit)
    return fit


def drive_on_receiver_time(drive: Drive, vehicle: Vehicle) -> tuple[Drive, DopplerTiming | None]:
    """The drive with its GNSS epochs at their stamps less the latency the drive decides
    (:func:`choose_doppler_latency` with no prior: where the drive does not decide it the
    epochs stay), and the timing; the drive itself and None without a Doppler."""
    if "gnss_ve" not in drive or "gnss_vn" not in drive:
        return drive, None
    timing = timing_of(drive, vehicle, 0.0)
    return shift_gnss(drive, timing.latency_s), timing
