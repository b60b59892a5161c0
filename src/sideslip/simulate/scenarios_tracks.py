"""Builders of the open-loop and test-track scenarios (seeds 001, 002 and 003).

Each builder is ``build(rng, vehicle) -> (Road, Plan)`` for
:class:`~sideslip.simulate.scenarios.Scenario`.  Open-loop manoeuvres (step steer, slalom) are
sized by the driving vehicle's linear steady-state lateral acceleration (ISO 7401 style);
the others are driven by the preview driver of :mod:`sideslip.simulate.driver`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from sideslip.simulate.driver import OpenLoopPlan, PathPlan, Plan, speed_profile
from sideslip.simulate.road import (
    Piece,
    Road,
    road_from_pieces,
    road_from_xy,
    straight,
    turn,
    with_roughness,
)
from sideslip.vehicle import Vehicle

KMH = 1.0 / 3.6  # m/s per km/h


# ---- helpers --------------------------------------------------------------------------------
def pieces_length(pieces: Sequence[Piece]) -> float:
    """Length of a sequence of road pieces, m."""
    return float(sum(p[0] for p in pieces))


def _open_loop(
    duration: float, steer: Callable[[np.ndarray], np.ndarray], speed: float, noise_deg: float
) -> OpenLoopPlan:
    t = np.arange(0.0, duration + 0.5, 0.005)
    return OpenLoopPlan(
        t=t, steer=steer(t), speed=np.full(t.size, speed), v0=speed, steer_noise_deg=noise_deg
    )


# ---- seed 003 (Table 2, CarSim): four manoeuvres of the passenger car -----------------------
def _linear_steer(vehicle: Vehicle, speed: float, ay: float, max_deg: float = 10.0) -> float:
    """Road-wheel steer giving a steady-state ``ay`` (m/s^2) in the linear single-track model.

    Open-loop tests are specified by their steady-state lateral acceleration (ISO 7401), so the
    manoeuvre suits whichever vehicle drives it; ``max_deg`` caps the amplitude (deg).
    """
    steer = ay * (vehicle.wheelbase + vehicle.understeer_gradient * speed**2) / speed**2
    return min(steer, max_deg * math.pi / 180.0)


def build_step_steer(rng: np.random.Generator, vehicle: Vehicle) -> tuple[Road, Plan]:
    road = road_from_pieces(straight(1500.0), mu=((0.0, 0.85),))
    v = 80 * KMH
    # a steady-state a_y of 4.2 m/s^2 (0.5 mu g): 1.5 deg road wheel for seed003_sedan
    amp = _linear_steer(vehicle, v, 4.2)
    plan = _open_loop(12.0, lambda t: np.where(t >= 2.0, amp, 0.0), v, 0.01)
    return road, plan


def build_slalom(rng: np.random.Generator, vehicle: Vehicle) -> tuple[Road, Plan]:
    road = road_from_pieces(straight(1500.0), mu=((0.0, 0.25),))
    v = 140 * KMH
    # amplitude for a linear steady-state a_y of 3.2 m/s^2 (0.45 deg road wheel for
    # seed003_sedan); at 0.5 Hz the response peaks near the 0.25 g friction limit.  Capped at
    # 1 deg: a strongly understeering car would otherwise saw at a sliding front axle.
    amp = _linear_steer(vehicle, v, 3.2, max_deg=1.0)

    def steer(t: np.ndarray) -> np.ndarray:
        return np.where((t >= 2.0) & (t <= 18.0), amp * np.sin(2 * math.pi * 0.5 * (t - 2.0)), 0.0)

    return road, _open_loop(22.0, steer, v, 0.005)


def build_banked_turn(rng: np.random.Generator, vehicle: Vehicle) -> tuple[Road, Plan]:
    # straight, then a right turn (R 150 m) whose bank ramps 0 -> 25 deg on the entry clothoid
    # (right edge lower: the inside of a right turn, positive in the roll sign).
    tr = 60.0
    pieces = straight(150.0) + turn(-90.0, 150.0, tr) + straight(500.0)
    s_exit = 150.0 + pieces_length(turn(-90.0, 150.0, tr))
    road = road_from_pieces(
        pieces, bank_deg=((150.0, 0.0), (150.0 + tr, 25.0), (s_exit - tr, 25.0), (s_exit, 0.0))
    )
    v = speed_profile(road, 80 * KMH, 8.0, 2.0, 3.0, v_start=80 * KMH, v_end=80 * KMH)
    return road, PathPlan(v_profile=v, v0=80 * KMH, steer_noise_deg=0.01)


def build_dlc_bank(rng: np.random.Generator, vehicle: Vehicle) -> tuple[Road, Plan]:
    # double lane change (3.5 m offset, 40 m transitions, 25 m in the other lane) on a road
    # whose bank ramps from 0 to 16 deg before the manoeuvre.
    x = np.arange(0.0, 900.0, 0.05)
    x0, lc, hold, off = 300.0, 40.0, 25.0, 3.5

    def ramp(u: np.ndarray) -> np.ndarray:
        u = np.clip(u, 0.0, 1.0)
        return 0.5 * (1.0 - np.cos(math.pi * u))

    y = off * (ramp((x - x0) / lc) - ramp((x - x0 - lc - hold) / lc))
    road = road_from_xy(x, y, bank_deg=((100.0, 0.0), (220.0, 16.0), (500.0, 16.0), (600.0, 0.0)))
    v = speed_profile(road, 80 * KMH, 8.0, 2.0, 3.0, v_start=80 * KMH, v_end=80 * KMH)
    return road, PathPlan(v_profile=v, v0=80 * KMH, steer_noise_deg=0.01)


# ---- seed 001: Blazer simulation and test-track turn ---------------------------------------
def build_two_turns(rng: np.random.Generator, vehicle: Vehicle) -> tuple[Road, Plan]:
    pieces = (
        straight(300.0) + turn(180.0, 100.0, 25.0) + straight(300.0)
        + turn(180.0, 100.0, 25.0) + straight(600.0)
    )  # fmt: skip
    road = with_roughness(road_from_pieces(pieces), rng, 0.05, 0.05)
    v = speed_profile(road, 20.0, 5.0, 2.0, 3.0, v_start=20.0, v_end=20.0)
    return road, PathPlan(v_profile=v, v0=20.0, steer_noise_deg=0.02)


def build_banked_track_turn(rng: np.random.Generator, vehicle: Vehicle) -> tuple[Road, Plan]:
    # 180 deg left turn of 145 m radius banked 8 deg toward the inside (left edge lower:
    # negative in the roll sign).
    tr = 40.0
    pieces = straight(250.0) + turn(180.0, 145.0, tr) + straight(600.0)
    s_exit = 250.0 + pieces_length(turn(180.0, 145.0, tr))
    road = road_from_pieces(
        pieces, bank_deg=((250.0, 0.0), (250.0 + tr, -8.0), (s_exit - tr, -8.0), (s_exit, 0.0))
    )
    road = with_roughness(road, rng, 0.05, 0.05)
    v = speed_profile(road, 24.0, 6.0, 2.0, 3.0, v_start=24.0, v_end=24.0)
    return road, PathPlan(v_profile=v, v0=24.0, steer_noise_deg=0.02)


# ---- seed 002: race lap --------------------------------------------------------------------------
# (straight before the turn m, turn deg, radius m)
_TRACK: tuple[tuple[float, float, float], ...] = (
    (1000.0, 90.0, 45.0),
    (150.0, -60.0, 70.0),
    (120.0, 120.0, 35.0),
    (150.0, 45.0, 120.0),
    (100.0, -90.0, 40.0),
    (120.0, 150.0, 50.0),
    (80.0, -45.0, 90.0),
    (120.0, 90.0, 55.0),
    (80.0, 30.0, 160.0),
    (150.0, 90.0, 40.0),
)


def build_race_lap(rng: np.random.Generator, vehicle: Vehicle) -> tuple[Road, Plan]:
    pieces: list[Piece] = []
    for length, angle, radius in _TRACK:
        pieces += straight(length) + turn(angle, radius, 25.0)
    pieces += straight(600.0)  # the lap ends 170 m down this straight (3.3 km); then run-off
    road = with_roughness(road_from_pieces(pieces, mu=((0.0, 1.05),)), rng, 0.05, 0.05)
    # the driver aims at 84 % of mu g laterally; load transfer and the rear-biased, rear-driven
    # car make the rear tyres slide well past the linear range (|beta| 5-8 deg in places).
    v = speed_profile(road, 65.0, 0.84 * 1.05 * 9.80665, 4.0, 8.0, v_start=35.0, v_end=40.0)
    return road, PathPlan(v_profile=v, v0=35.0, a_acc=4.0, a_dec=8.0)
