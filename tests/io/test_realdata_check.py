"""Real-data check on the comma2k19 minute: every runnable method is finite and its heading,
gyro bias, wheel-speed scale factor and dead reckoning agree with comma's pose.

The figures come from ``benchmarks/realdata_check.py`` (which also writes the result table).
Tolerances, from the data (DATA_NOTES.md and the converter's checks):

* heading RMSE < 1.0 deg: u-blox course noise ~0.3 deg at 17 m/s, |beta| < 0.5 deg on this
  minute (course-based methods cannot see it), mount-yaw removal uncertain by ~0.1 deg; the
  ~0.1 s fix clock mismatch moves the heading by < 0.15 deg at |r| < 1.5 deg/s.
* gyro bias within 0.1 deg/s of Android's and of the pose-derived bias: the two references
  differ by 0.03 deg/s; a minute of GNSS course with ~0.3 deg correlated errors resolves the
  bias to ~0.3 deg / 30 s = 0.01 deg/s, and the 3.8 deg tilt of the gyro z-axis changes the
  yaw rate by < 0.3 %; 0.1 deg/s is 2.5 % of the bias.  Methods whose gyro_bias stays exactly 0
  have not identified one (the observers take it at standstill; there is none here).
* wheel-speed ratio (measured/true) within 0.012 of the pose's: a 1 % error is 10 m along-track
  over this kilometre, 5x the fixes' own 2 m RMS, so GNSS-aided identification must do better.
* GNSS-aided position RMSE < 6.3 m: 3x the fixes' own RMS error against the pose (2.1 m).
* 40 s GNSS outage (~670 m): end error < 5 % of the distance (33 m); the estimator-free
  baseline (Android-bias gyro + raw CAN speed, started from the pose) reaches 9.6 m.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from sideslip.drive import Drive
from sideslip.io.comma2k19 import convert_comma2k19
from sideslip.methods.registry import all_methods
from sideslip.vehicle import Vehicle, load_vehicle

pytestmark = pytest.mark.realdata

ROOT = Path(__file__).resolve().parents[2]
SEGMENT = (ROOT.parent / "shared" / "data" / "comma2k19_example1"
           / "b0c9d2329ad1606b_2018-08-02--08-34-47_40")
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from benchmarks import realdata_check as rc  # noqa: E402

# Known failures on this minute, found by this check; strict so the test says when fixed.
KNOWN_HEADING_FAILURES = {
    "kkf": "the causal KKF starts from a 1 deg/s bias prior and needs about 10 s of straight "
    "driving to learn this raw gyro's 3.9 deg/s bias (it then matches Android's to 0.03 deg/s "
    "and holds the heading within 0.3 deg); the transient makes the minute's heading RMSE "
    "3.8 deg, above the 1 deg bound",
}
OUTAGE_DISTANCE_FRACTION = 0.05


@pytest.fixture(scope="module")
def setup() -> tuple[Drive, Vehicle]:
    if not SEGMENT.is_dir():
        pytest.skip(f"real data absent: {SEGMENT} (../shared/data is not shipped with the repo)")
    vehicle = load_vehicle("rav4")
    return convert_comma2k19(SEGMENT, vehicle), vehicle


@pytest.fixture(scope="module")
def results(setup: tuple[Drive, Vehicle]) -> tuple[dict[str, dict[str, Any]], dict[str, str]]:
    return rc.run_all(*setup)


@pytest.fixture(scope="module")
def facts(setup: tuple[Drive, Vehicle]) -> dict[str, float]:
    return rc.pose_facts(setup[0])


def _params(name: str) -> Any:
    marks = ()
    if name in KNOWN_HEADING_FAILURES:
        marks = (pytest.mark.xfail(reason=KNOWN_HEADING_FAILURES[name], strict=True),)
    return pytest.param(name, marks=marks, id=name)


METHODS = sorted(all_methods())


def test_every_method_runs_or_says_why(results: tuple[dict, dict]) -> None:
    ran, skipped = results
    assert set(ran) | set(skipped) == set(METHODS)
    assert all(reason for reason in skipped.values())
    for name, row in ran.items():
        assert row["finite"], name  # run_method also checks; here for the record


def test_pose_facts_match_data_notes(facts: dict[str, float]) -> None:
    assert facts["can_ratio"] == pytest.approx(0.9916, abs=0.001)
    assert np.degrees(facts["android_bias"]) == pytest.approx(-3.917, abs=0.002)
    assert np.degrees(facts["pose_bias"]) == pytest.approx(-3.886, abs=0.01)


@pytest.mark.parametrize("name", [_params(n) for n in METHODS])
def test_heading_bias_scale_and_position_within_tolerance(
    name: str, results: tuple[dict, dict], facts: dict[str, float]
) -> None:
    ran, skipped = results
    if name in skipped:
        pytest.skip(f"{name}: {skipped[name]}")
    row = ran[name]
    if "yaw_rmse_deg" in row:
        assert row["yaw_rmse_deg"] < 1.0
    if "gyro_bias_final_degps" in row and row["gyro_bias_final_degps"] != 0.0:
        assert abs(row["bias_minus_android_degps"]) < 0.1
        assert abs(row["bias_minus_pose_degps"]) < 0.1
    if "wheel_ratio" in row:
        assert abs(row["wheel_ratio_minus_pose"]) < 0.012
    if "pos_rmse_m" in row:
        assert row["pos_rmse_m"] < 6.3


def test_dead_reckoning_through_a_gnss_outage(setup: tuple[Drive, Vehicle],
                                              results: tuple[dict, dict]) -> None:
    drive, vehicle = setup
    ran, _ = results
    with_pos = [n for n, r in ran.items() if "pos_rmse_m" in r]
    outage = rc.outage_errors(drive, vehicle, with_pos)
    span = drive.t > drive.t[0] + rc.OUTAGE_START_S
    distance = float(np.nanmean(drive["v_can"]) * (drive.t[span][-1] - drive.t[span][0]))
    assert 600 < distance < 720
    for name, err in outage.items():
        assert np.isfinite(err["end_m"]), name
        assert err["end_m"] < OUTAGE_DISTANCE_FRACTION * distance, name
    assert rc.baseline_dead_reckoning(drive) < 15.0  # measured 9.6 m
