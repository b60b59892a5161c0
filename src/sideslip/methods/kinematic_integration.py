"""Baseline: direct integration of the kinematic sideslip relation (seed 003, kinematic model).

    beta' = a_y / v_x - r                      (seed 003, from v_y' = a_y - r v_x, beta ~ v_y/v_x)

with the measured lateral specific force ``ay`` taken as a_y (no gravity compensation) and the
gyro ``wz`` as r.  Open-loop: any accelerometer bias, gravity through roll/bank, or gyro bias
integrates into a drift.  It is the honest floor every other method must beat.

Low speed: below ``V_GATE`` the relation is singular; beta is held at zero there (the vehicle
restarts from rest with zero sideslip), which also handles standstill and reversing.
"""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import NDArray

from sideslip.drive import Drive
from sideslip.estimate import Estimate
from sideslip.methods.registry import SPEED, register
from sideslip.signals import hold, vehicle_speed
from sideslip.vehicle import Vehicle

V_GATE = 3.0  # m/s: below this, beta is reset to zero


@numba.njit(cache=True)
def _integrate(t: NDArray, ay: NDArray, r: NDArray, vx: NDArray, v_gate: float) -> NDArray:
    beta = np.zeros(t.size)
    for k in range(1, t.size):
        dt = t[k] - t[k - 1]
        v = vx[k - 1]
        if v < v_gate:
            beta[k] = 0.0
        else:
            b = beta[k - 1] + dt * (ay[k - 1] / v - r[k - 1])
            beta[k] = min(max(b, -1.5), 1.5)
    return beta


@register(
    "kinematic_integration",
    columns=("wz", "ay", SPEED),
    summary="open-loop integration of beta' = a_y/v_x - r (drifts; the baseline)",
    paper="seed 003 (kinematic model)",
)
def kinematic_integration(drive: Drive, vehicle: Vehicle) -> Estimate:
    """Sideslip by integrating beta' = a_y/v_x - r from zero; see module docstring."""
    ay, _ = hold(drive["ay"], drive.t)
    r, _ = hold(drive["wz"], drive.t)
    vx = vehicle_speed(drive)
    beta = _integrate(drive.t, ay, r, vx, V_GATE)
    return Estimate(
        "kinematic_integration",
        drive.t,
        {"beta": beta, "r": r},
        {"v_gate_mps": V_GATE, "gravity_compensation": False},
    )
