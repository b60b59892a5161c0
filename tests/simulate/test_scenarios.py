"""Every named scenario runs, is reproducible from its seed, and hits its headline numbers."""

from __future__ import annotations

import functools
import math
from typing import Any

import numpy as np
import pytest

from sideslip.simulate import simulate
from sideslip.simulate.scenarios import (
    SCENARIOS,
    Scenario,
    build_scenario,
    run_scenario,
    run_scenario_full,
)
from sideslip.simulate.truth import Truth
from sideslip.simulate.vehicle_model import Diagnostics
from sideslip.vehicle import load_vehicle, preset_names
from tests.simulate.fingerprints import array_fingerprint, assert_matches, fingerprint, load

SENSOR_KEYS = {"gyro_scale_factor", "gnss_rate_hz", "gnss_outages", "gnss_multipath_prob"}
KMH = 3.6


@functools.lru_cache(maxsize=16)
def _run(name: str, seed: int = 0) -> tuple[Truth, Diagnostics]:
    return run_scenario_full(name, seed)


def _speed_kmh(truth: Truth) -> np.ndarray:
    return np.hypot(truth.vx, truth.vy) * KMH


def test_the_scenario_list_is_complete() -> None:
    assert set(SCENARIOS) == {
        "step_steer", "slalom_low_mu", "banked_turn", "dlc_bank", "two_turns_gyro_sf",
        "banked_track_turn", "urban_course", "urban_highway", "race_lap", "suburban_outages",
        "demo", "endurance",
    }  # fmt: skip


def test_endurance_runs_for_a_requested_duration_on_mixed_roads() -> None:
    """The benchmark's drive: its length is a parameter; two minutes of it already hold town
    driving (a stop at the start), curves and both signs of crossfall."""
    truth, _ = run_scenario_full("endurance", 0, duration_s=120.0)
    assert truth.t[-1] == pytest.approx(120.0)
    assert np.isfinite(truth.vx).all()
    assert np.max(_speed_kmh(truth)) > 35.0
    assert np.max(np.abs(truth.r)) > 0.05


@pytest.mark.parametrize("name", sorted(SCENARIOS))
def test_scenario_runs_finite_on_its_grid(name: str) -> None:
    scenario: Scenario = SCENARIOS[name]
    assert scenario.vehicle in preset_names()
    assert set(scenario.sensor_overrides) <= SENSOR_KEYS
    assert scenario.description and "\n" not in scenario.description
    truth, diag = _run(name)
    n = round(scenario.duration_s / 0.01) + 1
    assert truth.t.size == n
    assert np.allclose(np.diff(truth.t), 0.01)
    for field in Truth.__dataclass_fields__:
        assert np.all(np.isfinite(getattr(truth, field))), field
    # the driver stays on the road (path-following scenarios) and nobody spins
    if name not in ("step_steer", "slalom_low_mu"):
        assert np.max(np.abs(diag.lateral_offset)) < 2.5
    assert np.max(np.abs(np.degrees(truth.beta))) < 12.0


@pytest.mark.parametrize("name", ["step_steer", "demo"])
def test_scenario_is_reproducible_from_its_seed(name: str) -> None:
    a = run_scenario(name, seed=7)
    b = run_scenario(name, seed=7)
    c = run_scenario(name, seed=8)
    for field in Truth.__dataclass_fields__:
        assert np.array_equal(getattr(a, field), getattr(b, field)), field
    # the seed drives the driver's steering noise (and the road roughness)
    assert not np.array_equal(a.steer, c.steer)


@pytest.mark.parametrize(
    ("name", "preset"),
    [("step_steer", "alphard_minivan"), ("slalom_low_mu", "blazer_suv"), ("demo", "rav4")],
)
def test_open_loop_manoeuvres_suit_another_vehicle(name: str, preset: str) -> None:
    # open-loop steering is sized by the linear steady-state a_y of the vehicle driving it,
    # so a strongly understeering SUV does the slalom without spinning
    truth = run_scenario(name, seed=0, vehicle=load_vehicle(preset))
    assert np.max(np.abs(np.degrees(truth.beta))) < 5.0
    assert np.max(np.abs(truth.ay)) > 1.5


def test_scenario_runs_with_another_vehicle() -> None:
    truth = run_scenario("banked_track_turn", seed=0, vehicle=load_vehicle("ferrari_250lm"))
    assert np.all(np.isfinite(truth.beta))
    assert np.max(np.abs(truth.yaw - truth.yaw[0])) == pytest.approx(math.pi, abs=0.1)


