"""Dead reckoning, seed 000 eqs 1-4: analytic cases."""

from __future__ import annotations

import numpy as np

from sideslip.models.dead_reckoning import (
    dead_reckon,
    horizontal_speed,
    horizontal_yaw_rate,
    integrate_heading,
)


def test_straight_line_at_constant_heading_is_exact() -> None:
    t = np.linspace(0.0, 10.0, 1001)
    e, n = dead_reckon(t, np.full(t.size, 10.0), np.full(t.size, np.pi / 6), e0=5.0, n0=-2.0)
    assert np.isclose(e[-1], 5.0 + 100.0 * np.cos(np.pi / 6), atol=1e-9)
    assert np.isclose(n[-1], -2.0 + 100.0 * np.sin(np.pi / 6), atol=1e-9)


def test_circle_closes_on_itself_after_one_lap() -> None:
    # V = 10 m/s, r = 0.2 rad/s: radius 50 m, one lap in 2 pi / 0.2 s.  The trapezoidal rule's
    # chord error per step (dt = 1 ms) is ~ R (r dt)^3 / 12 per step -> far below 1 mm per lap.
    t = np.linspace(0.0, 2 * np.pi / 0.2, 31417)
    yaw = integrate_heading(t, np.full(t.size, 0.2))
    e, n = dead_reckon(t, np.full(t.size, 10.0), yaw)
    assert np.hypot(e[-1], n[-1]) < 1e-3
    assert np.isclose(n.max(), 100.0, atol=1e-3)  # diameter 2 R, left turn from East


def test_sideslip_turns_the_path_and_moves_v_over_cos_beta() -> None:
    # wheel speed measures v_x; with beta the point moves v_x / cos(beta) along yaw + beta
    t = np.linspace(0.0, 1.0, 101)
    beta = np.full(t.size, 0.1)
    e, n = dead_reckon(t, np.full(t.size, 10.0), np.zeros(t.size), beta)
    assert np.isclose(np.arctan2(n[-1], e[-1]), 0.1, atol=1e-12)
    assert np.isclose(np.hypot(e[-1], n[-1]), 10.0 / np.cos(0.1), atol=1e-9)
    assert np.isclose(e[-1], 10.0, atol=1e-9)  # the along-heading distance is v_x t


def test_yaw_rate_projection_undoes_roll_and_pitch() -> None:
    # turning at Omega about the vertical with roll phi, pitch theta: w_z = Omega cos phi cos theta
    omega, phi, theta = 0.3, 0.1, -0.05
    wz = np.array([omega * np.cos(phi) * np.cos(theta)])
    assert np.isclose(horizontal_yaw_rate(wz, 0.0, [phi], [theta])[0], omega, rtol=1e-12)
    # the offset is measured minus true, the scale multiplies the raw gyro
    assert np.isclose(horizontal_yaw_rate(np.array([0.51]), 0.01, gyro_scale=1.0)[0], 0.5)


def test_eq4_speed_scale_factor_and_pitch() -> None:
    v = horizontal_speed(np.array([20.0]), scale_factor=1.01, pitch=np.array([0.1]))
    assert np.isclose(v[0], 20.0 * 1.01 * np.cos(0.1))


def test_anchor_row_takes_the_given_position_and_heading() -> None:
    t = np.linspace(0.0, 10.0, 101)
    yaw = integrate_heading(t, np.full(t.size, 0.1), yaw0=1.0, start=50)
    assert np.isclose(yaw[50], 1.0) and np.isclose(yaw[0], 0.5)
    e, n = dead_reckon(t, np.full(t.size, 5.0), yaw, e0=3.0, n0=4.0, start=50)
    assert (e[50], n[50]) == (3.0, 4.0)
    assert np.isfinite(e).all() and np.isfinite(n).all()
