"""The lateral accelerometer against the yaw rate and speed (sideslip.units_check)."""

from __future__ import annotations

import numpy as np
import pytest

from sideslip.drive import Drive, drive_from_columns
from sideslip.errors import InputError
from sideslip.methods.registry import run_method
from sideslip.units_check import (
    check_gnss_speed_units,
    check_lateral_axes,
    check_lateral_units,
    check_longitudinal,
    check_steer_units,
    check_tilt_rate_units,
    lateral_axes,
    steer_slope,
    tilt_excursion,
)
from sideslip.vehicle import load_vehicle
from tests.conftest import sim_drive


def _scaled(drive: Drive, factors: dict[str, float]) -> Drive:
    cols = {k: np.asarray(v) * factors.get(k, 1.0) if np.asarray(v).dtype.kind == "f" else v
            for k, v in drive.data.items()}  # fmt: skip
    return drive_from_columns({"t": drive.t, **cols}, dict(drive.meta))


def test_a_lateral_acceleration_in_g_is_named_with_its_slope():
    """race_lap with ay and ax logged in g: in its turns ay follows v wz with slope 0.10
    (0.99 in m/s^2), which no bank or roll explains; the error names the column, the first
    turning row and the units that would give it.  Every method refuses it (fused read 21 deg
    of beta RMSE from the Revs lap in g)."""
    drive = _scaled(sim_drive("race_lap"), {"ay": 1 / 9.81, "ax": 1 / 9.81})
    with pytest.raises(InputError) as err:
        check_lateral_units(drive)
    line = str(err.value)
    assert "column 'ay'" in line and "row " in line
    assert "ay follows 0.101 x speed x wz" in line and "ay in g reads 0.10" in line
    with pytest.raises(InputError, match="column 'ay'"):
        run_method("obs_bicycle", drive, load_vehicle(drive.meta["vehicle"]))


def test_a_lateral_acceleration_in_feet_per_second_squared_is_caught_under_the_range_limit():
    """urban_course with ay in ft/s^2 (at most 3.28 x 4 m/s^2, well under the 100 m/s^2
    limit): slope 1.19 x 3.28 = 3.89 of ay on v wz (measured), beyond 1.8."""
    drive = _scaled(sim_drive("urban_course"), {"ay": 3.2808})
    with pytest.raises(InputError, match=r"column 'ay': row \d+: in turns .* ay follows 3\.89"):
        check_lateral_units(drive)


def test_valid_drives_pass_including_superelevated_curves_and_a_banked_bowl():
    """urban_course reads 1.19 (roll gravity adds to the turn).  Superelevation tied to the
    curvature lowers the slope (urban_highway, to 5 deg: 0.62 measured over its turns) and a
    25 deg bowl reverses it (banked_turn seed 1: -0.51, correlation -0.77): both valid, neither
    judged here (their turns span under 1 m/s^2 of speed x wz, too narrow to decide a slope),
    neither raises.  A drive with under 10 s of turns beyond 2 m/s^2 is not judged either."""
    assert check_lateral_units(sim_drive("urban_course")) == pytest.approx(1.19, abs=0.03)
    assert check_lateral_units(sim_drive("urban_highway")) is None
    assert check_lateral_units(sim_drive("banked_turn", 1)) is None
    assert check_lateral_units(sim_drive("step_steer")) is None


def test_one_steady_turn_decides_no_slope():
    """A synthetic circle (speed x wz constant to the last digit): its least-squares slope is
    rounding (0.667 as written, 0.083 with ay / 9.81), so the drive is not judged."""
    from sideslip.drive import load_drive
    from tests.helpers import CIRCLE

    drive = load_drive(CIRCLE)
    assert check_lateral_units(drive) is None
    assert check_lateral_units(_scaled(drive, {"ay": 1 / 9.81})) is None


def _no_gnss(drive: Drive) -> Drive:
    cols = {k: np.asarray(v, dtype=float) for k, v in drive.data.items() if not k.startswith("gnss_")}
    return drive_from_columns({"t": drive.t, **cols}, dict(drive.meta))


def test_a_yaw_gyro_upside_down_without_gnss_is_named_by_the_steering_and_ay():
    """urban_course without GNSS (where the GNSS-course check cannot run), wz flipped: in its
    gentle turns wz turns against the steering and against ay / speed (correlations -1.00 /
    -1.00 measured, +1.00 / +1.00 unflipped); every method refuses the drive."""
    valid = _no_gnss(sim_drive("urban_course"))
    c_ay, c_steer, _ = lateral_axes(valid)
    assert c_ay > 0.99 and c_steer > 0.99
    check_lateral_axes(valid, uses_steer=True)  # no error
    flipped = _scaled(valid, {"wz": -1.0})
    with pytest.raises(InputError, match=r"column 'wz': row \d+: in gentle turns .* is the gyro axis flipped"):
        run_method("fused", flipped, load_vehicle(valid.meta["vehicle"]))


