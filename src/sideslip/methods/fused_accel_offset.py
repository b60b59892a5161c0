"""The lateral accelerometer's offset that the tyres do not carry, for ``fused``'s axle forces.

``fused`` measures each axle's lateral force with the accelerometer (seed 003 eqs 1-2).  A
constant error of the reading -- the sensor's bias, or g times a mounting roll -- is a force
the tyres never produce, which the rear relation turns into a constant sideslip of about
``m l_f / (L C_r)`` per m/s^2 (0.35 deg per m/s^2 on the simulator's sedan), and with GNSS
Doppler the heading follows it.  The drive's kinematics cannot tell it from a road's crossfall
(the state c_y holds both; the tyres do carry the crossfall).

Seed 000 (Takikawa et al. 2021, eqs 15-19) tells them apart in curves: the yaw gyro on a
rolled body reads the heading rate times cos(roll), and the roll a lateral reading implies
depends on its offset, so only the right offset closes each curve's heading change between
the GNSS Doppler courses before and after it.  :mod:`sideslip.methods.doppler_slip` runs that
scan (``ay_bias_m_s2`` with a 1-sigma, applied where at least five curves pin it to
0.15 m/s^2).  Here its value is combined with the prior ``N(0, prior_sigma)``
(``FusedSettings.accel_offset_sigma``) and the posterior is taken out of the axle forces.

A drive with fewer than :data:`~sideslip.methods.doppler_roll.MIN_CURVES` curves of the scan's
kind (the gyro's yaw rate above ``R_ON`` for ``MIN_CURVE_S`` turning ``MIN_TURN_RAD``, with
20 % of slack) skips the scan: it could not decide the offset, and the scan costs about half
a ``fused`` run (1.1 s per hour of 100 Hz drive).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from sideslip.drive import Drive
from sideslip.methods.doppler_roll import MIN_CURVE_S, MIN_CURVES, MIN_SPEED, MIN_TURN_RAD, R_ON
from sideslip.signals import hold, vehicle_speed
from sideslip.vehicle import Vehicle

FloatArray = NDArray[np.float64]

PRECHECK_SLACK = 0.8  # the pre-check's thresholds: this share of the scan's own


@dataclass(frozen=True)
class AccelOffset:
    """The offset (m/s^2, measured - true) taken out of the axle forces and its 1-sigma: the
    posterior with the prior where the scan decides it, else 0 and the prior's sigma.
    ``scan``: the scan's own value and 1-sigma (None where it did not run or decide)."""

    value: float
    sigma: float
    informed: bool
    note: str
    scan: tuple[float, float] | None = None

    def params(self) -> dict[str, object]:
        return {
            "accel_offset_y_m_s2": self.value,
            "accel_offset_y_m_s2_sigma": self.sigma,
            "accel_offset_y_informed": self.informed,
            "accel_offset_y_note": self.note,
            "accel_offset_y_scan_m_s2": None if self.scan is None else list(self.scan),
        }


def candidate_curves(drive: Drive) -> int:
    """Curves the heading-closure scan could use, counted generously from the gyro alone: runs
    of |w_z - the drive's median yaw rate on moving rows| above ``PRECHECK_SLACK x R_ON`` for at
    least ``PRECHECK_SLACK x MIN_CURVE_S`` that turn ``PRECHECK_SLACK x MIN_TURN_RAD``."""
    t = drive.t
    if t.size < 3 or "wz" not in drive:
        return 0
    wz, _ = hold(drive["wz"], t)
    wz = np.nan_to_num(wz)
    moving = np.abs(vehicle_speed(drive)) > MIN_SPEED
    if not moving.any():
        return 0
    rate = wz - float(np.median(wz[moving]))
    turning = (np.abs(rate) > PRECHECK_SLACK * R_ON) & moving
    edges = np.diff(np.concatenate(([0], turning.astype(np.int8), [0])))
    starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    turned = np.concatenate(([0.0], np.cumsum(rate[:-1] * np.diff(t))))
    count = 0
    for a, stop in zip(starts.tolist(), stops.tolist(), strict=True):
        b = min(stop, t.size - 1)
        long_enough = t[b] - t[a] >= PRECHECK_SLACK * MIN_CURVE_S
        if long_enough and abs(turned[b] - turned[a]) >= PRECHECK_SLACK * MIN_TURN_RAD:
            count += 1
    return count


def lateral_accel_offset(drive: Drive, vehicle: Vehicle, prior_sigma: float) -> AccelOffset:
    """The accelerometer's lateral offset for the axle forces (module docstring)."""
    prior = f"prior 0 +- {prior_sigma:g} m/s^2"
    if not ("gnss_ve" in drive and "gnss_vn" in drive and "ay" in drive):
        return AccelOffset(0.0, prior_sigma, False, f"no GNSS Doppler (no heading closure): {prior}")
    curves = candidate_curves(drive)
    if curves < MIN_CURVES:
        note = f"{curves} curves on the gyro (the scan needs {MIN_CURVES}): {prior}"
        return AccelOffset(0.0, prior_sigma, False, note)
    from sideslip.methods.doppler_slip import run_doppler_slip  # the scan and its heading fit

    try:
        p = run_doppler_slip(drive, vehicle).params
    except (RuntimeError, ValueError, ArithmeticError, np.linalg.LinAlgError) as err:
        # the scan is a refinement: a drive its heading fit cannot take keeps the prior (a
        # gyro turning against the course is an InputError and stops every method alike)
        return AccelOffset(0.0, prior_sigma, False, f"heading-closure scan failed ({err}); {prior}")
    if not p.get("ay_bias_applied", False):
        why = str(p.get("ay_bias_note", "")) or "not decided"
        return AccelOffset(0.0, prior_sigma, False, f"heading-closure scan: {why}; {prior}")
    value, sigma = float(p["ay_bias_m_s2"]), float(p["ay_bias_m_s2_sigma"])
    w_scan, w_prior = 1.0 / sigma**2, 1.0 / prior_sigma**2
    post = value * w_scan / (w_scan + w_prior)
    post_sigma = math.sqrt(1.0 / (w_scan + w_prior))
    note = (
        f"heading-closure scan in {p.get('dGy_curves', '?')} curves (seed 000 eqs 17-19): "
        f"{value:+.3f} +- {sigma:.3f} m/s^2, with the prior 0 +- {prior_sigma:g}"
    )
    return AccelOffset(post, post_sigma, True, note, (value, sigma))
