"""Roll physics of seed 003 (models/roll.py): analytic cases and agreement with the single-track model."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from sideslip.models.roll import (
    compensate_ay,
    dynamic_bank_weight,
    dynamic_factor,
    roll_arm,
    sin_roll_from_ay,
    sin_roll_from_r,
    static_bank,
    suspension_roll,
    suspension_roll_steady,
    tseng_gains,
)
from sideslip.models.single_track import continuous, steady_state
from sideslip.vehicle import G, load_vehicle

VEH = load_vehicle("seed003_sedan")


def test_static_bank_is_the_accelerometer_tilt_at_standstill() -> None:
    # At rest a_ym = g sin(phi) exactly (package convention), r v = 0.
    phi = np.deg2rad([-20.0, -3.0, 0.0, 5.0, 25.0])
    assert np.allclose(static_bank(G * np.sin(phi), 0.0 * phi, 0.0 * phi), phi, atol=1e-12)


def test_static_bank_removes_the_centripetal_part() -> None:
    # Steady left turn on a road banked by -10 deg (right edge higher): a_y = r v,
    # a_ym = a_y + g sin(bank); eq 46 (our sign) gives the bank back.
    r, v, bank = 0.3, 20.0, np.deg2rad(-10.0)
    aym = r * v + G * np.sin(bank)
    assert static_bank(np.array([aym]), np.array([r]), np.array([v]))[0] == pytest.approx(bank)


def test_compensate_ay_inverts_the_accelerometer_model() -> None:
    ay = np.array([-3.0, 0.0, 4.0])
    roll = np.deg2rad([2.0, -8.0, 15.0])
    assert np.allclose(compensate_ay(ay + G * np.sin(roll), roll), ay, atol=1e-12)


def test_suspension_roll_steady_state_is_eq43() -> None:
    # Eq 43: phi = m h a / k, and a left turn (a_y > 0) rolls the body right side down (> 0).
    h = VEH.cg_height - VEH.roll_axis_height
    assert roll_arm(VEH) == pytest.approx(0.54)  # seed 003 Table 1
    phi = suspension_roll_steady(np.array([4.0]), VEH)[0]
    assert phi == pytest.approx(VEH.mass * h * 4.0 / VEH.roll_stiffness) and phi > 0


def test_suspension_roll_follows_the_second_order_model_of_eq41() -> None:
    # Step of a_ym: the trapezoidal integration must match the analytic step response of
    # I_r s^2 + d s + k to within the O(dt^2) error of the rule (dt = 5 ms, w_n ~ 10 rad/s).
    t = np.arange(0.0, 3.0, 0.005)
    aym = np.where(t >= 0.5, 3.0, 0.0)
    out = suspension_roll(t, aym, VEH)
    sys = signal.lti([VEH.mass * roll_arm(VEH)],
                     [VEH.roll_inertia, VEH.roll_damping, VEH.roll_stiffness])
    _, ref, _ = signal.lsim(sys, aym, t)
    assert np.max(np.abs(out - ref)) < 2e-3 * np.max(np.abs(ref))
    assert out[-1] == pytest.approx(suspension_roll_steady(np.array([3.0]), VEH)[0], rel=1e-3)


@pytest.mark.parametrize("speed", [8.0, 22.2, 38.9])
def test_tseng_gains_equal_single_track_steady_state(speed: float) -> None:
    # Eqs 49-52 restated in our sign must be the steady state of the same linear model with
    # the bank input (single_track: u = [delta, sin(bank)]), a_ym = v r + g sin(bank).
    gains = tseng_gains(np.array([speed]), VEH.wheelbase, VEH.understeer_gradient_tyres)
    ss = steady_state(continuous(VEH, speed))  # rows beta, r; columns delta, sin(bank)
    assert gains.delta_r[0] == pytest.approx(ss[1, 0], rel=1e-9)
    assert gains.phi_r[0] == pytest.approx(ss[1, 1], rel=1e-9)
    assert gains.delta_ay[0] == pytest.approx(speed * ss[1, 0], rel=1e-9)
    assert gains.phi_ay[0] == pytest.approx(speed * ss[1, 1] + G, rel=1e-9)
    # understeer (K_us > 0): the bank's gravity turns the car down-slope (r < 0 for bank > 0)
    assert gains.phi_r[0] < 0 < gains.phi_ay[0]


def test_roll_channels_and_dfc_agree_in_a_steady_banked_turn() -> None:
    # Linear model, steady state with steer and bank: eqs 55 and 56 return the bank,
    # eq 46 too (no suspension roll here), so the DFC (eq 57) is zero and eq 58's factor is 1.
    v, delta, bank = 22.2, np.deg2rad(1.5), np.deg2rad(6.0)
    ss = steady_state(continuous(VEH, v))
    r = ss[1, 0] * delta + ss[1, 1] * np.sin(bank)
    aym = v * r + G * np.sin(bank)
    gains = tseng_gains(np.array([v]), VEH.wheelbase, VEH.understeer_gradient_tyres)
    s_ay = sin_roll_from_ay(np.array([aym]), np.array([delta]), gains)
    s_r = sin_roll_from_r(np.array([r]), np.array([delta]), gains)
    s_ss = np.sin(static_bank(np.array([aym]), np.array([r]), np.array([v])))
    assert s_ay[0] == pytest.approx(np.sin(bank), rel=1e-9)
    assert s_r[0] == pytest.approx(np.sin(bank), rel=1e-9)
    assert s_ss[0] == pytest.approx(np.sin(bank), rel=1e-9)
    dfc = dynamic_factor(s_ay, s_r, s_ss, np.array([v]), gains)
    assert abs(dfc[0]) < 1e-9
    assert dynamic_bank_weight(dfc, np.array([0.0]))[0] == pytest.approx(1.0)


def test_dfc_is_large_in_a_steering_transient_on_flat_ground() -> None:
    # Just after a steering step the yaw rate and a_y have not built up: the channels disagree
    # by about the missing steady a_y (~ H_delta->ay delta = 3 m/s^2 here), so eq 58 kills the bank.
    v, delta = 22.2, np.deg2rad(2.0)
    gains = tseng_gains(np.array([v]), VEH.wheelbase, VEH.understeer_gradient_tyres)
    s_ay = sin_roll_from_ay(np.array([0.0]), np.array([delta]), gains)
    s_r = sin_roll_from_r(np.array([0.0]), np.array([delta]), gains)
    dfc = dynamic_factor(s_ay, s_r, np.array([0.0]), np.array([v]), gains)
    assert abs(dfc[0]) > 1.0
    assert dynamic_bank_weight(dfc, np.array([0.0]))[0] == 0.0


def test_tseng_gains_finite_at_standstill_and_neutral_steer() -> None:
    gains = tseng_gains(np.array([0.0, 1e-3, 30.0]), 2.7, 0.0)
    for arr in (gains.phi_ay, gains.phi_r, gains.delta_ay, gains.delta_r):
        assert np.isfinite(arr).all()
    s = sin_roll_from_r(np.array([0.3, 0.0, -0.3]), np.zeros(3), gains)
    assert np.all(np.abs(s) <= 1.0)


def test_missing_roll_inertia_and_damping_fall_back_to_typical_dynamics() -> None:
    """Users' files often lack roll inertia/damping: the steady state (eq 43, from m, h, k)
    is unchanged, the transient uses a 1.5 Hz, 0.5-damped roll mode, and the methods run."""
    import math

    from sideslip.drive import drive_from_columns
    from sideslip.methods.registry import all_methods, why_not
    from sideslip.models.roll import roll_dynamics, suspension_roll, suspension_roll_steady
    from sideslip.vehicle import load_vehicle

    full = load_vehicle("seed003_sedan")
    rough = full.with_changes(roll_inertia=math.nan, roll_damping=math.nan)
    inertia, damping, assumed = roll_dynamics(rough)
    assert assumed and not roll_dynamics(full)[2]
    k_eff = rough.roll_stiffness - rough.mass * 9.80665 * (rough.cg_height - rough.roll_axis_height)
    assert math.sqrt(k_eff / inertia) / (2 * math.pi) == pytest.approx(1.5)
    assert damping / (2 * math.sqrt(k_eff * inertia)) == pytest.approx(0.5)
    t = np.arange(0, 5, 0.01)
    ay = np.where(t > 1.0, 4.0, 0.0)
    phi = suspension_roll(t, ay, rough)
    assert np.isfinite(phi).all()
    # settles to the same steady state as the full file's model (eq 41 with k, m, h)
    assert phi[-1] == pytest.approx(suspension_roll(t, ay, full)[-1], rel=0.02)
    # eq 41 as written has no gravity moment, so it settles exactly on eq 43: m h a_y / k
    assert phi[-1] == pytest.approx(float(suspension_roll_steady(4.0, rough)), rel=0.02)
    drive = drive_from_columns(
        {"t": t, "wz": 0 * t, "ax": 0 * t, "ay": ay, "steer": 0 * t, "v_can": 20 + 0 * t}
    )
    for name in ("roll_index", "obs_modified", "obs_kinematic"):
        assert why_not(all_methods()[name], drive, rough) is None
