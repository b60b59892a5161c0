"""The drive's own steering zero: the offset of the ``steer`` column, for the methods whose
papers assume a zeroed steering sensor.

A steering-angle sensor reads the road-wheel angle plus an offset (CAN steering sensors sit a
few tenths of a degree of steering wheel off after an alignment or a sensor swap; the
simulator draws 0.1 deg road wheel); the vehicle's own straight-running steer (toe, ply steer,
conicity) adds to it and cannot be told from it.  Seed 001's model-based filter, seed 002's
graph and seed 003's observers feed the steer straight into the front axle's slip, so an
offset ``d0`` reads as a front-axle force ``c_f d0`` and hence as sideslip on every row.

:func:`drive_steer_offset` is ``sideslip calibrate``'s steering relation
(:mod:`sideslip.calibrate.axle_stiffness`, relation 1: ``delta_m = s_d (atan(L r / v) +
F_yf / c_f - F_yr / c_r) + delta_0``, fitted by Gauss-Newton with the file's stiffness as a
+-50 % prior) on its own, without the GNSS rear-slip relation and the rest of calibrate's
preparation: the signals are averaged onto the relation's own 0.1 s grid first
(:func:`steer_signals`), so a 24 h drive costs a few full-length passes, not calibrate's
row-grid arrays.  The yaw rate is zeroed with the drive's own gyro zero
(:func:`sideslip.calibrate.sensors.drive_gyro_bias`); the gyro and wheel scales are taken as 1
and the suspension roll gradient from the file.  The offset's 1-sigma carries the understeer
gradient times a lateral accelerometer offset and a floor for the straight-running steer, as
in calibrate, and the relation's own model error here (``RELATION_ALONE_SIGMA``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from sideslip.calibrate.axle_stiffness import SensorCal, fit_axles
from sideslip.calibrate.prepare import MAX_GAP_S, SMOOTH_S, STANDSTILL_MPS, STEER_GRID_S, moving_mean
from sideslip.calibrate.result import Fitted, left_alone, zero_params
from sideslip.calibrate.roll import file_roll_gradient
from sideslip.calibrate.sensors import ZERO_SIGNIFICANCE, drive_gyro_bias, subtracted_zero
from sideslip.drive import Drive
from sideslip.signals import interpolate, speed_raw
from sideslip.vehicle import G, Vehicle

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

# relative 1-sigma of the curvature r / v when neither gyro nor wheel scale is calibrated (1 %
# each, as calibrate's SCALE_UNKNOWN_SIGMA), and of the gyro scale (MEMS: 0.2-2 %)
CURVATURE_SCALE_SIGMA = 0.014
GYRO_SCALE_SIGMA = 0.05
# 1-sigma of the roll gradient when the file does not give it (passenger cars roll 2-8 deg/g;
# Gillespie 1992, ch. 8), rad/(m/s^2)
ROLL_UNKNOWN_SIGMA = 0.005
ROLL_FILE_REL = 0.3  # a rough file's roll gradient is 30 % off
# the relation's own model error with the rear axle's slip left to the file's stiffness (no
# GNSS relation to pin it) and the tyres read as linear up to 0.4 g, added to the fit's
# 1-sigma: measured on 48 simulated drives (16 scenarios x seeds 0-2, the simulator's Magic
# Formula tyres and CommonRoad's multi-body model), the offset's error was 0.024 deg rms
# against a fitted 1-sigma of 0.015-0.030 (z rms 1.34, 87 % inside 2 sigma; worst: a
# one-direction circle, cr_circle, 3.8 sigma); with this term z rms 1.04, 89 % inside 2 sigma
RELATION_ALONE_SIGMA = math.radians(0.015)


@dataclass(frozen=True)
class SteerSignals:
    """The steering relation's signals on the 0.1 s grid (block means of the rows, then the
    calibration's centred moving mean): time (s), yaw rate zeroed with the drive's gyro zero
    (rad/s), speed (m/s), lateral acceleration (m/s^2), steer (rad), standstill."""

    t: FloatArray
    wz: FloatArray
    speed: FloatArray
    ay: FloatArray | None
    steer: FloatArray | None
    standstill: BoolArray

    @property
    def has_gnss(self) -> bool:
        """The GNSS rear-slip relation is not used here (calibrate's joint fit has it)."""
        return False


def _block_means(x: NDArray[np.floating], edges: NDArray[np.intp]) -> FloatArray:
    """Mean of the finite samples of ``x`` over each block of rows starting at ``edges``; NaN
    where a block has none (a sensor sampled slower than the grid, or a gap)."""
    ok = np.isfinite(x)
    total = np.add.reduceat(np.where(ok, x, 0.0), edges).astype(float)
    count = np.add.reduceat(ok.astype(np.int32), edges)
    out = np.full(total.shape, np.nan)
    np.divide(total, count, out=out, where=count > 0)
    return out


def steer_signals(drive: Drive, gyro_zero: float) -> SteerSignals:
    """The signals of ``drive`` the steering relation needs, averaged onto its 0.1 s grid
    (``STEER_GRID_S``) and smoothed like calibrate's (``SMOOTH_S`` moving mean); ``gyro_zero``
    (rad/s) is subtracted from the yaw rate."""
    t = drive.t
    dtm = float(np.median(np.diff(t))) if t.size > 1 else STEER_GRID_S
    step = max(1, round(STEER_GRID_S / max(dtm, 1e-6)))
    edges = np.arange(0, t.size, step)
    tg = _block_means(t, edges)

    def grid(values: FloatArray | None) -> FloatArray | None:
        # block means of the samples, then the gaps between blocks filled as calibrate fills
        # them between samples (linear, not across MAX_GAP_S): a tenth of the work of
        # interpolating every row first
        if values is None:
            return None
        return moving_mean(tg, interpolate(_block_means(values, edges), tg, MAX_GAP_S), SMOOTH_S)

    raw_speed = speed_raw(drive)
    speed = grid(raw_speed) if raw_speed is not None else np.full(tg.size, np.nan)
    wz = grid(drive["wz"])
    assert speed is not None and wz is not None
    still = np.abs(np.nan_to_num(speed, nan=1.0)) < STANDSTILL_MPS
    return SteerSignals(
        t=tg,
        wz=wz - gyro_zero,
        speed=speed,
        ay=grid(drive.get("ay")),
        steer=grid(drive.get("steer")),
        standstill=still & np.isfinite(wz),
    )


def drive_steer_offset(
    drive: Drive, vehicle: Vehicle, gyro_zero: Fitted | None = None, signals: SteerSignals | None = None
) -> Fitted:
    """The drive's own steering offset ``delta_0`` (rad, measured minus true road-wheel angle)
    from the steering relation alone (see the module docstring); ``gyro_zero``: the drive's
    gyro zero if the caller has it (else :func:`~sideslip.calibrate.sensors.drive_gyro_bias`
    is run); ``signals``: :func:`steer_signals` with that zero, if the caller has them.  Not
    informed (the value 0) without a steer column, the mass and axle positions in the file, or
    5 s of rows in the linear range faster than 3 m/s."""
    name = "steer_offset_rad"
    if "steer" not in drive or "wz" not in drive:
        return left_alone(name, 0.0, "rad", "no steer or yaw-rate column")
    if not all(math.isfinite(getattr(vehicle, k)) for k in ("mass", "lf", "lr")):
        return left_alone(name, 0.0, "rad", "the vehicle file lacks mass or axle positions")
    if gyro_zero is None:
        gyro_zero = drive_gyro_bias(drive, vehicle)
    sig = signals if signals is not None else steer_signals(drive, subtracted_zero(gyro_zero))
    k_file = file_roll_gradient(vehicle)
    k_roll = k_file if math.isfinite(k_file) else 0.0
    k_sd = ROLL_FILE_REL * k_roll if math.isfinite(k_file) else ROLL_UNKNOWN_SIGMA
    cal = SensorCal(
        gyro_bias=0.0,
        gyro_scale=1.0,
        wheel_scale=1.0,
        roll_gradient=k_roll,
        curvature_scale_sigma=CURVATURE_SCALE_SIGMA,
        gyro_scale_sigma=GYRO_SCALE_SIGMA,
        force_scale_sigma=G * k_sd / (1.0 + G * k_roll),
    )
    fitted = {f.name: f for f in fit_axles(sig, vehicle, cal)}  # type: ignore[arg-type]
    offset = fitted[name]
    if offset.informed:
        sigma = math.hypot(offset.sigma, RELATION_ALONE_SIGMA)
        return Fitted(
            name, offset.value, sigma, offset.rows, f"{offset.source}, steering relation alone",
            True, "rad", 0.0, None, offset.note,
        )  # fmt: skip
    return offset


def subtracted_offset(offset: Fitted) -> float:
    """The part of the drive's steering offset a method subtracts (rad): the offset where the
    drive tells it and it differs from 0 by more than ``ZERO_SIGNIFICANCE`` of its 1-sigma,
    else 0 (a zeroed sensor keeps its samples rather than take on the fit's noise)."""
    if not offset.informed or abs(offset.value) <= ZERO_SIGNIFICANCE * offset.sigma:
        return 0.0
    return offset.value


def steer_zero_params(offset: Fitted) -> dict[str, object]:
    """A method's params entries for the drive's steering offset (:func:`drive_steer_offset`)."""
    zeroed = subtracted_offset(offset) != 0.0
    return zero_params(offset, "steer_offset_rad", "steer_offset", zeroed, ZERO_SIGNIFICANCE)