def test_unknown_scenario_lists_the_names() -> None:
    with pytest.raises(KeyError, match="step_steer"):
        run_scenario("no_such_scenario")


def test_step_steer_headline() -> None:
    truth, _ = _run("step_steer")
    assert np.all(np.abs(_speed_kmh(truth) - 80.0) < 1.0)
    assert np.all(truth.mu == pytest.approx(0.85)) and np.all(truth.bank == 0.0)
    late = truth.t > 6.0
    assert 3.5 < np.mean(truth.ay[late]) < 5.0  # a step to about 0.4 g


def test_slalom_low_mu_headline() -> None:
    truth, _ = _run("slalom_low_mu")
    assert np.all(np.abs(_speed_kmh(truth) - 140.0) < 1.5)
    assert np.all(truth.mu == pytest.approx(0.25))
    # 0.5 Hz slalom up to 70-100 % of the friction limit 0.25 g
    peak = np.max(np.abs(truth.ay))
    assert 0.7 * 0.25 * 9.81 < peak < 0.25 * 9.81
    spectrum = np.abs(np.fft.rfft(truth.r - truth.r.mean()))
    freqs = np.fft.rfftfreq(truth.r.size, 0.01)
    assert freqs[np.argmax(spectrum)] == pytest.approx(0.5, abs=0.06)


@pytest.mark.parametrize(("name", "bank_max"), [("banked_turn", 25.0), ("dlc_bank", 16.0)])
def test_seed003_bank_ranges(name: str, bank_max: float) -> None:
    truth, _diag = _run(name)
    bank = np.degrees(truth.bank)
    assert bank.min() == pytest.approx(0.0, abs=0.01)
    assert bank.max() == pytest.approx(bank_max, abs=0.01)
    assert np.all(np.abs(_speed_kmh(truth) - 80.0) < 1.5)
    # body roll = bank + suspension roll, the latter a few degrees at most
    assert np.max(np.abs(np.degrees(truth.roll_sus))) < 4.0
    if name == "dlc_bank":  # the double lane change: 3.5 m out and back (path along East)
        assert np.ptp(truth.n) == pytest.approx(3.5, abs=0.3)
        assert abs(truth.n[-1] - truth.n[0]) < 0.3


def test_two_turns_headline() -> None:
    truth, _ = _run("two_turns_gyro_sf")
    assert SCENARIOS["two_turns_gyro_sf"].sensor_overrides["gyro_scale_factor"] == 0.02
    assert truth.yaw[-1] - truth.yaw[0] == pytest.approx(2 * math.pi, abs=0.05)
    turning = np.abs(truth.r) > 0.95 * np.max(np.abs(truth.r))
    radius = np.hypot(truth.vx, truth.vy)[turning] / np.abs(truth.r[turning])
    assert np.median(radius) == pytest.approx(100.0, rel=0.03)


def test_banked_track_turn_headline() -> None:
    truth, _ = _run("banked_track_turn")
    assert truth.yaw[-1] - truth.yaw[0] == pytest.approx(math.pi, abs=0.05)
    turning = np.abs(truth.r) > 0.95 * np.max(np.abs(truth.r))
    radius = np.hypot(truth.vx, truth.vy)[turning] / np.abs(truth.r[turning])
    assert np.median(radius) == pytest.approx(145.0, rel=0.02)
    # 8 deg bank toward the inside of the left turn (left edge lower: negative roll sign)
    assert np.median(np.degrees(truth.bank[turning])) == pytest.approx(-8.0, abs=0.3)


def test_urban_course_headline() -> None:
    truth, diag = _run("urban_course")
    assert diag.s[-1] == pytest.approx(5000.0, rel=0.05)
    v = _speed_kmh(truth)
    assert v.max() < 61.0
    assert np.mean(diag.held) > 0.05  # stops at lights
    turns = np.abs(np.diff(np.round(np.degrees(truth.yaw) / 90.0)))
    assert np.sum(turns) >= 8  # several 90 deg intersection turns
    moving = v > 20.0
    crossfall = np.abs(np.degrees(truth.bank[moving]))
    assert 1.0 < np.median(crossfall) < 3.0
    outages = SCENARIOS["urban_course"].sensor_overrides["gnss_outages"]
    assert all(0 < b - a <= 10.0 for a, b in outages)


