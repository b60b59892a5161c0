"""Roll physics of seed 003 (IEEE Access 2020, Sec. III): suspension roll, static bank, Tseng.

Signs are the package's (ISO 8855): roll ``phi`` > 0 lowers the right side, bank uses the roll
sign, and the lateral accelerometer on a body rolled by ``phi`` (suspension roll + road bank,
relative to the horizontal) reads ``a_ym = a_y + g sin(phi)`` with ``a_y`` the gravity-free
lateral acceleration.  Seed 003 writes ``a_ym + g sin(Phi) = v_y' + r v_x`` (eq 44), i.e. its
``Phi`` is minus ours; every equation below is restated in our sign, re-derived as noted.

* Suspension roll (eq 41): ``I_r phi'' = m h a_ym - d phi' - k phi`` with ``h`` the CG height
  above the roll axis, ``I_r`` the roll inertia about the roll axis (eq 42).  A left turn
  (a_y > 0) pushes the body to the right, right side down: phi > 0, so the sign of eq 41 holds
  in ours.  Driving it with the *measured* ``a_ym`` is what makes it exact to first order: the
  body's own roll adds ``g phi`` to ``a_ym`` and the destabilising gravity moment ``m g h phi``
  to the equation, and the two cancel.  Steady state (eq 43): ``phi_sus = m h a_ym / k``.
* Static bank (eq 46): with ``v_y' = 0``, ``a_ym - r v_x = g sin(phi)``, so
  ``phi_ss = asin((a_ym - r v_x)/g)`` (the paper's ``(r v_x - a_ym)/g`` in its own sign).
  In a steady state it is the *total* roll (bank + suspension roll).
* Tseng's steady-state transfer functions (eqs 49-52), re-derived from the single-track model
  on a bank (``m(v r) = F_yf + F_yr - m g sin(phi)``, steady state): the steering equation
  becomes ``delta = L r / v + K_us (v r + g sin phi)``, so
  ``r = v/(L + K_us v^2) delta - v K_us g/(L + K_us v^2) sin(phi)`` and with
  ``a_ym = v r + g sin(phi)``:
  ``H_phi->ay = g L/(L + K_us v^2)``,   ``H_phi->r = -v K_us g/(L + K_us v^2)``,
  ``H_delta->ay = v^2/(L + K_us v^2)``, ``H_delta->r = v/(L + K_us v^2)``.
  The two roll gains are the paper's eqs 49-50 with the sign of Phi flipped (eq 49 reads
  ``v^2 k_u g/(L + k_u v^2) - g = -g L/(L + k_u v^2)``).  ``K_us`` is the understeer gradient
  in rad/(m/s^2).
* Roll seen by each channel (eqs 55-56), Tseng's dynamic factor (eq 57) and dynamic bank
  (eq 58) follow.  The DFC is in m/s^2 (H_phi->ay ~ g); eq 58 subtracts it from 1 as written,
  i.e. numerically in m/s^2 (a 1 m/s^2 mismatch between the channels cancels the bank), and
  ``d sin(phi_ss)/dt`` in 1/s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from sideslip.typical import TYPICAL
from sideslip.vehicle import G, Vehicle

FloatArray = NDArray[np.float64]

MIN_ROLL_GAIN = 1e-3  # floor of |H_phi->r| (rad/s per unit sin(phi)); near-neutral-steer cars


def roll_arm(vehicle: Vehicle) -> float:
    """h: CG height above the roll axis, m (seed 003 Table 1 gives 0.54 m)."""
    return vehicle.cg_height - vehicle.roll_axis_height


def suspension_roll_steady(ay_m: ArrayLike, vehicle: Vehicle) -> FloatArray:
    """Eq 43: phi_sus,ss = m h a_ym / k (rad), from the measured lateral specific force."""
    return vehicle.mass * roll_arm(vehicle) * np.asarray(ay_m, dtype=float) / vehicle.roll_stiffness


@numba.njit(cache=True)
def _roll_oscillator(
    t: NDArray, force: NDArray, inertia: float, damping: float, stiffness: float
) -> NDArray:  # pragma: no cover - compiled
    # Trapezoidal (Tustin) step of I phi'' + d phi' + k phi = force: A-stable for any dt.
    n = t.size
    out = np.zeros(n)
    phi = force[0] / stiffness
    rate = 0.0
    out[0] = phi
    a10 = -stiffness / inertia
    a11 = -damping / inertia
    for k in range(n - 1):
        h = t[k + 1] - t[k]
        u = 0.5 * (force[k] + force[k + 1]) / inertia
        # (I - h/2 A) x1 = (I + h/2 A) x0 + h [0, u]
        r0 = phi + 0.5 * h * rate
        r1 = rate + 0.5 * h * (a10 * phi + a11 * rate) + h * u
        m00, m01 = 1.0, -0.5 * h
        m10, m11 = -0.5 * h * a10, 1.0 - 0.5 * h * a11
        det = m00 * m11 - m01 * m10
        phi = (m11 * r0 - m01 * r1) / det
        rate = (-m10 * r0 + m00 * r1) / det
        out[k + 1] = phi
    return out


TYPICAL_ROLL_FREQUENCY_HZ = TYPICAL["roll_frequency_hz"].value
TYPICAL_ROLL_DAMPING_RATIO = TYPICAL["roll_damping_ratio"].value


def roll_dynamics(vehicle: Vehicle) -> tuple[float, float, bool]:
    """(roll inertia kg m^2, roll damping N m s/rad, assumed) for eq 41.

    Users' vehicle files often give the roll stiffness (it sets the steady state, eq 43) but
    not the roll inertia or damping.  Where the file lacks them, typical passenger-car roll
    dynamics are assumed (natural frequency 1.5 Hz, damping ratio 0.5 on the effective
    stiffness k - m g h), and ``assumed`` is True so that methods can say so.
    """
    inertia, damping = vehicle.roll_inertia, vehicle.roll_damping
    assumed = not (np.isfinite(inertia) and np.isfinite(damping))
    k_eff = vehicle.roll_stiffness - vehicle.mass * G * roll_arm(vehicle)
    if k_eff <= 0.0:
        k_eff = vehicle.roll_stiffness
    if not np.isfinite(inertia):
        inertia = k_eff / (2.0 * np.pi * TYPICAL_ROLL_FREQUENCY_HZ) ** 2
    if not np.isfinite(damping):
        damping = 2.0 * TYPICAL_ROLL_DAMPING_RATIO * float(np.sqrt(k_eff * inertia))
    return float(inertia), float(damping), assumed


def suspension_roll(t: ArrayLike, ay_m: ArrayLike, vehicle: Vehicle) -> FloatArray:
    """Eq 41: suspension roll (rad) of the sprung mass driven by the measured a_ym (m/s^2).

    ``I_r phi'' = m h a_ym - d phi' - k phi`` integrated with the trapezoidal rule on the
    time base ``t`` (s), starting at the steady state of the first sample (eq 43).  Roll
    inertia and damping missing from the vehicle file: see :func:`roll_dynamics`.
    """
    tt = np.asarray(t, dtype=float)
    force = vehicle.mass * roll_arm(vehicle) * np.asarray(ay_m, dtype=float)
    inertia, damping, _ = roll_dynamics(vehicle)
    return _roll_oscillator(tt, force, inertia, damping, vehicle.roll_stiffness)


def static_bank(ay_m: ArrayLike, r: ArrayLike, vx: ArrayLike) -> FloatArray:
    """Eq 46 in our sign: phi_ss = asin((a_ym - r v_x)/g), rad (valid when v_y' ~ 0)."""
    s = np.asarray(ay_m, dtype=float) - np.asarray(r, dtype=float) * np.asarray(vx, dtype=float)
    return np.asarray(np.arcsin(np.clip(s / G, -1.0, 1.0)), dtype=float)


def compensate_ay(ay_m: ArrayLike, roll: ArrayLike) -> FloatArray:
    """Eq 62 in our sign: gravity-free a_y = a_ym - g sin(roll), m/s^2."""
    return np.asarray(ay_m, dtype=float) - G * np.sin(np.asarray(roll, dtype=float))


@dataclass(frozen=True)
class TsengGains:
    """Steady-state gains of eqs 49-52 (our roll sign), arrays over samples.

    phi_ay: a_ym per sin(phi), m/s^2;  phi_r: r per sin(phi), rad/s;
    delta_ay: a_y per road-wheel angle, m/s^2/rad;  delta_r: r per road-wheel angle, 1/s.
    """

    phi_ay: FloatArray
    phi_r: FloatArray
    delta_ay: FloatArray
    delta_r: FloatArray


def tseng_gains(vx: ArrayLike, wheelbase: float, understeer_gradient: float) -> TsengGains:
    """Eqs 49-52 re-derived in our sign (see module docstring); ``vx`` in m/s.

    ``understeer_gradient`` K_us in rad/(m/s^2).  |H_phi->r| is floored at
    :data:`MIN_ROLL_GAIN` keeping the sign of -K_us (yaw says little about bank near neutral
    steer or at low speed; the floor keeps eq 56 finite, and its estimate is then clipped).
    """
    v = np.asarray(vx, dtype=float)
    den = wheelbase + understeer_gradient * v**2
    den = np.where(np.abs(den) < 1e-3, 1e-3, den)  # oversteer at critical speed
    phi_ay = G * wheelbase / den
    phi_r = -v * understeer_gradient * G / den
    sign = -1.0 if understeer_gradient >= 0 else 1.0
    phi_r = np.where(np.abs(phi_r) < MIN_ROLL_GAIN, sign * MIN_ROLL_GAIN, phi_r)
    return TsengGains(phi_ay, phi_r, v**2 / den, v / den)


def sin_roll_from_ay(ay_m: ArrayLike, delta: ArrayLike, gains: TsengGains) -> FloatArray:
    """Eq 55: sin(phi_ay) = (a_ym - H_delta->ay delta) / H_phi->ay, clipped to [-1, 1]."""
    s = np.asarray(ay_m, dtype=float) - gains.delta_ay * np.asarray(delta, dtype=float)
    return np.clip(s / gains.phi_ay, -1.0, 1.0)


def sin_roll_from_r(r: ArrayLike, delta: ArrayLike, gains: TsengGains) -> FloatArray:
    """Eq 56: sin(phi_r) = (r - H_delta->r delta) / H_phi->r, clipped to [-1, 1]."""
    s = np.asarray(r, dtype=float) - gains.delta_r * np.asarray(delta, dtype=float)
    return np.clip(s / gains.phi_r, -1.0, 1.0)


def dynamic_factor(
    sin_ay: ArrayLike, sin_r: ArrayLike, sin_ss: ArrayLike, vx: ArrayLike, gains: TsengGains
) -> FloatArray:
    """Eq 57: DFC = H_phi->ay (sin phi_ay - sin phi_ss) + v_x H_phi->r (sin phi_r - sin phi_ss).

    In m/s^2; zero in a steady state, where the three roll estimates agree.
    """
    s_ss = np.asarray(sin_ss, dtype=float)
    return np.asarray(
        gains.phi_ay * (np.asarray(sin_ay) - s_ss)
        + np.asarray(vx, dtype=float) * gains.phi_r * (np.asarray(sin_r) - s_ss),
        dtype=float,
    )


def dynamic_bank_weight(dfc: ArrayLike, dsin_ss_dt: ArrayLike) -> FloatArray:
    """The factor of eq 58: max(0, 1 - |DFC| - |d sin(phi_ss)/dt|), in [0, 1]."""
    w = 1.0 - np.abs(np.asarray(dfc, dtype=float)) - np.abs(np.asarray(dsin_ss_dt, dtype=float))
    return np.clip(w, 0.0, 1.0)
