"""Baseline: direct integration of the kinematic sideslip relation (seed 003, kinematic model).

    beta' = a_y / v_x - r                      (seed 003, from v_y' = a_y - r v_x, beta ~ v_y/v_x)

with the measured lateral specific force ``ay`` taken as a_y (no gravity compensation) and the
gyro ``wz`` as r.  Open-loop: any accelerometer bias, gravity through roll/bank, or gyro bias
integrates into a drift.  It is the honest floor every other method must beat.

Low speed: below ``V_GATE`` the relation is singular; beta is held at zero there (the vehicle
restarts from rest with zero sideslip), which also handles standstill and reversing.

Health (0 good ... 1 unusable): an open-loop integral can check nothing; what it knows is how
fast it drifts.  Gravity through roll and bank and the accelerometer bias put an unmodelled
``DRIFT_AY`` (0.3 m/s^2: 1.7 deg of roll or bank, or a 30 mg bias) into a_y, so the error grows
as the integral of DRIFT_AY / v_x since the last reset; health is that over ``HEALTH_FULL_RAD``
(2 deg), clipped to 1.  Reversing rows (beta = 0, not atan2(v_y, v_x) ~ +-pi) get 1.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import NDArray

from sideslip.drive import Drive
from sideslip.estimate import Estimate
from sideslip.methods.observer_health import stale_health
from sideslip.methods.registry import SPEED, register
from sideslip.methods.roll_index import hold_first
from sideslip.signals import speed_raw
from sideslip.vehicle import Vehicle

V_GATE = 3.0  # m/s: below this, beta is reset to zero
DRIFT_AY = 0.3  # m/s^2: typical unmodelled a_y (gravity through roll/bank, bias)
HEALTH_FULL_RAD = float(np.radians(2.0))


@dataclass(frozen=True)
class KinematicIntegrationSettings:
    """Tuning of ``kinematic_integration``: ``v_gate_m_s`` (m/s), below which beta is reset."""

    v_gate_m_s: float = V_GATE

    def __post_init__(self) -> None:
        if not (np.isfinite(self.v_gate_m_s) and 0.5 <= self.v_gate_m_s <= 30.0):
            raise ValueError(f"KinematicIntegrationSettings.v_gate_m_s = {self.v_gate_m_s}: "
                             "expected 0.5 ... 30 m/s")


@numba.njit(cache=True)
def _drift_health_nb(t: NDArray, vx: NDArray, v_gate: float) -> NDArray:  # pragma: no cover
    """:func:`drift_health` in one pass: the drift integral restarts at every row below the
    gate (its running sum minus the sum at the latest reset row)."""
    n = t.size
    health = np.empty(n)
    c = 0.0
    c_reset = 0.0
    for k in range(n):
        dt = t[k] - t[k - 1] if k > 0 else 0.0
        rate = DRIFT_AY / max(vx[k], v_gate) if vx[k] >= v_gate else 0.0
        c += rate * dt
        if vx[k] < v_gate:
            c_reset = c
        h = (c - c_reset) / HEALTH_FULL_RAD
        health[k] = 1.0 if vx[k] <= -0.1 else min(max(h, 0.0), 1.0)
    return health


def drift_health(t: NDArray, vx: NDArray, v_gate: float) -> NDArray:
    """Per-row health of the module docstring (integral of DRIFT_AY / v_x since the reset)."""
    return np.asarray(_drift_health_nb(np.asarray(t, dtype=float), np.asarray(vx, dtype=float),
                                       float(v_gate)))


@numba.njit(cache=True)
def _integrate(t: NDArray, ay_m: NDArray, wz: NDArray, vx: NDArray, v_gate: float
               ) -> tuple[NDArray, NDArray, NDArray]:  # pragma: no cover - compiled
    """beta' = a_y / v_x - r by Euler steps from zero, reset below ``v_gate``, on the
    zero-order holds of ``ay_m`` and ``wz`` (0 before their first sample, as
    :func:`sideslip.signals.hold`).  Returns (beta, held r, rows with both IMU samples)."""
    n = t.size
    beta = np.zeros(n)
    r = np.empty(n)
    imu = np.empty(n, dtype=np.bool_)
    ay_k = 0.0
    r_k = 0.0
    for k in range(n):
        if k > 0:
            dt = t[k] - t[k - 1]
            v = vx[k - 1]
            if v < v_gate:
                beta[k] = 0.0
            else:
                b = beta[k - 1] + dt * (ay_k / v - r_k)
                beta[k] = min(max(b, -1.5), 1.5)
        ay_fresh = math.isfinite(ay_m[k])
        r_fresh = math.isfinite(wz[k])
        if ay_fresh:
            ay_k = ay_m[k]
        if r_fresh:
            r_k = wz[k]
        r[k] = r_k
        imu[k] = ay_fresh and r_fresh
    return beta, r, imu


@register(
    "kinematic_integration",
    columns=("wz", "ay", SPEED),
    summary="open-loop integration of beta' = a_y/v_x - r (drifts; the baseline)",
    paper="seed 003 (kinematic model)",
    settings=KinematicIntegrationSettings,
    accelerometer="cg_causal",
)
def kinematic_integration(drive: Drive, vehicle: Vehicle,
                          settings: KinematicIntegrationSettings | None = None) -> Estimate:
    """Sideslip by integrating beta' = a_y/v_x - r from zero; see module docstring."""
    st = settings or KinematicIntegrationSettings()
    raw = speed_raw(drive)  # vehicle_speed: the same hold, in one compiled pass
    vx = np.zeros_like(drive.t) if raw is None else np.asarray(hold_first(raw))
    beta, r, imu = _integrate(drive.t, drive["ay"], drive["wz"], vx, st.v_gate_m_s)
    health = drift_health(drive.t, vx, st.v_gate_m_s)
    np.maximum(health, stale_health(drive.t, imu), out=health)  # held samples in a sensor gap
    return Estimate(
        "kinematic_integration",
        drive.t,
        {"beta": beta, "r": r, "health": health},
        {"v_gate_m_s": st.v_gate_m_s, "gravity_compensation": False,
         "health": {"criterion": f"open-loop drift of {DRIFT_AY} m/s^2 / v_x since the reset, "
                    f"1 at {np.degrees(HEALTH_FULL_RAD):.0f} deg",
                    "flagged_share": float(np.mean(health > 0)) if health.size else 0.0}},
    )
