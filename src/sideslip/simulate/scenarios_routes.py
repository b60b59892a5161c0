"""Builders of the road-network scenarios: drives made of blocks of straight road and turns.

Seed 000's urban course and urban expressway, seed 004's suburban drive with GNSS outages, the
``demo`` country road and the hour-long ``endurance`` drive of ``sideslip bench``.  Each builder
is ``build(rng, vehicle) -> (Road, Plan)``; the ``*_schedule`` / ``*_duration`` functions plan
durations and outage times from the driver's speed profile, so that outages fall on the
intended stretches.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from sideslip.simulate.driver import PathPlan, Plan, profile_time, speed_profile
from sideslip.simulate.road import Piece, Road, road_from_pieces, straight, turn, with_bumps, with_roughness
from sideslip.simulate.scenarios_tracks import KMH, pieces_length
from sideslip.vehicle import Vehicle

Knots = list[tuple[float, float]]


# ---- seed 000: urban course and urban expressway (Tokyo, left-hand traffic) ------------------
# (straight m, speed km/h, crossfall deg, grade %, dwell s at the end or 0, turn deg, radius m)
_URBAN: tuple[tuple[float, float, float, float, float, float, float], ...] = (
    (320.0, 50.0, -2.0, 0.5, 20.0, 90.0, 14.0),
    (450.0, 60.0, -1.5, -1.0, 0.0, -90.0, 16.0),
    (280.0, 40.0, -2.5, 0.0, 15.0, 90.0, 12.0),
    (400.0, 60.0, 1.5, 1.5, 0.0, 30.0, 250.0),
    (350.0, 60.0, -2.0, 0.0, 25.0, -90.0, 15.0),
    (300.0, 50.0, -3.0, -1.5, 0.0, 90.0, 13.0),
    (420.0, 60.0, 2.0, 0.0, 18.0, 90.0, 16.0),
    (260.0, 40.0, -1.0, 2.0, 0.0, -45.0, 40.0),
    (380.0, 60.0, -2.5, 0.0, 22.0, -90.0, 14.0),
    (300.0, 50.0, -1.5, -2.0, 0.0, -90.0, 18.0),
    (450.0, 60.0, -2.0, 0.0, 12.0, 90.0, 15.0),
    (350.0, 50.0, 2.5, 1.0, 0.0, 90.0, 14.0),
    (290.0, 45.0, -2.0, 0.0, 0.0, 0.0, 0.0),
)


def _route(
    blocks: Sequence[tuple[float, float, float, float, float, float, float]],
    transition: float,
) -> tuple[list[Piece], Knots, Knots, Knots, Knots]:
    """Pieces, speed / crossfall / grade knots and stops of a route of blocks."""
    pieces: list[Piece] = []
    speed: list[tuple[float, float]] = []
    bank: list[tuple[float, float]] = []
    grade: list[tuple[float, float]] = []
    stops: list[tuple[float, float]] = []
    s = 0.0
    for length, v_kmh, cross, gr, dwell, angle, radius in blocks:
        ramp = min(20.0, 0.2 * length)
        speed += [(s, v_kmh * KMH), (s + length, v_kmh * KMH)]
        bank += [(s + ramp, cross), (s + length - ramp, cross)]
        grade += [(s + ramp, gr), (s + length - ramp, gr)]
        pieces += straight(length)
        s += length
        if dwell > 0:
            stops.append((s - 6.0, dwell))
        if angle != 0.0:
            tp = turn(angle, radius, min(transition, 0.5 * radius))
            pieces += tp
            s += pieces_length(tp)
    return pieces, speed, bank, grade, stops


def _knots(s: np.ndarray, knots: Sequence[tuple[float, float]]) -> np.ndarray:
    ks = np.array([k[0] for k in knots])
    kv = np.array([k[1] for k in knots])
    return np.interp(s, ks, kv)


def _urban_road() -> tuple[Road, list[tuple[float, float]], np.ndarray]:
    pieces, speed, bank, grade, stops = _route(_URBAN, 8.0)
    pieces = straight(5.0) + pieces + straight(60.0)
    shift = 5.0
    road = road_from_pieces(
        pieces,
        bank_deg=[(s + shift, b) for s, b in bank],
        grade_pct=[(s + shift, g) for s, g in grade],
        mu=((0.0, 0.9),),
    )
    v_set = _knots(road.s, [(s + shift, v) for s, v in speed])
    stops = [(0.5, 4.0)] + [(s + shift, d) for s, d in stops]
    return road, stops, v_set


def build_urban_course(rng: np.random.Generator, vehicle: Vehicle) -> tuple[Road, Plan]:
    road, stops, v_set = _urban_road()
    road = with_roughness(road, rng, 0.15, 0.2)
    v = speed_profile(road, v_set, 2.0, 1.5, 2.0, stops=stops)
    return road, PathPlan(v_profile=v, stops=tuple(stops), a_acc=1.8, a_dec=2.5)


# (straight m, speed km/h, 0, grade %, 0, turn deg, radius m); superelevation follows the turn
_HIGHWAY: tuple[tuple[float, float, float, float, float, float], ...] = (
    (800.0, 80.0, 1.0, 40.0, 600.0, 4.0),
    (1200.0, 80.0, -1.5, -60.0, 300.0, 5.0),
    (600.0, 70.0, 0.0, 90.0, 150.0, 5.0),
    (1000.0, 80.0, 2.0, 30.0, 500.0, 3.0),
    (700.0, 75.0, 0.0, -75.0, 200.0, 5.0),
    (900.0, 80.0, -2.0, 45.0, 400.0, 4.0),
    (500.0, 70.0, 1.0, -90.0, 180.0, 5.0),
    (1100.0, 80.0, 0.0, 60.0, 350.0, 4.0),
    (800.0, 80.0, 1.5, -35.0, 600.0, 2.5),
    (650.0, 65.0, -1.0, 80.0, 160.0, 5.0),
    (1200.0, 80.0, 0.0, -50.0, 450.0, 3.5),
    (700.0, 75.0, 0.0, 0.0, 0.0, 0.0),
)


def _highway_road() -> tuple[Road, np.ndarray]:
    pieces: list[Piece] = []
    speed: list[tuple[float, float]] = []
    bank: list[tuple[float, float]] = []
    grade: list[tuple[float, float]] = []
    s = 0.0
    for length, v_kmh, gr, angle, radius, superelevation in _HIGHWAY:
        speed += [(s, v_kmh * KMH), (s + length, v_kmh * KMH)]
        grade += [(s + 100.0, gr), (s + length - 100.0, gr)]
        bank += [(s + 40.0, 1.0), (s + length - 60.0, 1.0)]  # 1 deg crossfall on straights
        pieces += straight(length)
        s += length
        if angle != 0.0:
            tp = turn(angle, radius, 80.0)
            # superelevation lowers the inside edge: left turn -> left lower -> negative roll sign
            e = -math.copysign(superelevation, angle)
            bank += [(s + 60.0, e), (s + pieces_length(tp) - 60.0, e)]
            pieces += tp
            s += pieces_length(tp)
    road = road_from_pieces(pieces, bank_deg=bank, grade_pct=grade, mu=((0.0, 0.9),))
    return road, _knots(road.s, speed)


def _highway_plan(road: Road, v_set: np.ndarray) -> PathPlan:
    v = speed_profile(road, v_set, 2.0, 1.0, 1.5, v_start=70 * KMH, v_end=70 * KMH)
    return PathPlan(v_profile=v, v0=70 * KMH, a_acc=1.2, a_dec=2.0)


def build_urban_highway(rng: np.random.Generator, vehicle: Vehicle) -> tuple[Road, Plan]:
    road, v_set = _highway_road()
    road = with_roughness(road, rng, 0.1, 0.1)
    return road, _highway_plan(road, v_set)


def highway_duration() -> float:
    road, v_set = _highway_road()
    t = profile_time(road, _highway_plan(road, v_set), lag_s=0.0)
    # stop before the end of the road (the driver would brake for it)
    return float(np.floor(float(np.interp(road.length - 300.0, road.s, t))))


# ---- seed 004: suburban drive with three GNSS outages ------------------------------------------
# blocks as in _URBAN; the three outage stretches are marked in _SUBURBAN_OUTAGE_BLOCKS
_SUBURBAN: tuple[tuple[float, float, float, float, float, float, float], ...] = (
    (380.0, 45.0, -1.0, 0.5, 30.0, 90.0, 12.0),
    (420.0, 50.0, -1.5, 0.0, 40.0, -90.0, 14.0),
    (300.0, 40.0, 1.0, 1.0, 25.0, 90.0, 12.0),
    (1500.0, 61.0, -1.0, 0.0, 0.0, -90.0, 16.0),  # outage 1: 61 km/h straight
    (350.0, 45.0, 1.0, -1.0, 35.0, 90.0, 14.0),
    (400.0, 50.0, -1.5, 0.0, 45.0, -90.0, 12.0),
    (280.0, 39.0, -1.0, 6.0, 0.0, 90.0, 40.0),  # outage 2: 39 km/h sharp turn on a slope
    (260.0, 39.0, -1.0, 6.0, 30.0, -90.0, 13.0),
    (350.0, 45.0, 1.5, 0.0, 40.0, 90.0, 15.0),
    (320.0, 50.0, -1.0, -1.0, 35.0, -90.0, 12.0),
    (520.0, 32.0, -1.0, 5.0, 0.0, 0.0, 0.0),  # outage 3: 32 km/h, speed bumps, on a slope
    (300.0, 45.0, 1.0, 0.0, 40.0, 90.0, 14.0),
    (400.0, 50.0, -1.5, 0.5, 30.0, -90.0, 13.0),
    (350.0, 45.0, -1.0, 0.0, 45.0, 90.0, 12.0),
    (380.0, 50.0, 1.0, -0.5, 35.0, -90.0, 15.0),
    (300.0, 40.0, -1.0, 0.0, 40.0, 90.0, 12.0),
    (420.0, 50.0, -1.5, 1.0, 30.0, -90.0, 14.0),
    (350.0, 45.0, 1.0, 0.0, 45.0, 90.0, 13.0),
    (400.0, 50.0, -1.0, -1.0, 35.0, -90.0, 12.0),
    (320.0, 45.0, 1.5, 0.0, 40.0, 90.0, 14.0),
    (380.0, 50.0, -1.0, 0.0, 30.0, -90.0, 12.0),
    (330.0, 45.0, 1.0, 0.5, 40.0, 90.0, 13.0),
    (350.0, 50.0, -1.5, 0.0, 45.0, -90.0, 12.0),
    (320.0, 40.0, 1.0, -0.5, 40.0, 90.0, 14.0),
    (360.0, 50.0, -1.0, 0.0, 35.0, -90.0, 12.0),
    (340.0, 45.0, -1.0, 0.0, 0.0, 0.0, 0.0),
)
_SUBURBAN_OUTAGE_BLOCKS = (3, 6, 10)


def _suburban_road() -> tuple[Road, list[tuple[float, float]], np.ndarray, list[float]]:
    pieces, speed, bank, grade, stops = _route(_SUBURBAN, 8.0)
    shift = 5.0
    pieces = straight(shift) + pieces + straight(60.0)
    # start of each block, to place the outages and the speed bumps
    starts = []
    s = shift
    for length, *_rest, angle, radius in _SUBURBAN:
        starts.append(s)
        s += length
        if angle != 0.0:
            s += pieces_length(turn(angle, radius, min(8.0, 0.5 * radius)))
    road = road_from_pieces(
        pieces,
        bank_deg=[(s + shift, b) for s, b in bank],
        grade_pct=[(s + shift, g) for s, g in grade],
        mu=((0.0, 0.9),),
    )
    b3 = starts[10]
    road = with_bumps(road, [b3 + 60.0 + 70.0 * k for k in range(6)])
    v_set = _knots(road.s, [(s + shift, v) for s, v in speed])
    # the sharp turn of outage 2 is taken at the block speed (39 km/h, a_y 2.9 m/s^2)
    stops = [(0.5, 5.0)] + [(s + shift, d) for s, d in stops]
    # centre (m) of each outage stretch
    centres = [
        starts[3] + 0.5 * _SUBURBAN[3][0],
        starts[7] - 0.5 * pieces_length(turn(90.0, 40.0, 8.0)),
        starts[10] + 0.5 * _SUBURBAN[10][0],
    ]
    return road, stops, v_set, centres


def _suburban_plan(road: Road, stops: list[tuple[float, float]], v_set: np.ndarray) -> PathPlan:
    v = speed_profile(road, v_set, 3.2, 1.5, 2.0, stops=stops)
    return PathPlan(v_profile=v, stops=tuple(stops), a_acc=1.8, a_dec=2.5)


def build_suburban(rng: np.random.Generator, vehicle: Vehicle) -> tuple[Road, Plan]:
    road, stops, v_set, _ = _suburban_road()
    road = with_roughness(road, rng, 0.15, 0.2)
    return road, _suburban_plan(road, stops, v_set)


def suburban_schedule() -> tuple[float, tuple[tuple[float, float], ...]]:
    road, stops, v_set, centres = _suburban_road()
    plan = _suburban_plan(road, stops, v_set)
    t = profile_time(road, plan)
    outages = tuple(
        (round(float(np.interp(c, road.s, t)) - 15.0, 1), round(float(np.interp(c, road.s, t)) + 15.0, 1))
        for c in centres
    )
    return float(np.ceil(t[-1] + 20.0)), outages


# ---- demo: a country road ------------------------------------------------------------------------
def _demo_road() -> tuple[Road, list[tuple[float, float]], float]:
    pieces = (
        straight(250.0) + turn(60.0, 250.0, 40.0) + straight(200.0)
        + turn(-90.0, 180.0, 50.0) + straight(220.0) + straight(300.0)
        + turn(45.0, 300.0, 40.0) + straight(650.0)
    )  # fmt: skip
    s_right = 250.0 + pieces_length(turn(60.0, 250.0, 40.0)) + 200.0
    s_right_end = s_right + pieces_length(turn(-90.0, 180.0, 50.0))
    road = road_from_pieces(
        pieces,
        bank_deg=(
            (0.0, 1.0), (s_right, 1.0), (s_right + 50.0, 4.0), (s_right_end - 50.0, 4.0),
            (s_right_end, 1.0),
        ),
        grade_pct=((0.0, 0.0), (300.0, 2.0), (700.0, -1.5), (1200.0, 1.0), (1800.0, 0.0)),
        mu=((0.0, 0.9),),
    )  # fmt: skip
    stops = [(s_right_end + 200.0, 6.0)]
    return road, stops, 0.5 * (s_right + s_right_end)


def _demo_plan(road: Road, stops: list[tuple[float, float]]) -> PathPlan:
    v = speed_profile(road, 80 * KMH, 2.5, 1.5, 2.5, v_start=80 * KMH, stops=stops)
    return PathPlan(v_profile=v, stops=tuple(stops), v0=80 * KMH)


def build_demo(rng: np.random.Generator, vehicle: Vehicle) -> tuple[Road, Plan]:
    road, stops, _ = _demo_road()
    road = with_roughness(road, rng, 0.1, 0.1)
    return road, _demo_plan(road, stops)


def demo_schedule() -> tuple[float, tuple[tuple[float, float], ...]]:
    road, stops, centre = _demo_road()
    t = profile_time(road, _demo_plan(road, stops), lag_s=0.0)
    tc = float(np.interp(centre, road.s, t))
    # end before the driver brakes for the end of the road
    t_end = float(np.interp(road.length - 400.0, road.s, t))
    return float(np.floor(t_end)), ((round(tc - 5.0, 1), round(tc + 5.0, 1)),)


def urban_duration() -> float:
    road, stops, v_set = _urban_road()
    v = speed_profile(road, v_set, 2.0, 1.5, 2.0, stops=stops)
    t = profile_time(road, PathPlan(v_profile=v, stops=tuple(stops)))
    return float(np.ceil(t[-1] + 10.0))


def urban_outages() -> tuple[tuple[float, float], ...]:
    # short outages (bridges, tall buildings) at fixed fractions of the drive
    return ((95.0, 99.0), (260.0, 266.0), (410.0, 413.0), (560.0, 567.0))


# ---- endurance: an hour of mixed driving for `sideslip bench` -----------------------------------
ENDURANCE_LENGTH_M = 110_000.0  # enough road for 1.5 h at the route's average speed


Block = tuple[float, float, float, float, float, float, float]


def _endurance_blocks(rng: np.random.Generator) -> list[Block]:
    """Random blocks (as in _URBAN) until the route is long enough: town, country, highway."""
    blocks: list[Block] = []
    total = 0.0
    while total < ENDURANCE_LENGTH_M:
        kind = rng.choice(3, p=(0.3, 0.4, 0.3))
        if kind == 0:  # town: short blocks, 90 deg corners, stops
            length, v, radius = rng.uniform(150, 450), rng.choice((40.0, 50.0)), rng.uniform(12, 25)
            angle = float(rng.choice((-90.0, 90.0)))
            dwell = float(rng.choice((0.0, 0.0, 15.0)))
        elif kind == 1:  # country road: sweeping curves
            length, v, radius = rng.uniform(300, 1500), rng.choice((70.0, 80.0, 90.0)), rng.uniform(150, 500)
            angle, dwell = float(rng.uniform(-90, 90)), 0.0
        else:  # highway
            length, v, radius = rng.uniform(1000, 4000), 100.0, rng.uniform(600, 1500)
            angle, dwell = float(rng.uniform(-40, 40)), 0.0
        cross = float(rng.uniform(-3.0, 3.0))
        grade = float(rng.uniform(-4.0, 4.0))
        blocks.append((float(length), float(v), cross, grade, dwell, angle, float(radius)))
        total += length + abs(angle) / 180.0 * np.pi * radius
    return blocks


def build_endurance(rng: np.random.Generator, vehicle: Vehicle) -> tuple[Road, Plan]:
    pieces, speed, bank, grade, stops = _route(_endurance_blocks(rng), 30.0)
    road = road_from_pieces(
        straight(5.0) + pieces + straight(200.0),
        bank_deg=[(s + 5.0, b) for s, b in bank],
        grade_pct=[(s + 5.0, g) for s, g in grade],
        mu=((0.0, 0.9),),
    )
    road = with_roughness(road, rng, 0.15, 0.2)
    v_set = _knots(road.s, [(s + 5.0, v) for s, v in speed])
    stops = [(0.5, 4.0)] + [(s + 5.0, d) for s, d in stops]
    v = speed_profile(road, v_set, 2.5, 1.5, 2.5, stops=stops)
    return road, PathPlan(v_profile=v, stops=tuple(stops), a_acc=1.8, a_dec=2.5)
