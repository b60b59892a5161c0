"""Drives shared by the seed-001 filter tests (kkf, mkf, mkf_adaptive): a linear-model drive
with an analytic truth, an awkward drive (standstill, reverse, outage, gaps) and a raw phone
gyro's drive."""

from __future__ import annotations

import functools
import math

import numpy as np

from sideslip.drive import Drive, drive_from_columns
from sideslip.models.single_track import continuous, discretise
from sideslip.models.single_track import steady_state as st_gain
from sideslip.vehicle import Vehicle, load_vehicle

BLAZER = load_vehicle("blazer_suv")


@functools.lru_cache(maxsize=1)
def raw_gyro_demo() -> Drive:
    """demo, seed 3, with a turn-on gyro bias of 4 deg/s 1-sigma (the draw: -4.8 deg/s on the
    yaw axis, a raw phone gyro's size; comma2k19's is -3.9), simulated once."""
    from sideslip.simulate import SensorConfig, simulate
    from sideslip.simulate.scenarios import SCENARIOS

    cfg = SensorConfig().with_overrides(
        {**SCENARIOS["demo"].sensor_overrides, "gyro_bias_std": math.radians(4.0)}
    )
    return simulate("demo", seed=3, config=cfg)


def yaw_err_deg(yaw: np.ndarray, drive: Drive) -> np.ndarray:
    """|yaw - ref_yaw| wrapped, deg, on every row."""
    return np.degrees(np.abs(np.angle(np.exp(1j * (yaw - drive["ref_yaw"])))))


def rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(x))))


def linear_drive(
    vehicle: Vehicle = BLAZER,
    *,
    speed: float = 20.0,
    radius: float = 100.0,
    gyro_scale: float = 0.0,
    gyro_bias: float = 0.005,
    seed: int = 0,
    gnss_hz: float = 10.0,
) -> Drive:
    """Straight 20 s, 180 deg turn, straight 20 s on the linear single-track model at 100 Hz."""
    rng = np.random.default_rng(seed)
    rate = 100.0
    dt = 1.0 / rate
    t_turn = math.pi * radius / speed
    segs = [(20.0, 0.0), (t_turn, 1.0 / radius), (20.0, 0.0)]
    n = int(sum(s[0] for s in segs) * rate)
    t = np.arange(n) * dt
    curv = np.zeros(n)
    t0 = 0.0
    for dur, c in segs:
        curv[(t >= t0) & (t < t0 + dur)] = c
        t0 += dur
    k = int(2 * rate)
    curv = np.convolve(curv, np.ones(k) / k, mode="same")
    model = continuous(vehicle, speed)
    delta = curv * speed / st_gain(model)[1, 0]
    Ad, Bd = discretise(model.A, model.B, dt)
    x = np.zeros(2)
    X = np.zeros((n, 2))
    for i in range(n):
        X[i] = x
        x = Ad @ x + Bd @ np.array([delta[i], 0.0])
    beta, r = X[:, 0], X[:, 1]
    yaw = 0.3 + np.concatenate(([0.0], np.cumsum(r[:-1]) * dt))
    nu = yaw + beta
    step = int(rate / gnss_hz)
    ve = np.full(n, np.nan)
    vn = np.full(n, np.nan)
    ve[::step] = speed * np.cos(nu[::step]) + rng.normal(0, 0.05, n)[::step]
    vn[::step] = speed * np.sin(nu[::step]) + rng.normal(0, 0.05, n)[::step]
    cols = {
        "t": t,
        "wz": (1 + gyro_scale) * r + gyro_bias + rng.normal(0, math.radians(0.3), n),
        "steer": delta,
        "v_rl": np.full(n, speed),
        "v_rr": np.full(n, speed),
        "gnss_ve": ve,
        "gnss_vn": vn,
        "ref_beta": beta,
        "ref_yaw": yaw,
        "ref_r": r,
    }
    return drive_from_columns(cols, {"vehicle": "blazer_suv"})


def awkward_drive() -> Drive:
    """Standstill, pull away, GNSS outage, gyro gap, slow reverse: all normal driving."""
    rate = 100.0
    t = np.arange(0, 60, 1 / rate)
    n = t.size
    rng = np.random.default_rng(5)
    speed = np.zeros(n)
    speed[(t >= 5) & (t < 40)] = np.clip((t[(t >= 5) & (t < 40)] - 5) * 2.0, 0, 15)
    speed[(t >= 45) & (t < 55)] = -2.0
    r = np.where((t > 20) & (t < 30), 0.1, 0.0) * (speed > 0)
    yaw = np.cumsum(r) / rate
    wz = r + 0.003 + rng.normal(0, 0.003, n)
    wz[(t > 25) & (t < 26)] = np.nan
    course = yaw + np.where(speed < 0, np.pi, 0.0)
    ve = np.abs(speed) * np.cos(course) + rng.normal(0, 0.05, n)
    vn = np.abs(speed) * np.sin(course) + rng.normal(0, 0.05, n)
    keep = (np.arange(n) % 10 == 0) & ~((t > 30) & (t < 38))
    ve[~keep] = np.nan
    vn[~keep] = np.nan
    steer = r * 2.6 / np.maximum(speed, 1.0)
    cols = {"t": t, "wz": wz, "steer": steer, "v_rl": speed, "v_rr": speed,
            "gnss_ve": ve, "gnss_vn": vn}  # fmt: skip
    return drive_from_columns(cols, {})


def turns(drive: Drive) -> list[tuple[int, int]]:
    """(start, end) rows of the turns, from the reference yaw rate (test-side truth only)."""
    turning = np.abs(drive["ref_r"]) > 0.1
    edges = np.flatnonzero(np.diff(turning.astype(int)))
    return list(zip(edges[::2].tolist(), edges[1::2].tolist(), strict=False))


def beta_err_deg(est_beta: np.ndarray, drive: Drive) -> np.ndarray:
    return np.degrees(est_beta - drive["ref_beta"])


