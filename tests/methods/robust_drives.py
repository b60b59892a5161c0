"""Drives that every method must survive (not a test module): reversing, gaps, bad vehicles."""

from __future__ import annotations

import functools
import math

import numpy as np

from sideslip.drive import Drive, drive_from_columns
from sideslip.simulate import drive_from_truth
from sideslip.simulate.driver import OpenLoopPlan
from sideslip.simulate.road import road_from_pieces, straight
from sideslip.simulate.vehicle_model import simulate_truth_full
from sideslip.vehicle import load_vehicle


@functools.lru_cache(maxsize=4)
def parking_drive(seed: int = 0) -> Drive:
    """Forward at 8 m/s with gentle steering, stop, reverse at 2 m/s with 10 deg of left steer,
    stop again: 45 s of the nonlinear truth model with the default sensor grades."""
    car = load_vehicle("midsize_sedan")
    t = np.arange(0.0, 45.5, 0.005)
    speed = np.select([t < 18.0, t < 23.0, t < 38.0], [8.0, 0.0, -2.0], 0.0)
    steer = np.select(
        [t < 5.0, t < 15.0, t < 23.0, t < 38.0],
        [0.0, math.radians(3.0) * np.sin(2 * np.pi * (t - 5.0) / 10.0), 0.0, math.radians(10.0)],
        0.0,
    )
    plan = OpenLoopPlan(t=t, steer=steer, speed=speed, v0=0.0)
    road = road_from_pieces(straight(2000.0), mu=((0.0, 0.9),))
    truth, _ = simulate_truth_full(car, road, plan, 45.0, rng=np.random.default_rng(seed))
    return drive_from_truth(truth, car, seed, scenario="parking", vehicle_ref="midsize_sedan")