def test_a_steering_positive_right_stops_the_methods_that_read_it_only():
    """urban_course without GNSS, steer flipped: the steering turns against wz while ay agrees
    with wz.  obs_bicycle (which reads the steering) refuses the drive, naming steer; fused
    (which does not, FusedSettings.front_axle off) runs."""
    drive = _scaled(_no_gnss(sim_drive("urban_course")), {"steer": -1.0})
    vehicle = load_vehicle(drive.meta["vehicle"])
    with pytest.raises(InputError, match=r"column 'steer': .* is the steering positive right"):
        run_method("obs_bicycle", drive, vehicle)
    assert np.isfinite(run_method("fused", drive, vehicle)["beta"]).all()


def test_a_banked_bowl_and_short_drives_are_not_judged_on_their_axes():
    """banked_turn (25 deg): ay turns against the turn there (correlation -0.88) while the
    steering and the gyro agree, so ay alone is never judged; its 5 s of gentle turns are
    under the 10 s the check needs anyway."""
    assert lateral_axes(sim_drive("banked_turn")) is None
    check_lateral_axes(sim_drive("banked_turn"), uses_steer=True)


def test_an_imu_mounted_backwards_is_named_by_the_speeds_rate():
    """urban_course with ax and ay flipped (the IMU turned 180 deg about z): ax turns against
    the speed's rate (correlation -1.00 measured; +1.00, slope 1.03 as simulated), so every
    method refuses the drive, naming ax.  (fused read 36 deg of beta RMSE from the Revs lap so
    mounted.)"""
    valid = sim_drive("urban_course")
    assert check_longitudinal(valid) == pytest.approx(1.03, abs=0.05)
    drive = _scaled(valid, {"ax": -1.0, "ay": -1.0})
    with pytest.raises(InputError, match=r"column 'ax': row \d+: .* is the IMU mounted backwards"):
        run_method("fused", drive, load_vehicle(valid.meta["vehicle"]))


def test_time_stamps_in_milliseconds_are_named_by_the_slope_of_ax():
    """urban_course with t in ms: the speed's rate reads 1000x too small, so ax follows it
    with a slope of hundreds (756 measured: on the millisecond clock the 0.5 s mean is one row,
    so the wheel speeds' noise stays in the rate); ax in g reads 0.10."""
    drive = sim_drive("urban_course")
    cols = {k: np.asarray(v, dtype=float) for k, v in drive.data.items()}
    in_ms = drive_from_columns({"t": drive.t * 1000.0, **cols}, dict(drive.meta))
    with pytest.raises(InputError, match=r"column 'ax': .* ax follows [1-9]\d\d x the speed's rate"):
        check_longitudinal(in_ms)
    with pytest.raises(InputError, match=r"ax follows 0\.10\d x the speed's rate"):
        check_longitudinal(_scaled(drive, {"ax": 1 / 9.81}))


def test_an_imu_slower_than_the_table_is_judged_on_its_own_samples():
    """urban_course with the IMU on every second / fifth row only (NaN between its samples,
    as the contract allows for a slower sensor): the 0.5 s mean of ax is the mean of its
    samples.  Before, the empty rows counted as zeros and ax read 0.52 / 0.21 x the speed's
    rate, and every method refused the drive (the Revs lap: "ax follows 0.211")."""
    drive = sim_drive("urban_course")
    for keep in (2, 5):
        data = dict(drive.data)
        between = np.ones(len(drive), dtype=bool)
        between[::keep] = False
        for name in ("ax", "ay", "az", "wx", "wy", "wz"):
            col = drive[name].copy()
            col[between] = np.nan
            data[name] = col
        slow = Drive(drive.t, data, drive.meta, drive.path)
        assert check_longitudinal(slow) == pytest.approx(1.03, abs=0.05)
        assert check_lateral_units(slow) == pytest.approx(check_lateral_units(drive), abs=0.02)


