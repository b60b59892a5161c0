"""The fused estimator's measurement models: every analytic Jacobian against central
differences, and each model's value in a case with a known answer."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sideslip.models import fused_measurements as fm
from sideslip.models.fused_process import IMU, IPSI, ISF, ISR, ISW, ITAU, IVX, IVY, NX_CORE, NX_GNSS_CAL, U_WZ

# [l_f, l_r, C_f/m, C_r/m, g l_r/L, g l_f/L, curve shape]: the brush curve, and the same axles
# with the simplified Magic Formula curve (S = 1.3)
AXLE = np.array([1.2, 1.5, 70.0, 80.0, 9.81 * 1.5 / 2.7, 9.81 * 1.2 / 2.7, 0.0])
AXLE_MF = np.array([*AXLE[: fm.A_SHAPE], 1.3])
LEVER = np.array([0.4, -0.1, 1.2])
U = np.array([0.25, 0.02, -0.01, 0.3, 5.0, 4.9])


def _x(nx: int) -> np.ndarray:
    rng = np.random.default_rng(7)
    x = rng.normal(0.0, 0.05, nx)
    x[IPSI], x[IVX], x[IVY] = 0.4, 20.0, -0.3
    x[ISW] = 1.01
    x[ISF], x[ISR], x[IMU] = 0.9, 1.1, 0.8
    if nx > NX_CORE:
        x[ITAU] = 0.04
    return x


CASES = {
    "wheel_speed": (fm.wheel_speed, ()),
    "standstill_yaw_rate": (fm.standstill_yaw_rate, (U, 0.01)),
    "rear_axle_force": (fm.rear_axle_force, (U, 0.01, AXLE)),
    "rear_axle_velocity": (fm.rear_axle_velocity, (U, 0.01, AXLE)),
    "front_axle_force": (fm.front_axle_force, (U, 0.05, 0.01, AXLE)),
    "rear_axle_force_magic": (fm.rear_axle_force, (U, 0.01, AXLE_MF)),
    "front_axle_force_magic": (fm.front_axle_force, (U, 0.05, 0.01, AXLE_MF)),
    "gnss_velocity": (fm.gnss_velocity, (U, 0.01, LEVER)),
    "gnss_position": (fm.gnss_position, (U, 0.01, LEVER, 0.02)),
}


@pytest.mark.parametrize("nx", [NX_CORE, NX_CORE + NX_GNSS_CAL])
@pytest.mark.parametrize("name", sorted(CASES))
def test_jacobian_matches_central_differences(name, nx):
    """H against central differences (h = 1e-6; smooth models, agreement to 1e-5 absolute)."""
    func, args = CASES[name]
    x = _x(nx)
    _, H = fm.predicted(func, x, *args)
    H = np.atleast_2d(H)
    num = np.zeros_like(H)
    h = 1e-6
    for j in range(nx):
        xp, xm = x.copy(), x.copy()
        xp[j] += h
        xm[j] -= h
        num[:, j] = (fm.predicted(func, xp, *args)[0] - fm.predicted(func, xm, *args)[0]) / (2 * h)
    np.testing.assert_allclose(H, num, atol=1e-5)


def test_rear_axle_force_is_linear_tyre_at_small_slip():
    """Rear slip -(v_y - l_r r)/v_x = 0.001 -> force C_r z (1 - u), u = C z / (3 mu F_z) = 0.6 %
    the brush curve's first bend; the linear part alone would be 0.6 % higher."""
    x = np.zeros(NX_CORE)
    x[IVX], x[IVY], x[ISR], x[IMU] = 20.0, -0.02, 1.0, 1.0
    u = np.zeros(6)
    f, _ = fm.predicted(fm.rear_axle_force, x, u, 0.0, AXLE)
    u = AXLE[fm.A_CR] * 0.001 / (3 * AXLE[fm.A_NR])
    assert f[0] == pytest.approx(AXLE[fm.A_CR] * 0.001 * (1 - u), rel=1e-4)


@pytest.mark.parametrize(("func", "extra", "index"), [
    (fm.rear_axle_force, (), ISR), (fm.front_axle_force, (0.05,), ISF),
])  # fmt: skip
def test_an_axle_stiffness_is_held_within_half_and_twice_the_files(func, extra, index):
    """Beyond [SCALE_MIN, SCALE_MAX] the scale state no longer moves the force (H = 0): a cue
    the tyres cannot explain (a misplaced antenna drove the rear scale to 0.09 and to 5.2 on
    urban_course) cannot make the tyres say any slip is fine, or none is."""
    x = _x(NX_CORE)
    args = (U, *extra, 0.01, AXLE)
    forces = {}
    for value in (0.2, fm.SCALE_MIN, 1.0, fm.SCALE_MAX, 5.0):
        x[index] = value
        f, H = fm.predicted(func, x, *args)
        forces[value] = f[0]
        assert (np.atleast_2d(H)[0, index] == 0.0) == (value in (0.2, 5.0))
    assert forces[0.2] == forces[fm.SCALE_MIN] and forces[5.0] == forces[fm.SCALE_MAX]
    assert abs(forces[fm.SCALE_MIN]) < abs(forces[1.0]) < abs(forces[fm.SCALE_MAX])


def test_rear_axle_velocity_is_the_slip_angles_numerator_in_reverse_too():
    """Reversing at 2 m/s, v_y = 0.2 m/s, gyro 0.15 rad/s (no bias, level): the rear axle
    moves sideways at v_y - l_r r; the same value forwards (no division by v_x)."""
    x = np.zeros(NX_CORE)
    x[IVX], x[IVY] = -2.0, 0.2
    u = np.zeros(7)
    u[U_WZ] = 0.15
    back, _ = fm.predicted(fm.rear_axle_velocity, x, u, 0.0, AXLE)
    x[IVX] = 2.0
    ahead, _ = fm.predicted(fm.rear_axle_velocity, x, u, 0.0, AXLE)
    assert back[0] == pytest.approx(0.2 - AXLE[fm.A_LR] * 0.15)
    assert ahead[0] == pytest.approx(back[0])


def test_position_of_a_late_fix_lies_behind_along_the_track():
    """A fix 0.1 s old (age + latency) at 20 m/s due East sits 2 m west of the antenna."""
    x = np.zeros(NX_CORE + NX_GNSS_CAL)
    x[IVX] = 20.0
    x[ITAU] = 0.05
    (e, n), _ = fm.predicted(fm.gnss_position, x, np.zeros(6), 0.0, np.zeros(3), 0.05)
    assert e == pytest.approx(-2.0)
    assert n == pytest.approx(0.0)


def test_doppler_sees_the_roll_rate_through_a_tall_lever_arm():
    """Antenna 1.2 m up, roll rate 0.1 rad/s: 0.12 m/s to the right (omega x l), heading 0."""
    x = np.zeros(NX_CORE)
    x[IVX] = 10.0
    u = np.array([0.0, 0.1, 0.0, 0.0, 0.0, 0.0])
    (ve, vn), _ = fm.predicted(fm.gnss_velocity, x, u, 0.0, np.array([0.0, 0.0, 1.2]))
    assert ve == pytest.approx(10.0)
    assert vn == pytest.approx(-0.12)
    assert math.isfinite(ve)
