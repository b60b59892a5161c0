"""Two pieces of the fused estimator's update step (:mod:`sideslip.methods.fused_engine`):
the Schmidt-Kalman update that keeps some states as consider parameters, and the wheel
speed's longitudinal slip under combined slip.

Schmidt-Kalman ("consider") update (Schmidt 1966, NASA TN D-3146; Simon 2006, *Optimal State
Estimation*, sec. 7.6): the gain of a consider state is set to zero, so the measurement does
not move it, but its uncertainty enters the innovation variance and its cross-covariances
with the other states are updated.  With the gain ``k`` altered, the covariance is the Joseph
product ``P - k (P h')' - (P h') k' + S k k'``, which holds for any gain (Simon 2006, eq 5.19).
Dropping the cross-covariances instead (adding ``h_c^2 P_cc`` to the measurement variance of
each update as if it were white) lets many updates average out an error that is in fact the
same in all of them: the filter grows overconfident in the states the relation does move.

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

import math

import numba
from numpy.typing import NDArray

from sideslip.filters.kalman import innovation_variance_nb, robust_weight_nb
from sideslip.vehicle import G


@numba.njit(cache=True)
def scalar_consider_nb(
    x: NDArray, P: NDArray, innov: float, h: NDArray, r: float, keep: NDArray, work: NDArray
) -> float:
    """In place scalar update with the gain of state i multiplied by ``keep[i]`` (0: a
    consider state, 1: estimated) and the covariance by the Joseph product (module
    docstring); returns S = h P h' + r.  All ``keep`` 1 is the ordinary Kalman update.
    ``work`` at least (2, n); a non-positive S leaves x and P unchanged."""
    n = x.size
    for i in range(n):
        work[0, i] = 0.0
    for j in range(n):
        hj = h[j]
        if hj != 0.0:
            for i in range(n):
                work[0, i] += P[j, i] * hj
    s = r
    for i in range(n):
        s += h[i] * work[0, i]
    if not s > 0.0:
        return s
    for i in range(n):
        work[1, i] = work[0, i] / s * keep[i]
        x[i] += work[1, i] * innov
    for i in range(n):
        ki, phi = work[1, i], work[0, i]
        for j in range(i, n):
            m = P[i, j] - ki * work[0, j] - phi * work[1, j] + s * ki * work[1, j]
            P[i, j] = m
            P[j, i] = m
    return s


@numba.njit(cache=True)
def robust_consider_nb(
    x: NDArray, P: NDArray, innov: float, h: NDArray, r: float, inflate_nis: float, keep: NDArray,
    work: NDArray,
) -> tuple[float, bool]:  # fmt: skip
    """Scalar consider update whose variance grows with its NIS beyond ``inflate_nis``
    (``sideslip.filters.kalman.robust_weight_nb``); returns ``(NIS, taken at full weight)``."""
    s = innovation_variance_nb(P, h, r)
    if not s > 0.0:
        return math.nan, False
    nis = innov * innov / s
    w = robust_weight_nb(nis, math.inf, inflate_nis)
    scalar_consider_nb(x, P, innov, h, r / w, keep, work)
    return nis, w >= 1.0


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