@pytest.mark.parametrize("column", ["wx", "wy"])
def test_a_roll_or_pitch_rate_in_degrees_per_second_is_named(column):
    """urban_course with its roll (or pitch) gyro in deg/s: within the 5 rad/s range limit, but
    the angle it turns within 10 s (its mean removed) reaches 4.4 rad for the roll, 6.7 for
    the pitch (0.076 and 0.12 in rad/s); fused read the roll as the road's bank (9.6 deg beta
    RMSE).  One line naming the column,
    the window's first row and the unit."""
    drive = _scaled(sim_drive("urban_course"), {column: 180.0 / np.pi})
    with pytest.raises(InputError) as err:
        check_tilt_rate_units(drive)
    line = str(err.value)
    assert f"column '{column}': row " in line and "is it in deg/s?" in line and "\n" not in line
    with pytest.raises(InputError, match=f"column '{column}'"):
        run_method("fused", drive, load_vehicle(drive.meta["vehicle"]))


def test_a_banked_turn_and_a_drive_in_rad_per_second_pass_the_tilt_check():
    """The largest valid excursions: entering the 25-degree banked turn, 0.45 rad of roll in
    10 s (measured), under the 2 rad bound; the same drive in deg/s would read 25.7."""
    drive = sim_drive("banked_turn")
    check_tilt_rate_units(drive)
    found = tilt_excursion(drive, "wx")
    assert found is not None and 0.40 < found[0] < 0.5


@pytest.mark.parametrize(
    ("columns", "factor", "named", "ratio"),
    [
        (("gnss_ve", "gnss_vn"), 3.6, "gnss_ve", "3.6"),
        (("gnss_ve", "gnss_vn"), 1.0 / 0.514444, "gnss_ve", "1.9"),
        (("gnss_e", "gnss_n"), 0.001, "gnss_e", "0.001"),
    ],
)
def test_a_gnss_speed_in_other_units_is_named_by_the_wheels(columns, factor, named, ratio):
    """urban_course with its Doppler in km/h or knots, or its positions in km: the GNSS speed
    over the moving samples is that factor times the wheels' (valid drives: 0.99-1.00 on the
    simulated ones, 1.01 on the comma2k19 minute, measured).  Before, fused ran the km/h
    Doppler with 48 % of the drive flagged.  One line naming the GNSS column."""
    drive = _scaled(sim_drive("urban_course"), dict.fromkeys(columns, factor))
    with pytest.raises(InputError) as err:
        check_gnss_speed_units(drive)
    line = str(err.value)
    assert f"column '{named}': row " in line and f"is {ratio}" in line and "\n" not in line
    check_gnss_speed_units(sim_drive("urban_course"))  # as recorded: passes


@pytest.mark.parametrize(("scenario", "factor", "reads"), [("demo", 15.0, "19.6"), ("banked_turn", 180.0 / np.pi, "66.")])
def test_a_steering_wheel_angle_or_degrees_inside_the_range_limit_is_named(scenario, factor, reads):
    """The demo drive with steer logged as a steering-wheel angle (x15: at most 0.33, inside
    the 1.2 range limit) and banked_turn with steer in degrees (at most 0.94): in their gentle
    turns steer follows the kinematic angle L w_z / v with slope 19.6 / 66.7 (1.31 / 1.16 in
    rad).  obs_bicycle (which reads the steering) refuses the drive, naming steer, the row
    and the steering ratio; fused (which does not) runs."""
    drive = _scaled(sim_drive(scenario), {"steer": factor})
    vehicle = load_vehicle(drive.meta["vehicle"])
    with pytest.raises(InputError, match=r"column 'steer': row \d+: .*steer follows " + reads):
        run_method("obs_bicycle", drive, vehicle)
    with pytest.raises(InputError, match=r"divide a steering-wheel angle by the steering ratio"):
        check_steer_units(drive, vehicle.lf + vehicle.lr)
    assert np.isfinite(run_method("fused", drive, vehicle)["beta"]).all()


@pytest.mark.parametrize("scenario", ["urban_course", "two_turns_gyro_sf", "cr_circle", "slalom_low_mu"])
def test_road_wheel_angles_in_rad_pass_the_steering_check(scenario):
    """The steering against L w_z / v on valid drives: 1 + K_us v^2 / L for an understeering
    car, measured 0.82 (cr_circle) to 2.40 (two_turns_gyro_sf at speed) over the 16
    scenarios x seeds 0-1 where judged (the Revs lap 1.39), inside the check's 0.3-6."""
    drive = sim_drive(scenario)
    vehicle = load_vehicle(drive.meta["vehicle"])
    found = steer_slope(drive, vehicle.lf + vehicle.lr)
    assert found is not None and 0.8 <= found[0] <= 2.5 and found[1] >= 0.9
    assert check_steer_units(drive, vehicle.lf + vehicle.lr) == pytest.approx(found[0])
