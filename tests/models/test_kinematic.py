"""Kinematic bicycle model (seed 004 eqs 2.1-2.6), checked against circle geometry.

A car turning with steering delta and no tyre slip turns about the point on the rear-axle line
at radius R_r = L / tan(delta) from the rear-axle centre (the instantaneous centre).  Every
relation of the model follows from that picture, so the tests build it independently of the
module and compare to round-off.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from sideslip.models.kinematic import (
    cg_velocity,
    enu_rate,
    kinematic_beta,
    lever_arm_enu,
    rear_axle_speed,
    rear_axle_yaw_rate,
    rear_wheel_speeds,
    steer_yaw_rate,
)
from sideslip.vehicle import load_vehicle

CAR = load_vehicle("midsize_sedan")


@pytest.mark.parametrize("radius", [8.0, 25.0, -40.0])
def test_rear_wheel_yaw_rate_is_right_minus_left_over_track_in_a_left_turn(radius):
    # rear-axle centre on a circle of signed radius (left turn > 0) at 10 m/s: the left rear
    # wheel runs on radius R - T/2, the right one on R + T/2, at the same angular rate v / R.
    v = 10.0
    omega = v / radius
    track = CAR.track_rear
    v_rl = omega * (radius - track / 2.0)
    v_rr = omega * (radius + track / 2.0)
    assert rear_axle_yaw_rate(v_rl, v_rr, track) == pytest.approx(omega, rel=1e-12)
    assert rear_axle_speed(v_rl, v_rr) == pytest.approx(v, rel=1e-12)
    if radius > 0:  # a left turn: the right wheel is the outer one and turns faster
        assert v_rr > v_rl


def test_rear_wheel_speeds_inverts_eqs_2_5_and_2_6():
    v = np.array([-3.0, 0.0, 5.0, 30.0])
    r = np.array([0.1, 0.0, -0.4, 0.05])
    v_rl, v_rr = rear_wheel_speeds(v, r, 1.5)
    np.testing.assert_allclose(rear_axle_speed(v_rl, v_rr), v, rtol=0, atol=1e-12)
    np.testing.assert_allclose(rear_axle_yaw_rate(v_rl, v_rr, 1.5), r, rtol=0, atol=1e-12)


@pytest.mark.parametrize("delta", [0.02, 0.3, -0.45])
def test_beta_and_yaw_rate_follow_the_instantaneous_centre(delta):
    L, lr = CAR.wheelbase, CAR.lr
    r_rear = L / math.tan(delta)  # signed radius of the rear-axle centre
    # CG velocity is perpendicular to the line from the centre (0, r_rear) to the CG (lr, 0)
    # (frame: rear axle at the origin, x forward): direction atan2(lr, r_rear) off the x axis.
    beta_geom = math.atan(lr / r_rear)
    assert kinematic_beta(delta, CAR.lf, lr) == pytest.approx(beta_geom, rel=1e-12)
    v = 12.0
    assert steer_yaw_rate(v, delta, L) == pytest.approx(v / r_rear, rel=1e-12)
    # eq 2.4: v_y at the CG is lr r, so v_y / v_x is tan(beta)
    vx, vy = cg_velocity(v, v / r_rear, lr)
    assert math.atan2(vy, vx) == pytest.approx(beta_geom, rel=1e-12)


def test_reversing_keeps_beta_and_reverses_yaw_rate():
    # Backing up with left steer the car yaws right (r < 0) and the CG velocity ratio is kept.
    delta = 0.2
    assert steer_yaw_rate(-3.0, delta, CAR.wheelbase) < 0.0
    vx, vy = cg_velocity(-3.0, steer_yaw_rate(-3.0, delta, CAR.wheelbase), CAR.lr)
    assert math.atan(vy / vx) == pytest.approx(kinematic_beta(delta, CAR.lf, CAR.lr), rel=1e-12)


def test_integrated_model_drives_the_cg_on_the_geometric_circle():
    # eqs 2.1 (rotation by psi alone), 2.2 and 2.4 integrated for 20 s at constant steering
    # must keep the CG at distance sqrt(R_r^2 + lr^2) from the instantaneous centre.  The
    # paper's printed form (rotation by psi + beta with v_y = -lr r) misses it by 1.6 m.
    L, lr, delta, v = CAR.wheelbase, CAR.lr, 0.15, 8.0
    r = steer_yaw_rate(v, delta, L)

    def rhs(_t: float, s: np.ndarray) -> list[float]:
        vx, vy = cg_velocity(v, r, lr)
        de, dn = enu_rate(vx, vy, s[2])
        return [de, dn, r]

    sol = solve_ivp(rhs, (0.0, 20.0), [0.0, 0.0, 0.0], rtol=1e-10, atol=1e-10, max_step=0.05)
    r_rear = L / math.tan(delta)
    centre = np.array([-lr, r_rear])  # rear axle at (-lr, 0) when the CG is at the origin
    dist = np.hypot(sol.y[0] - centre[0], sol.y[1] - centre[1])
    np.testing.assert_allclose(dist, math.hypot(r_rear, lr), rtol=0, atol=1e-6)


def test_functions_take_arrays_and_scalars_alike():
    delta = np.array([0.0, 0.1, -0.1])
    beta = kinematic_beta(delta, CAR.lf, CAR.lr)
    assert beta.shape == (3,)
    assert beta[1] == pytest.approx(kinematic_beta(0.1, CAR.lf, CAR.lr), rel=1e-15)
    assert beta[1] == pytest.approx(-beta[2], rel=1e-15)


def test_lever_arm_rotates_with_yaw():
    # an antenna 1 m ahead of the CG is 1 m north when the car heads north (yaw = pi/2)
    de, dn = lever_arm_enu(math.pi / 2.0, 1.0, 0.0)
    assert de == pytest.approx(0.0, abs=1e-15)
    assert dn == pytest.approx(1.0, rel=1e-15)
    de, dn = lever_arm_enu(0.0, 0.0, 0.5)  # 0.5 m left of the CG heading east is north
    assert (de, dn) == pytest.approx((0.0, 0.5))
