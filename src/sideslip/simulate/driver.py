"""Driver model of the simulator: what the driver wants (plans) and how he gets it (control laws).

Two kinds of plan:

* :class:`PathPlan` -- follow the road's path.  Lateral control is a preview path follower on
  the desired path curvature (a "curvature-feedback" driver in the spirit of MacAdam's preview
  driver and the Stanley controller; Rajamani, *Vehicle Dynamics and Control*, 2nd ed., ch. 3)::

      kappa_des = kappa_path(s + V t_preview) - (k_e e_y + k_d de_y/dt + k_i int e_y) / max(V, 3)^2
      delta_cmd = atan(L kappa_des) + K_us (V^2 kappa_des + g sin(bank)) + k_r (V kappa_des - r)

  with e_y the lateral offset of the CG from the path (m, left positive) and
  ``de_y/dt = V sin(course - path heading)``; the second term is the linear steady-state
  understeer and bank feed-forward (steering needed to hold a lane on a bank: a straight road
  with bank b needs K_us g sin b, from the linear single-track model), the integral removes what
  the driver's linear picture of the car misses (saturating tyres), and the yaw-rate term is
  the driver's counter-steer that damps the yaw motion of a car near or beyond its limit.
  When the yaw rate exceeds the path's by more than 0.03 rad/s the driver lifts the throttle
  (a stability-control rule).  The speed target is a profile v(s) limited by the path
  curvature (lateral acceleration), by acceleration and deceleration limits, and by the plan's
  stops, where the vehicle comes to rest and waits.
* :class:`OpenLoopPlan` -- road-wheel steering and speed as functions of time (step steer,
  slalom), the way a test driver or a steering robot drives a manoeuvre.

Longitudinal control (both plans): the driver's speed command ``v_cmd`` follows the target with
a first-order lag and rate limits; a PI on ``v_cmd - v_x`` plus feed-forward of the command's
rate, of rolling and air resistance and of the grade gives the total force, split into drive
force (power- and traction-limited) or brake force.  Steering is rate limited (default 400
deg/s at the hand wheel).  Small driver steering noise (an Ornstein-Uhlenbeck process) is drawn
from the scenario's seed.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray
from scipy.signal import lfilter

from sideslip.simulate.road import Road

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class DriverGains:
    """Driver control gains and limits.

    preview_s           t_preview, s: how far ahead (in time) the path curvature is read
    lateral_omega       natural frequency of the lateral-error loop, rad/s
    lateral_zeta        its damping ratio
    lateral_ki          integral gain on the lateral offset, 1/s^3 (x max(V,3)^-2 curvature)
    yaw_rate_gain       k_r, steer per yaw-rate error, rad/(rad/s) (counter-steer)
    speed_kp, speed_ki  PI gains of the speed loop, 1/s and 1/s^2 (times mass: N)
    speed_tau           time constant of the speed command following the target, s
    speed_preview_s     how far ahead (in time) the speed profile is read, s
    handwheel_rate_deg  steering-rate limit at the hand wheel, deg/s
    steer_tau           steering servo time constant, s
    steer_limit         road-wheel steering limit, rad
    stop_decel          deceleration for planned stops, m/s^2
    """

    preview_s: float = 0.25
    lateral_omega: float = 1.6
    lateral_zeta: float = 0.9
    lateral_ki: float = 0.3
    yaw_rate_gain: float = 0.1
    speed_kp: float = 1.2
    speed_ki: float = 0.3
    speed_tau: float = 0.4
    speed_preview_s: float = 0.6
    handwheel_rate_deg: float = 400.0
    steer_tau: float = 0.04
    steer_limit: float = 0.6
    stop_decel: float = 1.8


@dataclass(frozen=True)
class PathPlan:
    """Follow the road path at a speed profile.

    v_profile      target speed on the road grid (shape of ``road.s``), m/s, already limited by
                   curvature and acceleration (see :func:`speed_profile`)
    stops          ((s_stop m, dwell s), ...) sorted by s: come to rest at s_stop, wait
    v0             initial speed, m/s (0: start at rest)
    a_acc, a_dec   the driver's acceleration / deceleration limits, m/s^2
    steer_noise_deg  std of the driver's steering noise at the road wheel, deg
    """

    v_profile: FloatArray
    stops: tuple[tuple[float, float], ...] = ()
    v0: float = 0.0
    a_acc: float = 2.0
    a_dec: float = 3.0
    steer_noise_deg: float = 0.03
    gains: DriverGains = field(default_factory=DriverGains)


@dataclass(frozen=True)
class OpenLoopPlan:
    """Road-wheel steering and speed as functions of time (uniform grid from t = 0).

    t              time grid, s (uniform)
    steer          road-wheel steering angle, rad, left positive (before the rate limit)
    speed          target speed, m/s (negative: reversing; 0 at rest holds the brake)
    """

    t: FloatArray
    steer: FloatArray
    speed: FloatArray
    v0: float = 0.0
    a_acc: float = 2.5
    a_dec: float = 4.0
    steer_noise_deg: float = 0.01
    gains: DriverGains = field(default_factory=DriverGains)


Plan = PathPlan | OpenLoopPlan


def speed_profile(
    road: Road,
    v_set: FloatArray | float,
    a_lat: float,
    a_acc: float,
    a_dec: float,
    v_start: float = 0.0,
    v_end: float = 0.0,
    stops: Sequence[tuple[float, float]] = (),
    curvature_window: float = 10.0,
) -> FloatArray:
    """Target speed along the road, m/s: min of ``v_set`` and sqrt(a_lat / |curvature|).

    Curvature is the maximum of |kappa| within +-``curvature_window``/2 m (the driver slows
    for the tightest part of a corner).  A backward pass limits deceleration to ``a_dec``
    before corners, stops and the road's end (speed ``v_end``); a forward pass limits
    acceleration to ``a_acc`` from ``v_start`` and from each stop.  Both passes share the
    friction with the lateral acceleration (friction ellipse: the longitudinal limit shrinks by
    sqrt(1 - (a_y / a_lat)^2)), as a quasi-steady-state lap-time simulation does.
    """
    ds = road.ds
    m = road.s.size
    v = np.broadcast_to(np.asarray(v_set, dtype=float), (m,)).copy()
    half = max(1, round(0.5 * curvature_window / ds))
    kabs = np.abs(road.curvature)
    padded = np.concatenate([np.full(half, kabs[0]), kabs, np.full(half, kabs[-1])])
    windows = np.lib.stride_tricks.sliding_window_view(padded, 2 * half + 1)
    kmax = windows.max(axis=1)
    with np.errstate(divide="ignore"):
        v = np.minimum(v, np.sqrt(a_lat / np.maximum(kmax, 1e-9)))
    v[-1] = min(v[-1], v_end)
    zero_at = [min(m - 1, round(s / ds)) for s, _ in stops]
    for i in zero_at:
        v[i] = 0.0
    # friction ellipse (g-g diagram): the longitudinal acceleration left over by the lateral
    # acceleration v^2 |kappa| at each sample
    for i in range(m - 2, -1, -1):
        use = (v[i + 1] ** 2 * kabs[i] / a_lat) ** 2
        avail = a_dec * math.sqrt(1.0 - use) if use < 1.0 else 0.0
        v[i] = min(v[i], math.sqrt(v[i + 1] ** 2 + 2.0 * max(avail, 0.05 * a_dec) * ds))
    v[0] = min(v[0], v_start) if v_start > 0 else 0.0
    for i in range(1, m):
        use = (v[i - 1] ** 2 * kabs[i] / a_lat) ** 2
        avail = a_acc * math.sqrt(1.0 - use) if use < 1.0 else 0.0
        v[i] = min(v[i], math.sqrt(v[i - 1] ** 2 + 2.0 * max(avail, 0.05 * a_acc) * ds))
    return v


def profile_time(road: Road, plan: PathPlan, lag_s: float = 1.0) -> FloatArray:
    """Approximate time (s) at which the driver reaches each road sample, for planning sensor
    events (e.g. where a GNSS outage falls).  Integrates ds / v over the profile (with a floor
    at 0.3 m/s around stops) and adds each stop's dwell; ``lag_s`` is added once the vehicle
    starts (the speed loop's delay)."""
    v = np.maximum(plan.v_profile, 0.3)
    dt = road.ds / (0.5 * (v[1:] + v[:-1]))
    t = np.concatenate([[0.0], np.cumsum(dt)])
    for s_stop, dwell in plan.stops:
        if math.isfinite(dwell):
            t[road.s >= s_stop] += dwell
    return t + lag_s


def ou_noise(rng: np.random.Generator, n: int, dt: float, std: float, tau: float) -> FloatArray:
    """Ornstein-Uhlenbeck noise of stationary ``std`` and correlation time ``tau`` (s)."""
    if std <= 0 or n == 0:
        return np.zeros(n)
    a = math.exp(-dt / tau)
    w = rng.standard_normal(n)
    w[1:] *= std * math.sqrt(1.0 - a * a)
    w[0] *= std
    return np.asarray(lfilter([1.0], [1.0, -a], w), dtype=float)
