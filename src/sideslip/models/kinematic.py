"""Kinematic bicycle model (seed 004 eqs 2.1-2.6): rolling without lateral tyre slip.

The rear axle centre B moves along the body x axis (no rear slip), the front axle along the
steered wheel.  With rear-axle speed ``v`` (m/s, signed: negative when reversing), front
road-wheel angle ``delta`` (rad, left positive), CG-to-axle distances ``lf``, ``lr`` and
wheelbase ``L = lf + lr``:

    eq 2.5   v      = (v_RL + v_RR) / 2                   rear-axle speed from rear wheels
    eq 2.6   r      = (v_RR - v_RL) / T_r                 yaw rate from rear wheels
    eq 2.2   r      = v tan(delta) / L                    yaw rate from steering (V cos(beta) = v)
    eq 2.3   beta   = atan(lr tan(delta) / L)             sideslip at the CG
    eq 2.4   [v_x, v_y] = [v, lr r]                       body velocity at the CG
    eq 2.1   [e', n'] = R(psi) [v_x, v_y]                 = V [cos(psi+beta), sin(psi+beta)]

Signs re-derived for the package conventions (ISO 8855, ENU, yaw from East counter-clockwise):

* eq 2.6: the paper writes (v_L - v_R)/T_r (a clockwise-positive yaw).  A wheel centre at
  lateral offset y moves forward at v - r y, so v_RL = v - r T_r/2 (y = +T_r/2, left side)
  and v_RR = v + r T_r/2: in a left turn (r > 0) the right wheel runs on the outer, longer
  circle, and r = (v_RR - v_RL)/T_r.  This holds whatever the lateral tyre slip,
  since wheel speeds measure the longitudinal velocity of each wheel centre.
* eq 2.4: the paper writes v_y = -lr r (north-east-down axes).  The CG lies lr ahead of B, so
  v_C = v_B + r e_z x (lr e_x) = [v, +lr r] in ISO axes (y left).
* eq 2.1: the paper rotates [v_x, v_y] by psi + beta, which counts the sideslip twice (v_y
  already carries it).  A body vector is rotated to ENU by the yaw alone; the course psi + beta
  appears only in the equivalent form V [cos(psi + beta), sin(psi + beta)], V = |[v_x, v_y]|.
* eq 2.3 uses atan (not atan2) so that reversing (v < 0) keeps the same beta: the CG velocity
  ratio v_y / v_x = lr tan(delta) / L does not depend on the sign of v.

All functions take floats or numpy arrays and are compiled with numba, so the EKF loop
(:mod:`sideslip.methods.ekf_positioning`) calls the same code as everyone else.
Valid at low lateral acceleration (kinematic: no tyre slip angles); at speed the real yaw rate
is below v tan(delta)/L by the factor L/(L + K_us v^2) (understeer) and the real CG sideslip
falls below the kinematic one.
"""

from __future__ import annotations

from typing import Any

import numba
import numpy as np

Num = Any  # a float or a numpy float array (the functions are numba-compiled for both)


@numba.njit(cache=True)
def rear_axle_speed(v_rl: Num, v_rr: Num) -> Num:
    """Eq 2.5: speed of the rear-axle centre, m/s, from the rear wheel speeds (m/s)."""
    return 0.5 * (v_rl + v_rr)


@numba.njit(cache=True)
def rear_axle_yaw_rate(v_rl: Num, v_rr: Num, track_rear: Num) -> Num:
    """Eq 2.6 (ISO sign): yaw rate r = (v_RR - v_RL) / T_r, rad/s (left turn positive)."""
    return (v_rr - v_rl) / track_rear


@numba.njit(cache=True)
def steer_yaw_rate(v: Num, delta: Num, wheelbase: Num) -> Num:
    """Eq 2.2: yaw rate r = v tan(delta) / L, rad/s, from rear-axle speed v = V cos(beta)."""
    return v * np.tan(delta) / wheelbase


@numba.njit(cache=True)
def kinematic_beta(delta: Num, lf: Num, lr: Num) -> Num:
    """Eq 2.3: sideslip at the CG, beta = atan(lr tan(delta) / (lf + lr)), rad."""
    return np.arctan(lr * np.tan(delta) / (lf + lr))


@numba.njit(cache=True)
def cg_velocity(v: Num, r: Num, lr: Num) -> tuple[Num, Num]:
    """Eq 2.4 (ISO sign): body velocity at the CG, (v_x, v_y) = (v, lr r), m/s."""
    return v + 0.0 * r, lr * r


@numba.njit(cache=True)
def enu_rate(vx: Num, vy: Num, yaw: Num) -> tuple[Num, Num]:
    """Eq 2.1 (re-derived): (e', n') = R(yaw) [v_x, v_y], m/s, yaw from East CCW."""
    c = np.cos(yaw)
    s = np.sin(yaw)
    return vx * c - vy * s, vx * s + vy * c


@numba.njit(cache=True)
def lever_arm_enu(yaw: Num, arm_x: Num, arm_y: Num) -> tuple[Num, Num]:
    """Horizontal ENU offset (m) of a point at body (arm_x, arm_y) from the CG (roll, pitch 0)."""
    c = np.cos(yaw)
    s = np.sin(yaw)
    return arm_x * c - arm_y * s, arm_x * s + arm_y * c


def rear_wheel_speeds(v: Num, r: Num, track_rear: float) -> tuple[Num, Num]:
    """Inverse of eqs 2.5/2.6: (v_RL, v_RR) = (v - r T_r/2, v + r T_r/2), m/s (test helper)."""
    return v - 0.5 * r * track_rear, v + 0.5 * r * track_rear