def test_urban_highway_headline() -> None:
    truth, diag = _run("urban_highway")
    assert diag.s[-1] == pytest.approx(14000.0, rel=0.05)
    v = _speed_kmh(truth)
    assert np.percentile(v, 2) > 59.0 and v.max() < 81.0
    bank = np.degrees(truth.bank)
    assert 4.0 < bank.max() < 5.6 and -5.6 < bank.min() < -4.0
    radius = np.hypot(truth.vx, truth.vy) / np.maximum(np.abs(truth.r), 1e-6)
    assert 140.0 < np.min(radius) < 160.0


def test_race_lap_headline() -> None:
    truth, diag = _run("race_lap")
    beta = np.max(np.abs(np.degrees(truth.beta)))
    assert 5.0 <= beta <= 8.0
    assert diag.s[-1] > 3290.0  # one 3.3 km lap
    assert np.max(np.abs(truth.ay)) > 0.8 * 1.05 * 9.81  # near the friction limit
    assert np.max(_speed_kmh(truth)) > 200.0  # the 1 km straight


def test_suburban_outages_headline() -> None:
    scenario = SCENARIOS["suburban_outages"]
    truth, diag = _run("suburban_outages")
    assert diag.s[-1] == pytest.approx(11000.0, rel=0.05)
    assert scenario.duration_s == pytest.approx(32 * 60, rel=0.1)
    assert scenario.sensor_overrides["gnss_rate_hz"] == 1.0
    outages = scenario.sensor_overrides["gnss_outages"]
    assert len(outages) == 3
    v = _speed_kmh(truth)
    for (a, b), target in zip(outages, (61.0, 39.0, 32.0), strict=True):
        assert b - a == pytest.approx(30.0)
        sel = (truth.t >= a) & (truth.t <= b)
        assert np.mean(v[sel]) == pytest.approx(target, abs=2.0)
    # outage 2: a sharp turn on a slope; outage 3: speed bumps on a slope
    a, b = outages[1]
    sel = (truth.t >= a) & (truth.t <= b)
    assert abs(truth.yaw[sel][-1] - truth.yaw[sel][0]) > math.radians(60.0)
    assert np.mean(np.tan(truth.grade[sel])) > 0.03
    a, b = outages[2]
    sel = (truth.t >= a) & (truth.t <= b)
    assert np.mean(np.tan(truth.grade[sel])) > 0.03
    assert np.max(np.abs(truth.acc_enu[sel, 2])) > 1.0  # the bumps shake the body


def test_demo_headline() -> None:
    scenario = SCENARIOS["demo"]
    truth, diag = _run("demo")
    assert 60.0 <= scenario.duration_s <= 120.0
    ((a, b),) = scenario.sensor_overrides["gnss_outages"]
    assert b - a == pytest.approx(10.0)
    assert np.sum(diag.held) * 0.01 >= 3.0  # a stop
    assert truth.vx[-1] > 15.0  # and the pull-away
    assert np.max(truth.r) > 0.05 and np.min(truth.r) < -0.05  # left and right curves
    assert np.degrees(truth.bank.max()) == pytest.approx(4.0, abs=0.5)


def split_fingerprint(name: str) -> dict[str, Any]:
    """Fingerprint (tests.simulate.fingerprints) of a scenario's definition (duration, sensor
    overrides, options, headline), its whole road and driver plan for seed 3, and the truth,
    model diagnostics and drive columns of its first 3 s."""
    out = fingerprint(SCENARIOS[name], "scenario.")
    road, plan, _rng = build_scenario(name, seed=3)
    fingerprint(road, "road.", out)
    fingerprint(plan, "plan.", out)
    truth, diag = run_scenario_full(name, seed=3, duration_s=3.0)
    fingerprint(truth, "truth.", out)
    fingerprint(diag, "diag.", out)
    drive = simulate(name, seed=3, duration_s=3.0)
    for column in sorted(drive.data):
        out["drive." + column] = array_fingerprint(drive.data[column])
    return out


# recorded from the tree whose drives the sha256 digests of the module split (72d2f34) and of
# the named parameters had checked bit-identical; see tests/simulate/fingerprints.py
@pytest.mark.parametrize("name", sorted(SCENARIOS))
def test_scenario_matches_the_recording_before_the_module_split(name: str) -> None:
    assert_matches(split_fingerprint(name), load()[f"split/{name}"])


def test_every_scenario_has_a_recorded_fingerprint() -> None:
    assert {k.split("/", 1)[1] for k in load() if k.startswith("split/")} == set(SCENARIOS)