def with_sensor_gaps(drive: Drive, seed: int = 0) -> Drive:
    """The drive with 1.5 s holes in the IMU and wheel speeds and a 20 s GNSS outage."""
    rng = np.random.default_rng(seed)
    cols = {"t": drive.t, **{k: np.array(v, copy=True) for k, v in drive.data.items()}}
    n = len(drive)
    for _ in range(3):
        a = int(rng.integers(0, max(1, n - 200)))
        for name in ("ax", "ay", "az", "wx", "wy", "wz", "v_fl", "v_fr", "v_rl", "v_rr", "v_can"):
            if name in cols:
                cols[name][a : a + 150] = np.nan
    mid = drive.t[n // 2]
    gone = (drive.t > mid - 10.0) & (drive.t < mid + 10.0)
    for name in ("gnss_e", "gnss_n", "gnss_u", "gnss_ve", "gnss_vn", "gnss_vu", "gnss_pos_std", "gnss_vel_std"):
        if name in cols:
            cols[name][gone] = np.nan
    return drive_from_columns(cols, dict(drive.meta), drive.path)


# ------------------------------------------------------------------------------------------
# gaps a driver meets (issue 17 point 4)
# ------------------------------------------------------------------------------------------
def _columns(drive: Drive) -> dict[str, np.ndarray]:
    return {"t": drive.t.copy(), **{k: np.array(v, copy=True) for k, v in drive.data.items()}}


IMU_AND_WHEELS = ("ax", "ay", "az", "wx", "wy", "wz", "v_fl", "v_fr", "v_rl", "v_rr", "v_can")
WHEELS = ("v_fl", "v_fr", "v_rl", "v_rr", "v_can")
GNSS = ("gnss_e", "gnss_n", "gnss_u", "gnss_ve", "gnss_vn", "gnss_vu", "gnss_pos_std", "gnss_vel_std")


@functools.lru_cache(maxsize=2)
def standstill_hour_drive(seed: int = 0) -> Drive:
    """An hour parked with the engine on, from the truth model at 10 Hz (IMU, wheels, CAN,
    steering at 10 Hz, GNSS at 1 Hz with its drifting position error): cheap to build, long
    enough for every random walk and bias model to run for an hour without motion."""
    from sideslip.simulate.sensors import SensorConfig

    car = load_vehicle("midsize_sedan")
    duration = 3600.0
    t = np.array([0.0, duration])
    plan = OpenLoopPlan(t=t, steer=np.zeros(2), speed=np.zeros(2), v0=0.0)
    road = road_from_pieces(straight(100.0), mu=((0.0, 0.9),))
    truth, _ = simulate_truth_full(car, road, plan, duration, dt=0.1, rng=np.random.default_rng(seed))
    cfg = SensorConfig(imu_rate_hz=10.0, wheel_rate_hz=10.0, can_speed_rate_hz=10.0,
                       steer_rate_hz=10.0, gnss_rate_hz=1.0)
    return drive_from_truth(truth, car, seed, config=cfg, scenario="standstill_hour",
                            vehicle_ref="midsize_sedan")


@functools.lru_cache(maxsize=2)
def khz_drive(seed: int = 0) -> Drive:
    """20 s of weaving at 15 m/s from the truth model on a 1 kHz table: IMU at 1 kHz, wheels
    and steering at 100 Hz, CAN speed at 50 Hz, GNSS at 10 Hz."""
    from sideslip.simulate.sensors import SensorConfig

    car = load_vehicle("midsize_sedan")
    duration = 20.0
    t = np.arange(0.0, duration + 0.01, 0.01)
    steer = math.radians(2.0) * np.sin(2 * np.pi * t / 4.0) * (t > 2.0)
    plan = OpenLoopPlan(t=t, steer=steer, speed=np.full(t.size, 15.0), v0=15.0)
    road = road_from_pieces(straight(2000.0), mu=((0.0, 0.9),))
    truth, _ = simulate_truth_full(car, road, plan, duration, dt=0.001, rng=np.random.default_rng(seed))
    cfg = SensorConfig(imu_rate_hz=1000.0, wheel_rate_hz=100.0, can_speed_rate_hz=50.0,
                       steer_rate_hz=100.0, gnss_rate_hz=10.0)
    return drive_from_truth(truth, car, seed, config=cfg, scenario="khz", vehicle_ref="midsize_sedan")


def one_hz(drive: Drive) -> Drive:
    """Every 100th row of a 100 Hz drive: a 1 Hz table (GNSS at 10 Hz keeps one fix a row)."""
    keep = np.arange(0, len(drive), 100)
    cols = {k: v[keep] for k, v in _columns(drive).items()}
    return drive_from_columns(cols, dict(drive.meta), drive.path)


def with_wheel_lock(drive: Drive, start_s: float = 40.0, length_s: float = 1.5) -> Drive:
    """Locked wheels under hard braking: all four wheel speeds (and CAN speed) read 0 for
    ``length_s`` while the car still moves; the IMU and GNSS see the real motion."""
    cols = _columns(drive)
    lock = (drive.t >= drive.t[0] + start_s) & (drive.t < drive.t[0] + start_s + length_s)
    for name in WHEELS:
        if name in cols:
            cols[name][lock & np.isfinite(cols[name])] = 0.0
    return drive_from_columns(cols, dict(drive.meta), drive.path)


def with_dropout(drive: Drive, start_s: float = 50.0, length_s: float = 10.0) -> Drive:
    """A 10 s dropout of the IMU and the wheel speeds (NaN), GNSS still there."""
    cols = _columns(drive)
    gap = (drive.t >= drive.t[0] + start_s) & (drive.t < drive.t[0] + start_s + length_s)
    for name in IMU_AND_WHEELS:
        if name in cols:
            cols[name][gap] = np.nan
    return drive_from_columns(cols, dict(drive.meta), drive.path)


def with_duplicated_gnss(drive: Drive, every: int = 5) -> Drive:
    """A receiver that re-sends an old epoch: every ``every``-th GNSS row repeats the previous
    fix (position, velocity and their sigmas) on its own, later row."""
    cols = _columns(drive)
    rows = np.flatnonzero(np.isfinite(cols["gnss_e"]))
    for k in range(every, rows.size, every):
        for name in GNSS:
            if name in cols:
                cols[name][rows[k]] = cols[name][rows[k - 1]]
    return drive_from_columns(cols, dict(drive.meta), drive.path)


def with_clock_jump(drive: Drive, at_s: float = 60.0, jump_s: float = 3600.0) -> Drive:
    """The logger's clock jumps forward by ``jump_s`` (an hour) at ``at_s``; the samples go on
    as before, so every sensor sees one very long step."""
    cols = _columns(drive)
    cols["t"] = np.where(drive.t >= drive.t[0] + at_s, drive.t + jump_s, drive.t)
    return drive_from_columns(cols, dict(drive.meta), drive.path)
