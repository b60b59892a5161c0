"""Seed 003's roll estimation: roll_index (eqs 41-61) and Tseng's roll_dfc (eqs 49-58).

Graded on analytic cases (standstill tilt, flag timing, gyro zeroing) and on the simulator's
four seed 003 scenarios (truth roll = road bank + suspension roll of a nonlinear two-track
model; MEMS errors: ~0.2 deg/s gyro bias, which at 22 m/s moves the static bank
(a_ym - r v)/g by ~0.45 deg, and 0.05 m/s^2 accelerometer bias, ~0.3 deg).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from sideslip.drive import Drive, drive_from_columns
from sideslip.methods.registry import all_methods, run_method
from sideslip.methods.roll_index import (
    STANDSTILL_MIN_S,
    held_for,
    seen_within,
    standstill_gyro_bias,
)
from sideslip.models.roll import compensate_ay, suspension_roll_steady
from sideslip.vehicle import G, load_vehicle
from tests.conftest import sim_drive

VEH = load_vehicle("seed003_sedan")
SCENARIOS = ("step_steer", "slalom_low_mu", "banked_turn", "dlc_bank")
BANKED = ("banked_turn", "dlc_bank")


def rmse_deg(x: np.ndarray) -> float:
    return float(np.rad2deg(np.sqrt(np.mean(np.square(x)))))


def run(name: str, drive: Drive):
    return run_method(all_methods()[name], drive, load_vehicle(drive.meta["vehicle"]))


# ------------------------------------------------------------------------------------------
# analytic cases
# ------------------------------------------------------------------------------------------
def test_held_for_needs_the_whole_window() -> None:
    # rows every 0.125 s (exact in binary); true from 0.5 s to 1.375 s.  A row's condition
    # covers the interval since the previous row, so after the false row at 0.375 s the
    # condition has held for 0.5 s at the row 0.875 s.
    t = np.arange(0.0, 2.0, 0.125)
    cond = (t >= 0.5) & (t < 1.5)
    out = held_for(cond, t, 0.5)
    assert np.array_equal(np.flatnonzero(out), np.flatnonzero((t >= 0.875) & (t < 1.5)))


def test_seen_within_remembers_for_the_window() -> None:
    t = np.arange(0.0, 3.0, 0.1)
    cond = np.isclose(t, 1.0)
    out = seen_within(cond, t, 1.5)
    assert np.array_equal(np.flatnonzero(out), np.flatnonzero((t > 1.0 - 1e-9) & (t <= 2.5 + 1e-9)))


def test_standstill_gyro_bias_is_the_mean_after_enough_standstill() -> None:
    t = np.arange(0.0, 3.0, 0.01)
    still = t < 1.0
    wz = 0.004 + np.where(still, 0.0, 0.2)
    bias = standstill_gyro_bias(t, wz, still)
    assert np.all(bias[t < STANDSTILL_MIN_S - 0.02] == 0.0)  # not enough standstill yet
    assert bias[-1] == pytest.approx(0.004)


def test_roll_index_is_the_accelerometer_tilt_at_standstill_on_a_bank() -> None:
    # Standing on a road banked by 6 deg with a gyro bias: a_ym = g sin(roll) exactly, r v = 0,
    # so the static bank (eq 46) is the roll; the bias is zeroed after 0.5 s of standstill.
    t = np.arange(0.0, 5.0, 0.01)
    roll = math.radians(6.0)
    cols = {"t": t, "ay": np.full_like(t, G * math.sin(roll)), "wz": np.full_like(t, 0.003),
            "v_rl": np.zeros_like(t), "v_rr": np.zeros_like(t), "steer": np.zeros_like(t)}
    drive = drive_from_columns(cols, {"vehicle": "seed003_sedan"})
    est = run_method(all_methods()["roll_index"], drive, VEH)
    assert np.allclose(est["roll"], roll, atol=1e-9)
    # the suspension leans downhill on its springs (road-plane force g sin(bank)): eq 43
    sus = suspension_roll_steady(np.array([G * math.sin(roll)]), VEH)[0]
    assert np.allclose(est["bank"][t > 2.0], roll - sus, atol=1e-6)
    assert est["gyro_bias"][-1] == pytest.approx(0.003)


# ------------------------------------------------------------------------------------------
# the paper's findings on the seed 003 scenarios
# ------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def roll_rmse() -> dict[tuple[str, str], float]:
    out = {}
    for s in SCENARIOS:
        drive = sim_drive(s)
        for m in ("roll_index", "roll_dfc"):
            out[(s, m)] = rmse_deg(run(m, drive)["roll"] - drive["ref_roll"])
    return out


def test_roll_index_beats_tseng_dfc_on_banked_roads(roll_rmse: dict) -> None:
    # Paper Figs 7a, 8a: the DFC (eq 58) shrinks the bank whenever the channels disagree by
    # ~1 m/s^2 (steering offset and model error suffice), the roll index keeps it.  (On the
    # flat scenarios both errors are at the sensor-bias level and their order depends on the
    # bias draw, so they are not compared here; see benchmarks/results/observers_accuracy.md.)
    for s in BANKED:
        assert roll_rmse[(s, "roll_index")] < 0.5 * roll_rmse[(s, "roll_dfc")], s


def test_roll_index_accuracy_on_the_seed003_scenarios(roll_rmse: dict) -> None:
    # The static bank (a_ym - r v)/g carries the sensor biases: 0.05 m/s^2 of accelerometer
    # bias is 0.3 deg, 0.2 deg/s of gyro bias at 80 km/h 0.45 deg (at 140 km/h 0.8 deg).
    # Flat step steer (roll = suspension roll ~2.5 deg): within that budget, 0.8 deg.  Banks of
    # 16 and 25 deg: within 3.5 deg rms -- the biases plus the switching delay at the bank's
    # end that the paper also reports (Fig 7a): lambda stays 0 while the steering unwinds, so
    # the roll is held at the bank for up to ~2 s of the 3 s ramp down from 25 deg (alone
    # ~sqrt(2/28) x 12 deg ~ 3 deg rms over the 28 s drive).  Flat slalom at 140 km/h: 1.5 deg.
    assert roll_rmse[("step_steer", "roll_index")] < 0.8
    for s in BANKED:
        assert roll_rmse[(s, "roll_index")] < 3.5, s
    assert roll_rmse[("slalom_low_mu", "roll_index")] < 1.5


def test_compensation_removes_the_gravity_bias_of_the_lateral_acceleration() -> None:
    # Paper Figs 7b, 8b: a_ym carries g sin(bank) (up to 4 m/s^2 at 25 deg); compensated by the
    # roll index it is within 0.2 m/s^2 of the gravity-free truth on average (roll error
    # 1.5 deg rms ~ 0.26 m/s^2 locally, mostly at the bank's end).
    for s in BANKED:
        drive = sim_drive(s)
        roll = run("roll_index", drive)["roll"]
        ok = np.isfinite(drive["ay"])
        raw = drive["ay"][ok] - drive["ref_ay"][ok]
        comp = compensate_ay(drive["ay"], roll)[ok] - drive["ref_ay"][ok]
        assert abs(raw.mean()) > 1.0, s
        assert abs(comp.mean()) < 0.2, s
        assert np.sqrt(np.mean(comp**2)) < 0.25 * np.sqrt(np.mean(raw**2)), s


def test_compensation_removes_the_suspension_roll_on_flat_ground() -> None:
    # Paper Fig 5b: on the flat step steer the uncompensated a_ym is biased by g sin(roll_sus)
    # (~0.3 m/s^2 here); compensated, the mean error is at the accelerometer-bias level.
    drive = sim_drive("step_steer")
    roll = run("roll_index", drive)["roll"]
    turn = np.isfinite(drive["ay"]) & (drive.t > 4.0)
    raw = (drive["ay"] - drive["ref_ay"])[turn]
    comp = (compensate_ay(drive["ay"], roll) - drive["ref_ay"])[turn]
    assert abs(raw.mean()) > 0.2
    assert abs(comp.mean()) < 0.08


# ------------------------------------------------------------------------------------------
# robustness
# ------------------------------------------------------------------------------------------
def test_roll_methods_finite_and_sane_on_an_urban_drive_with_standstill() -> None:
    # urban_course (minivan, 20 % standstill): roll of a few degrees at most; the estimates
    # stay finite and within 2 deg rms.
    drive = sim_drive("urban_course")
    for m in ("roll_index", "roll_dfc"):
        est = run(m, drive)
        assert set(est.series) == {"roll", "bank", "gyro_bias", "health"}
        assert rmse_deg(est["roll"] - drive["ref_roll"]) < 2.0, m


def test_roll_methods_finite_through_nan_gaps() -> None:
    drive = sim_drive("banked_turn")
    data = dict(drive.data)
    rows = (drive.t > 10.0) & (drive.t < 12.0)
    for name in ("ay", "wz", "steer", "v_fl", "v_fr", "v_rl", "v_rr"):
        col = np.array(data[name], dtype=float)
        col[rows] = np.nan
        data[name] = col
    gap = Drive(drive.t, data, drive.meta, drive.path)
    # the 2 s gap in the middle of the 25 deg bank costs little over the whole drive (bound
    # 0.5 deg rms); roll_index stays within its banked-road budget (3.5 deg, test above).
    # roll_dfc is compared with itself only: on this bank its DFC weight (eq 58) shrinks the
    # roll wherever the yaw and a_y channels disagree, which a steering offset of 0.1 deg
    # moves by about 5 deg (d0 / (K_us g)), so its absolute error depends on the offset
    # draw (measured 3.5 deg with the steer as recorded, 10.1 with the drive's zero; Figs 7a
    # and 8a of seed 003 report the same shrinking)
    for m in ("roll_index", "roll_dfc"):
        whole = rmse_deg(run(m, drive)["roll"] - drive["ref_roll"])
        est = run(m, gap)  # run_method raises if any output is not finite
        assert rmse_deg(est["roll"] - drive["ref_roll"]) < whole + 0.5, m
    assert rmse_deg(run("roll_index", gap)["roll"] - drive["ref_roll"]) < 3.5


def test_compiled_input_passes_equal_their_numpy_forms() -> None:
    """hold_first = signals.hold with the first sample as fill; the standstill gyro mean as
    cumulative sums; sensor_inputs' standstill rows = signals.standstill (computed from the
    held speed it already has)."""
    from sideslip.methods.roll_index import (
        STANDSTILL_MIN_S,
        hold_first,
        sensor_inputs,
        standstill_gyro_bias,
    )
    from sideslip.signals import hold, standstill

    rng = np.random.default_rng(7)
    t = np.cumsum(rng.uniform(0.009, 0.011, 4000))
    x = rng.normal(size=t.size)
    x[:13] = np.nan
    x[rng.random(t.size) < 0.4] = np.nan
    first = float(x[np.isfinite(x)][0])
    np.testing.assert_array_equal(hold_first(x), hold(x, t, fill=first)[0])
    assert np.all(hold_first(np.full(5, np.nan)) == 0.0)
    still = (t > 5.0) & (t < 5.3) | (t > 20.0) & (t < 21.0)
    wz = rng.normal(0.01, 0.002, t.size)
    wz[rng.random(t.size) < 0.1] = np.nan
    use = still & np.isfinite(wz)
    count = np.cumsum(use)
    total = np.cumsum(np.where(use, wz, 0.0))
    seen = np.cumsum(np.where(use, np.diff(t, prepend=t[0]), 0.0))
    ref = np.where(seen >= STANDSTILL_MIN_S, np.where(count > 0, total / np.maximum(count, 1),
                                                      0.0), 0.0)
    got = standstill_gyro_bias(t, wz, still)
    np.testing.assert_array_equal(got, ref)
    assert got[t < 20.15].max() == 0.0 and got[-1] > 0.0  # 0.3 s is not enough, 1.3 s is
    drive = sim_drive("demo")
    inp = sensor_inputs(drive)
    np.testing.assert_array_equal(
        inp.gyro_bias, standstill_gyro_bias(drive.t, drive["wz"], standstill(drive)))
