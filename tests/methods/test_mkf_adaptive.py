"""Seed 001 sec. VI: cornering stiffness and gyro scale identified from the KKF, the MKF
rerun with them."""

from __future__ import annotations

import pytest

from sideslip.methods.mkf import mkf
from sideslip.methods.mkf_adaptive import identify_from_kkf, mkf_adaptive
from sideslip.methods.registry import all_methods, run_method
from sideslip.vehicle import load_vehicle
from tests.conftest import sim_drive
from tests.methods.seed001_drives import BLAZER, beta_err_deg, linear_drive, rms


def test_cornering_stiffness_identified_from_kkf_on_wrong_file() -> None:
    d = linear_drive(gyro_scale=0.02, radius=130.0)  # a_y = 3.1 m/s^2: linear range
    wrong = BLAZER.with_changes(cf=0.7 * BLAZER.cf, cr=0.7 * BLAZER.cr)
    ident = identify_from_kkf(d, wrong)
    assert ident["identified"]
    # scale factor seen from the heading change over the turn (course known to ~0.01 deg over
    # pi rad of turn): within 0.3 %
    assert ident["gyro_scale"] == pytest.approx(1.02, abs=0.003)
    # slip angles here: front ~2.4 deg, rear ~1.1 deg; the KKF beta after the scale-factor
    # correction is good to ~0.1-0.2 deg (residual scale error x pi rad of turn, course noise),
    # i.e. ~5 % of the front and ~15 % of the rear slip angle.  The wrong file is 30 % off.
    assert ident["cf"] == pytest.approx(BLAZER.cf, rel=0.10)
    assert ident["cr"] == pytest.approx(BLAZER.cr, rel=0.20)


def test_mkf_adaptive_recovers_from_wrong_cornering_stiffness() -> None:
    d = sim_drive("two_turns_gyro_sf", 0)
    off = BLAZER.with_changes(cf=0.7 * BLAZER.cf, cr=0.7 * BLAZER.cr)
    plain = rms(beta_err_deg(mkf(d, off)["beta"], d))
    adapt = mkf_adaptive(d, off)
    ident = adapt.params["identification"]
    assert ident["identified"]
    assert ident["gyro_scale"] == pytest.approx(
        1.0 + d.meta["truth_sensor"]["gyro_scale_factor"], abs=0.003
    )  # heading change over two 180 deg turns seen by the course: ~0.1 % per turn
    # identified stiffness back near the (tyre-model) truth the right file encodes: the
    # nonlinear tyres at 0.42 g give ~10 % less effective stiffness than the linear slope
    assert ident["cf"] == pytest.approx(BLAZER.cf, rel=0.15)
    assert ident["cr"] == pytest.approx(BLAZER.cr, rel=0.15)
    assert rms(beta_err_deg(adapt["beta"], d)) < 0.3 * plain


@pytest.mark.parametrize("scenario", ["banked_track_turn", "suburban_outages"])
def test_robust_to_stiffness_30_percent_off_and_other_scenarios(scenario: str) -> None:
    d = sim_drive(scenario, 0)
    veh = load_vehicle(d.meta["vehicle"])
    off = veh.with_changes(cf=0.7 * veh.cf, cr=0.7 * veh.cr)
    for name in ("kkf", "mkf", "mkf_adaptive"):
        for v in (veh, off):
            est = run_method(all_methods()[name], d, v)
            err = beta_err_deg(est["beta"], d)
            # not absurd: a few degrees at most (the KKF integrates gyro scale factor and
            # tilt through turns; the MKF is biased by a wrong file by tenths of a degree)
            assert rms(err) < 3.0, (name, rms(err))
