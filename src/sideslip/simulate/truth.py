"""The truth trajectory: what the nonlinear vehicle model produces and the sensor models read.

Frames and signs follow the package conventions (``sideslip.__doc__``).  "Heading frame" is the
ISO 8855 intermediate system: x along the body heading projected on the horizontal plane,
z up.  All arrays have shape (N,) unless said, on the simulation time base ``t``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Truth:
    """Truth states of the simulated vehicle.

    t            time, s
    e, n, u      CG position, local ENU, m
    yaw          heading of the body x axis, rad, from East counter-clockwise (unwrapped)
    pitch        body pitch relative to the horizontal, rad, ISO (positive nose down)
    roll         body roll relative to the horizontal, rad, ISO (right side down positive);
                 = bank + roll_sus
    roll_sus     suspension roll of the sprung mass relative to the road, rad (seed 003 eq 41)
    bank         road bank angle under the vehicle, rad, roll sign (right edge lower positive)
    grade        road grade, rad, positive uphill in the direction of travel
    vx, vy       CG velocity in the heading frame, m/s (beta = atan2(vy, vx))
    r            yaw rate d(yaw)/dt, rad/s
    ax, ay       gravity-free CG acceleration in the heading frame, m/s^2
                 (ax = dvx/dt - r vy, ay = dvy/dt + r vx)
    acc_enu      (N, 3) CG acceleration in ENU, m/s^2 (gravity-free)
    omega_body   (N, 3) angular rate of the sprung mass in body axes [wx, wy, wz], rad/s
    wheel_speed  (N, 4) linear tyre speed omega_i * R_eff of [FL, FR, RL, RR], m/s,
                 signed (negative when rolling backwards); includes longitudinal tyre slip
    steer        front road-wheel angle, rad, left positive
    mu           road friction coefficient under the vehicle
    """

    t: FloatArray
    e: FloatArray
    n: FloatArray
    u: FloatArray
    yaw: FloatArray
    pitch: FloatArray
    roll: FloatArray
    roll_sus: FloatArray
    bank: FloatArray
    grade: FloatArray
    vx: FloatArray
    vy: FloatArray
    r: FloatArray
    ax: FloatArray
    ay: FloatArray
    acc_enu: FloatArray
    omega_body: FloatArray
    wheel_speed: FloatArray
    steer: FloatArray
    mu: FloatArray

    @property
    def beta(self) -> FloatArray:
        """Sideslip at the CG, rad: atan2(vy, vx)."""
        return np.arctan2(self.vy, self.vx)
