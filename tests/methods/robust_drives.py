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
