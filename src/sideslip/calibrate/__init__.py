"""Vehicle and sensor calibration from one drive (``sideslip calibrate``).

:func:`calibrate` identifies, each with its 1-sigma and the number of rows that informed it:
wheel-speed scale, gyro bias and scale (:mod:`.sensors`); suspension roll gradient and IMU
yaw / roll mounting misalignment (:mod:`.roll`); effective front / rear axle cornering
stiffness, steering scale and offset (hence the steering ratio), understeer gradient and seed
000's slip gain K (:mod:`.axle_stiffness`).  GNSS Doppler gives sideslip (course minus gyro
heading), the speed scale and the gyro scale; without it the steering / yaw-rate /
lateral-acceleration consistency gives what it can.  Parameters the drive cannot inform keep
the file's value, and the result says so (:class:`.result.Calibration`).  The fitted vehicle
is written by :func:`calibration_toml` (loads with :func:`sideslip.vehicle.load_vehicle`).

Cost: a few passes over the rows (moving means, bincounts, small least squares), linear in the
drive's length.
"""

from __future__ import annotations

import datetime as _dt
import math

from sideslip.calibrate.axle_stiffness import SensorCal, fit_axles
from sideslip.calibrate.prepare import AY_LINEAR_MAX, RDOT_MAX, V_GNSS_MIN, V_STEER_MIN, prepare
from sideslip.calibrate.result import Calibration, Fitted, left_alone
from sideslip.calibrate.roll import file_roll_gradient, misalignment_fits, roll_from_gnss
from sideslip.calibrate.sensors import gyro_bias_scale, wheel_speed_scale
from sideslip.calibrate.wheel_yaw import wheel_gyro_zero
from sideslip.drive import SPEED_COLUMNS, Drive
from sideslip.errors import InputError
from sideslip.imu_lever import drive_at_cg
from sideslip.vehicle import G, Vehicle, vehicle_to_toml

__all__ = ["Calibration", "Fitted", "calibrate", "calibration_toml"]

SCALE_UNKNOWN_SIGMA = 0.014  # relative 1-sigma of s_w / s_g when no GNSS tells them (1 % each)
# 1-sigma of the roll gradient when neither the drive nor the file gives it: passenger cars
# roll 2-8 deg/g, i.e. 0.004-0.014 rad/(m/s^2) (Gillespie 1992, ch. 8)
ROLL_UNKNOWN_SIGMA = 0.005

GATES = {
    "steering relation": f"v > {V_STEER_MIN:g} m/s, |f_y| < {AY_LINEAR_MAX:.2f} m/s^2 (0.4 g), "
    f"|r'| < {RDOT_MAX:g} rad/s^2, not standing",
    "GNSS relations": f"Doppler speed > {V_GNSS_MIN:g} m/s, consecutive epochs, |f_y| < 0.4 g, "
    "multipath outliers (> 5 robust sigma) dropped",
    "wheel-speed scale": "straight (|course rate| < 0.05 rad/s), |a_x| < 0.5 m/s^2",
    "gyro bias": "standstill (wheels and GNSS at rest) and GNSS course windows",
}


def _need_columns(drive: Drive) -> None:
    if "wz" not in drive:
        raise InputError(
            drive.path, "calibrate needs the yaw-rate gyro, which is missing or empty", column="wz"
        )
    if not any(c in drive for c in SPEED_COLUMNS):
        raise InputError(
            drive.path,
            "calibrate needs a speed (one of v_fl, v_fr, v_rl, v_rr, v_can), missing or empty",
            column="v_can",
        )


def _roll_stiffness(vehicle: Vehicle, roll: Fitted) -> Fitted:
    """The file's roll stiffness that makes its steady roll m h f_y / (k - m g h) match."""
    if not roll.informed or vehicle.missing(["mass", "cg_height", "roll_axis_height"]) or roll.value <= 0:
        why = "roll gradient not identified" if not roll.informed else "the file lacks mass / heights"
        return left_alone("roll_stiffness", vehicle.roll_stiffness, "N m/rad", why, "roll_stiffness")
    mh = vehicle.mass * (vehicle.cg_height - vehicle.roll_axis_height)
    k = mh * (1.0 / roll.value + G)
    if not 1e3 <= k <= 1e7:
        return left_alone(
            "roll_stiffness", vehicle.roll_stiffness, "N m/rad", "roll gradient absurd", "roll_stiffness"
        )
    sigma = mh * roll.sigma / roll.value**2
    return Fitted(
        "roll_stiffness",
        k,
        sigma,
        roll.rows,
        "k = m h (1 / roll gradient + g)",
        True,
        "N m/rad",
        vehicle.roll_stiffness,
        "roll_stiffness",
        "matches the fitted roll gradient (truth-model form)",
    )


