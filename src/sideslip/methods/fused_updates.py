"""The wheel speed's longitudinal slip under combined slip, for the fused estimator's wheel
cue (:mod:`sideslip.methods.fused_engine`; its consider update is
:mod:`sideslip.filters.consider`).

Wheel slip under combined slip: a tyre producing a lateral force ``F_y`` at tan of the slip
angle ``z`` needs for a longitudinal force ``F_x`` the slip ratio ``kappa = z F_x / F_y``
(isotropic brush model, Pacejka 2012, sec. 3.2.3: the slip vector is parallel to the force
vector, F_x / F_y = sigma_x / sigma_y), which in the linear range is ``F_x / (C_k F_z)`` and
grows with the secant compliance ``z / F_y`` as the tyre saturates.  The driving force is
not the net acceleration alone: the front axle's lateral force acts across the front wheels,
steered by ``delta``, and drags the car by ``F_yf sin(delta)``, which the driven wheels
overcome at constant speed (a limit corner of the race lap at 20 m/s: a_x about 0, the
wheel speed 0.4-1.4 % above the true speed).
"""

from __future__ import annotations

import numba

from sideslip.vehicle import G


@numba.njit(cache=True)
def wheel_slip_ratio(
    a_x: float, f_rear: float, z_rear: float, q_front: float, lr_over_lf: float, c_k: float
) -> float:
    """Longitudinal slip ratio (-) of the wheels that give the speed (module docstring).

    ``a_x`` the longitudinal acceleration (m/s^2, the reading less its offset), ``f_rear``
    the measured rear-axle lateral force per vehicle mass (m/s^2; the front's is
    ``f_rear l_r / l_f`` by the moment balance), ``z_rear`` the tan of the rear slip angle,
    ``q_front`` the tan of the front axle's velocity angle ``(v_y + l_f r) / v_x`` (the part of
    the road-wheel angle the state gives: the front slip angle is left out, so the drag is a
    lower bound), ``c_k`` the normalised longitudinal slip stiffness C_Fk / F_z.  Returns
    ``|F_x| max(1 / (g c_k), |z_rear| / |f_rear|)`` with ``|F_x| = |a_x| + |f_front q_front|``."""
    f_x = abs(a_x) + abs(f_rear * lr_over_lf * q_front)
    compliance = 1.0 / (G * c_k)
    if abs(f_rear) > 1e-3:
        compliance = max(compliance, abs(z_rear) / abs(f_rear))
    return f_x * compliance