def calibrate(drive: Drive, vehicle: Vehicle) -> Calibration:
    """Identify the vehicle and sensor calibration of ``drive`` starting from ``vehicle``."""
    _need_columns(drive)
    vehicle.need("mass", "lf", "lr")
    # the accelerometer as read at the CG, where the force balances hold (sideslip.imu_lever)
    drive, _ = drive_at_cg(drive, vehicle, causal=False)
    sig = prepare(drive, vehicle.gnss_xyz)
    wheel = wheel_speed_scale(sig)
    bias, gscale = gyro_bias_scale(sig)
    if not bias.informed:  # no GNSS course, no standstill: the rear wheels' speed difference
        wheels = wheel_gyro_zero(drive, vehicle.track_rear)
        bias = wheels if wheels.informed else bias
    roll, yaw_mis = roll_from_gnss(sig, vehicle)
    yaw_fit, roll_mis = misalignment_fits(sig, yaw_mis, bias.value, gscale.value)
    k_roll = roll.value if math.isfinite(roll.value) else file_roll_gradient(vehicle)
    k_roll = k_roll if math.isfinite(k_roll) else 0.0
    k_sd = roll.sigma if math.isfinite(roll.sigma) else ROLL_UNKNOWN_SIGMA
    if gscale.informed and wheel.informed:
        curv_sd = math.hypot(gscale.sigma / gscale.value, wheel.sigma / wheel.value)
    else:
        curv_sd = SCALE_UNKNOWN_SIGMA
    cal = SensorCal(
        bias.value,
        gscale.value,
        wheel.value,
        k_roll,
        curv_sd,
        gscale.sigma / gscale.value if gscale.informed else 0.05,
        G * k_sd / (1.0 + G * k_roll),
    )
    axles = fit_axles(sig, vehicle, cal)
    fitted = [*axles, roll, _roll_stiffness(vehicle, roll), wheel, bias, gscale, yaw_fit, roll_mis]
    changes = {}
    for f in fitted:
        if f.informed and f.file_key is not None:
            key = "understeer_gradient_given" if f.file_key == "understeer_gradient" else f.file_key
            changes[key] = f.value
    fitted_vehicle = vehicle.with_changes(**changes)
    notes = [f"{f.name}: left as it was ({f.note})" for f in fitted if not f.informed]
    if not sig.has_gnss:
        notes.insert(0, "no GNSS Doppler: sideslip, speed scale and gyro scale not observable")
    if math.isnan(roll.value) or not roll.informed:
        src = "the file's" if math.isfinite(file_roll_gradient(vehicle)) else "no (0)"
        notes.append(f"lateral tyre force uses {src} roll gradient")
    return Calibration(tuple(fitted), fitted_vehicle, tuple(notes), dict(GATES))


def _fmt(x: float) -> str:
    return f"{x:.6g}" if math.isfinite(x) else "nan"


def calibration_toml(cal: Calibration, drive_name: str, vehicle_name: str) -> str:
    """The fitted vehicle as TOML: a comment per fitted value (value, 1-sigma, rows, source),
    sensor calibrations in ``[calibration]`` and what was left alone in ``[notes]``."""
    comments: dict[str, str] = {}
    for f in cal.fitted:
        if f.file_key is None:
            continue
        if f.informed:
            comments[f.file_key] = (
                f"fitted {_fmt(f.value)} +- {_fmt(f.sigma)} (1-sigma) {f.unit} from {f.rows} rows: "
                f"{f.source}; was {_fmt(f.before)}" + (f"; {f.note}" if f.note else "")
            )
        else:
            comments[f.file_key] = f"left as it was: {f.note}"
    table: list[tuple[str, float | str, str]] = []
    for f in cal.fitted:
        if f.file_key is not None or not f.informed:
            continue
        table.append(
            (
                f.name,
                f.value,
                f"1-sigma {_fmt(f.sigma)} {f.unit}, {f.rows} rows: {f.source}"
                + (f"; {f.note}" if f.note else ""),
            )
        )
        table.append((f"{f.name}_sigma", f.sigma, ""))
    notes: list[tuple[str, float | str, str]] = [
        ("calibrated_from", drive_name, ""),
        ("starting_vehicle", vehicle_name, ""),
        ("written", f"{_dt.datetime.now(_dt.UTC):%Y-%m-%d %H:%M} UTC", ""),
    ]
    notes += [(f"left_{k}", line, "") for k, line in enumerate(cal.notes)]
    header = [
        f"Vehicle file fitted by `sideslip calibrate` from {drive_name}, starting from {vehicle_name}.",
        "Fitted keys carry their value, 1-sigma, rows and source in the comment above them;",
        "[calibration] holds the sensor calibration (measured / true scales), [notes] what was left.",
    ]
    return vehicle_to_toml(cal.vehicle, comments, {"calibration": table, "notes": notes}, header=header)
