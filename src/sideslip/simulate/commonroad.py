"""A second, independent truth: the CommonRoad multi-body vehicle model (flat road).

CommonRoad's multi-body model (``vehiclemodels.vehicle_dynamics_mb``, Althoff & Wuersching,
"CommonRoad: Vehicle Models", 2020, section 6; package ``commonroad-vehicle-models`` 3.0.2,
optional extra ``commonroad``) is a 29-state model (sprung mass with roll/pitch/heave, front
and rear unsprung masses, four wheel spins, compliant joints, Pacejka tyres) written by others:
estimators are graded here on dynamics nobody in this project wrote.

Signs (re-derived from the package source and pinned by tests/simulate/test_commonroad.py)
-------------------------------------------------------------------------------------------
The model is written in SAE axes: x forward, **y right, z down**.  Evidence in the source:
the vertical velocity obeys ``dz/dt' = g - F_susp/m`` (z down); the "left" front wheel speed
is ``(v_x + T_f/2 r) cos(delta) + ...`` and its yaw moment ``+(F_x,LF - F_x,RF) T_f/2``, i.e.
the left wheel sits at y = -T_f/2 (y right).  Its global frame (X, Y, yaw) is the same
right-handed frame seen from below.  We turn it into ISO 8855 / ENU by the 180 deg rotation
about x (a rotation, not a mirror, so left stays left)::

    e = X,  n = -Y,  u = -z            yaw = -psi,   r = -psi'
    vx = vx,  vy = -vy                 roll = phi (both: right side down positive)
    pitch = -theta (ISO nose down positive; SAE nose up positive)
    steer = -delta (ISO left positive)
    wheel FL, FR, RL, RR = CommonRoad LF, RF, LR, RR (omega * R_w)

Checked by simulation: in a steady left turn the ISO roll is positive (right side down) and
the right (outer) wheels turn faster; under braking the ISO pitch is positive (nose down).

Inputs (CommonRoad's): steering-angle velocity (limited to +-0.4 rad/s road wheel by the
package) and longitudinal acceleration (turned into drive/brake torque).  We track a wanted
road-wheel angle profile with a proportional steering-rate loop (feed-forward of the profile's
rate, gain 40 1/s) and a wanted speed profile with a PI loop (feed-forward of dv/dt).

The model switches to a kinematic model below 0.1 m/s; the adapter therefore needs a moving
vehicle (speed >= 1 m/s throughout).  Road: flat, no bank or grade.

Known behaviour of the model (not of this adapter): on a straight road it settles into a
small self-sustained lateral oscillation, about 1.7 Hz, roll +-0.26 deg, v_y +-0.025 m/s,
yaw rate +-0.0004 rad/s, with 10 ms kinks in a_y; identical with LSODA and Radau and for every
parameter set.  It is part of the truth (the sensors see it), so estimators meet it as they
would meet a real car's body motion.
"""

from __future__ import annotations

import copy
import functools
import importlib.util
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from sideslip.simulate.assemble import drive_from_truth
from sideslip.simulate.truth import Truth

if TYPE_CHECKING:
    from sideslip.drive import Drive
    from sideslip.simulate.sensors import SensorConfig

FloatArray = NDArray[np.float64]
Profile = float | Callable[[float], float]

# CommonRoad parameter-set IDs (vehiclemodels/parameters/parameters_vehicle<ID>.yaml).
# ID 4 (semi-trailer truck) is not a multi-body passenger-car set.
PARAMETER_SETS: dict[str, int] = {"ford_escort": 1, "bmw_320i": 2, "vw_vanagon": 3}
CR_G = 9.81  # gravity the CommonRoad models use, m/s^2

STEER_GAIN = 40.0  # steering-rate loop gain, 1/s
SPEED_KP = 1.5  # speed loop, (m/s^2)/(m/s)
SPEED_KI = 0.5  # speed loop, (m/s^2)/m
MIN_SPEED = 1.0  # m/s: below, CommonRoad's kinematic switch would break the truth


def available() -> bool:
    """True when the optional ``commonroad-vehicle-models`` package is installed."""
    return importlib.util.find_spec("vehiclemodels") is not None


def _require() -> None:
    if not available():
        from sideslip.errors import InputError

        raise InputError(
            "commonroad",
            "the CommonRoad scenarios need the optional extra: "
            "pip install 'sideslip[commonroad]' (commonroad-vehicle-models)",
        )


def parameters(params: str) -> Any:
    """CommonRoad's parameter object for a set name in :data:`PARAMETER_SETS`."""
    if params not in PARAMETER_SETS:
        raise ValueError(
            f"unknown CommonRoad parameter set {params!r}: expected one of "
            + ", ".join(PARAMETER_SETS)
        )
    _require()
    from vehiclemodels.vehicle_parameters import setup_vehicle_parameters

    return _cached_parameters(PARAMETER_SETS[params], setup_vehicle_parameters)


def with_friction(p: Any, mu: float) -> Any:
    """A copy of parameter object ``p`` on a road of friction coefficient ``mu``: the Magic
    Formula peak factors ``p_dy1`` (lateral) and ``p_dx1`` (longitudinal) scaled so that
    ``p_dy1 = mu``.  The cornering stiffness ``K_y = p_ky1 F_z`` does not depend on them
    (``B = K / (C D)``: CommonRoad's ``tireModel``, Pacejka 2012 eq. 4.E), so the vehicle
    file derived from the set stays right; only the grip limit moves."""
    if not (math.isfinite(mu) and mu > 0.0):
        raise ValueError(f"with_friction: mu = {mu!r}: expected a number > 0")
    out = copy.deepcopy(p)
    scale = mu / float(p.tire.p_dy1)
    out.tire.p_dy1 = float(p.tire.p_dy1) * scale
    out.tire.p_dx1 = float(p.tire.p_dx1) * scale
    return out


@functools.lru_cache(maxsize=8)
def _cached_parameters(vehicle_id: int, setup: Callable[[int], Any]) -> Any:
    return setup(vehicle_id)


def _as_function(profile: Profile) -> Callable[[float], float]:
    if callable(profile):
        return profile
    value = float(profile)
    return lambda _t: value


# ------------------------------------------------------------------------------------------
# truth
# ------------------------------------------------------------------------------------------
def commonroad_truth(
    steer: Profile,
    speed: Profile | None = None,
    duration_s: float = 10.0,
    dt: float = 0.01,
    params: str = "vw_vanagon",
    accel: Profile | None = None,
    initial_speed: float | None = None,
    yaw0: float = 0.0,
    mu: float | None = None,
) -> Truth:
    """Simulate CommonRoad's multi-body model and return the ISO/ENU :class:`Truth`.

    steer         wanted front road-wheel angle, rad, ISO (left positive): constant or f(t)
    speed         wanted CG speed v_x, m/s: constant or f(t) (PI-tracked) — or give
    accel         longitudinal acceleration input, m/s^2: constant or f(t) (open loop)
    duration_s    simulated time, s;  dt: output time step, s
    params        CommonRoad parameter set (see :data:`PARAMETER_SETS`)
    initial_speed m/s (default: speed(0)); yaw0: initial heading, rad from East
    mu            road friction coefficient (default: the set's own, p_dy1 ~ 1.05), see
                  :func:`with_friction`

    State (CommonRoad, 29): see ``vehiclemodels.init_mb``; plus the integral of the speed
    error (m) for the PI loop.  Integrated with LSODA (the tyre/suspension modes are stiff),
    rtol 1e-6, outputs at ``dt``.  Accelerations come from the model's right-hand side at
    each output sample, so ``ax = dvx/dt - r vy`` and ``ay = dvy/dt + r vx`` hold exactly.
    Raises ValueError when the vehicle would drop below 1 m/s.
    """
    from scipy.integrate import solve_ivp

    if (speed is None) == (accel is None):
        raise ValueError("commonroad_truth: give exactly one of speed= and accel=")
    p = parameters(params) if mu is None else with_friction(parameters(params), mu)
    from vehiclemodels.init_mb import init_mb
    from vehiclemodels.vehicle_dynamics_mb import vehicle_dynamics_mb

    steer_f = _as_function(steer)
    speed_f = _as_function(speed) if speed is not None else None
    accel_f = _as_function(accel) if accel is not None else None
    v0 = float(initial_speed if initial_speed is not None else (speed_f(0.0) if speed_f else 0))
    if v0 < MIN_SPEED:
        raise ValueError(f"commonroad_truth: initial speed {v0} m/s: expected >= {MIN_SPEED} m/s")
    eps = 1e-3

    def inputs(t: float, x: FloatArray) -> list[float]:
        target = -steer_f(t)  # CommonRoad steer is SAE: right positive
        rate = -(steer_f(t + eps) - steer_f(t - eps)) / (2 * eps)
        u_steer = rate + STEER_GAIN * (target - x[2])
        if speed_f is not None:
            dv = (speed_f(t + eps) - speed_f(t - eps)) / (2 * eps)
            u_acc = dv + SPEED_KP * (speed_f(t) - x[3]) + SPEED_KI * x[29]
        else:
            assert accel_f is not None
            u_acc = accel_f(t)
        return [u_steer, u_acc]

    def rhs(t: float, x: FloatArray) -> list[float]:
        f = vehicle_dynamics_mb(list(x[:29]), inputs(t, x), p)
        err = speed_f(t) - x[3] if speed_f is not None else 0.0
        return [*f, err]

    x0 = [*init_mb([0.0, 0.0, -steer_f(0.0), v0, -yaw0, 0.0, 0.0], p), 0.0]
    n = round(duration_s / dt) + 1
    t: FloatArray = np.asarray(np.arange(n) * dt, dtype=np.float64)
    sol = solve_ivp(rhs, (0.0, t[-1]), x0, method="LSODA", t_eval=t, rtol=1e-6, atol=1e-8,
                    max_step=dt)
    if sol.status != 0 or sol.y.shape[1] != n:
        raise RuntimeError(f"commonroad_truth: integration failed ({sol.message})")
    x = np.asarray(sol.y.T, dtype=float)
    if np.min(x[:, 3]) < MIN_SPEED:
        raise ValueError(
            f"commonroad_truth: speed fell to {np.min(x[:, 3]):.2f} m/s: expected >= "
            f"{MIN_SPEED} m/s (the model switches to kinematics near standstill)"
        )
    f = np.array([vehicle_dynamics_mb(list(x[i, :29]), inputs(t[i], x[i]), p) for i in range(n)])
    return _to_iso(t, x, f, p)


def _to_iso(t: FloatArray, x: FloatArray, f: FloatArray, p: Any) -> Truth:
    """Map CommonRoad (SAE) states and derivatives to the ISO/ENU :class:`Truth`."""
    yaw, r = -x[:, 4], -x[:, 5]
    roll, roll_rate = x[:, 6], x[:, 7]
    pitch, pitch_rate = -x[:, 8], -x[:, 9]
    vx, vy = x[:, 3], -x[:, 10]
    ax = f[:, 3] - x[:, 5] * x[:, 10]  # dvx/dt - r vy (sign-invariant)
    ay = -(f[:, 10] + x[:, 5] * x[:, 3])  # ISO: dvy/dt + r vx
    c, s = np.cos(yaw), np.sin(yaw)
    acc_enu = np.column_stack([c * ax - s * ay, s * ax + c * ay, -f[:, 12]])
    # Body rates of the sprung mass from Euler rates, R = rot_z(yaw) rot_y(pitch) rot_x(roll).
    cr, sr, cp, sp = np.cos(roll), np.sin(roll), np.cos(pitch), np.sin(pitch)
    omega = np.column_stack([
        roll_rate - r * sp,
        pitch_rate * cr + r * sr * cp,
        r * cr * cp - pitch_rate * sr,
    ])
    zeros = np.zeros_like(t)
    return Truth(
        t=t, e=x[:, 0].copy(), n=-x[:, 1], u=-x[:, 11], yaw=yaw, pitch=pitch, roll=roll,
        roll_sus=roll.copy(), bank=zeros, grade=zeros.copy(), vx=vx.copy(), vy=vy, r=r,
        ax=ax, ay=ay, acc_enu=acc_enu, omega_body=omega,
        wheel_speed=x[:, 23:27] * p.R_w, steer=-x[:, 2],
        mu=np.full_like(t, float(p.tire.p_dy1)),
    )  # fmt: skip


# ------------------------------------------------------------------------------------------
# vehicle file
# ------------------------------------------------------------------------------------------
def vehicle_values(params: str) -> dict[str, float]:
    """This package's vehicle parameters derived from a CommonRoad parameter set.

    * ``cf``/``cr`` per axle, N/rad: CommonRoad's single-track model uses per-axle cornering
      coefficients ``C_S = -p_ky1 / p_dy1`` (1/rad, per unit axle load and friction) with
      ``F_y = mu C_S F_z alpha``, ``mu = p_dy1``, static axle loads ``F_zf = m g b / L``,
      ``F_zr = m g a / L``; hence ``cf = mu C_S m g b / L = |p_ky1| m g b / L``.  This is the
      tyres' small-slip stiffness at the static load; the multi-body model's lateral
      compliance and load transfer make the effective axle stiffness a little lower.
    * ``lf``/``lr`` = CommonRoad ``a``/``b`` (sprung-mass CG, the model's reference point).
    * ``roll_stiffness``: per axle, springs ``K_s T^2 / 2`` plus the auxiliary torsion
      stiffness ``-K_ts`` (negative in CommonRoad = stiffening), in series with the tyres'
      vertical stiffness ``K_zt T^2 / 2``; summed over both axles.
    * ``roll_damping`` = ``(K_sdf T_f^2 + K_sdr T_r^2) / 2``;  ``roll_inertia`` about the roll
      axis = ``I_Phi_s + m_s (h_s - h_ra)^2``; ``roll_axis_height`` = load-weighted mean of
      ``h_raf``/``h_rar``; ``cg_height`` = ``h_cg`` (total mass).
    """
    p = parameters(params)
    wheelbase = p.a + p.b
    mu_cs = abs(float(p.tire.p_ky1))
    cf = mu_cs * p.m * CR_G * p.b / wheelbase
    cr = mu_cs * p.m * CR_G * p.a / wheelbase

    def axle_roll(k_spring: float, k_torsion: float, track: float) -> float:
        k_susp = k_spring * track**2 / 2.0 - k_torsion
        k_tyre = p.K_zt * track**2 / 2.0
        return 1.0 / (1.0 / k_susp + 1.0 / k_tyre)

    h_ra = (p.h_raf * p.b + p.h_rar * p.a) / wheelbase
    return {
        "mass": float(p.m),
        "yaw_inertia": float(p.I_z),
        "lf": float(p.a),
        "lr": float(p.b),
        "cf": float(cf),
        "cr": float(cr),
        "track_front": float(p.T_f),
        "track_rear": float(p.T_r),
        "cg_height": float(p.h_cg),
        "roll_axis_height": float(h_ra),
        "roll_stiffness": float(axle_roll(p.K_sf, p.K_tsf, p.T_f) + axle_roll(p.K_sr, p.K_tsr, p.T_r)),
        "roll_damping": float((p.K_sdf * p.T_f**2 + p.K_sdr * p.T_r**2) / 2.0),
        "roll_inertia": float(p.I_Phi_s + p.m_s * (p.h_s - h_ra) ** 2),
        "steering_ratio": 16.0,
        "wheel_radius": float(p.R_w),
    }


GNSS_LEVER_ARM = (0.0, 0.0, 1.0)  # roof antenna above the CG, m (not in CommonRoad)


def vehicle_toml(params: str) -> str:
    """Text of the preset ``presets/commonroad_<params>.toml`` (see :func:`vehicle_values`)."""
    v = vehicle_values(params)
    lines = [
        f"# CommonRoad multi-body parameter set {PARAMETER_SETS[params]} ({params}), from",
        "# commonroad-vehicle-models 3.0.2, vehiclemodels/parameters/"
        f"parameters_vehicle{PARAMETER_SETS[params]}.yaml",
        "# (Althoff & Wuersching, 'CommonRoad: Vehicle Models', 2020).  Generated by",
        f"# sideslip.simulate.commonroad.vehicle_toml('{params}'); do not edit by hand.",
        "# mass = m, yaw_inertia = I_z, lf/lr = a/b (sprung-mass CG), tracks = T_f/T_r,",
        "# cg_height = h_cg.",
        "# Cornering stiffness per axle (N/rad): CommonRoad's per-axle cornering coefficient",
        "# C_S = -p_ky1/p_dy1 (1/rad, per unit load and friction) times mu = p_dy1 times the",
        "# static axle load: cf = |p_ky1| m g b / L, cr = |p_ky1| m g a / L (g = 9.81).",
        "# roll_stiffness: per axle K_s T^2/2 - K_ts (springs + auxiliary torsion) in series with",
        "# the tyres K_zt T^2/2, summed; roll_damping = (K_sdf T_f^2 + K_sdr T_r^2)/2;",
        "# roll_inertia = I_Phi_s + m_s (h_s - h_ra)^2 about the roll axis (h_ra from h_raf/h_rar).",
        "# steering_ratio: not in CommonRoad, a typical 16 (the drive's steer is road-wheel angle).",
        "# wheel_radius (R_w) is an extra key for information; lever arms chosen here.",
        "[vehicle]",
        f'name = "commonroad_{params}"',
    ]
    for key, value in v.items():
        lines.append(f"{key} = {value:.10g}" if key != "steering_ratio" else f"{key} = {value:.1f}")
    lines += [
        "",
        "[sensors]",
        "imu_xyz = [0.0, 0.0, 0.0]",
        "gnss_xyz = [" + ", ".join(f"{a:.1f}" for a in GNSS_LEVER_ARM) + "]",
        "",
    ]
    return "\n".join(lines)


# ------------------------------------------------------------------------------------------
# scenarios reachable from simulate()
# ------------------------------------------------------------------------------------------
def _ramp(t: float, t0: float, t1: float) -> float:
    """Smooth 0 -> 1 step between t0 and t1 (cosine), for rate-limited steering."""
    if t <= t0:
        return 0.0
    if t >= t1:
        return 1.0
    return 0.5 - 0.5 * math.cos(math.pi * (t - t0) / (t1 - t0))


def _step_steer(t: float) -> float:
    return 0.02 * _ramp(t, 2.0, 2.1)


def _slalom(t: float) -> float:
    return 0.025 * _ramp(t, 1.0, 3.0) * math.sin(2.0 * math.pi * 0.5 * (t - 1.0))


def _circle(t: float) -> float:
    return 0.05 * _ramp(t, 5.0, 7.0)


def _limit_slalom(t: float) -> float:
    """0.4 Hz slalom of 5 deg road wheel between straights: on mu 0.6 the rear axle
    saturates in every swing (BMW 320i at 60 km/h: beta to about 5.5 deg, a_y 0.95 mu g)."""
    fade = _ramp(t, 4.0, 6.0) * (1.0 - _ramp(t, 18.5, 20.0))
    return 0.088 * fade * math.sin(2.0 * math.pi * 0.4 * (t - 4.0))


def _limit_ramp(t: float) -> float:
    """Constant-speed ramp steer (ISO 4138 style, 0.3 deg/s road wheel) past the limit
    (understeer: the front axle saturates first, a_y 0.95 mu g), then back to straight."""
    up = min(max((t - 3.0) / 20.0, 0.0), 1.0)
    return 0.10 * up * (1.0 - _ramp(t, 24.0, 27.0))


# GNSS multipath bursts of the limit scenarios: one starts every 12 s on average, lasts 2 s
LIMIT_BURSTS: Mapping[str, Any] = {"gnss_burst_rate_hz": 1.0 / 12.0, "gnss_burst_s": 2.0}


@dataclass(frozen=True)
class CommonRoadScenario:
    """A CommonRoad-truth scenario: steer and speed profiles on a CommonRoad parameter set."""

    name: str
    description: str
    params: str
    duration_s: float
    steer: Callable[[float], float]
    speed: float
    sensor_overrides: Mapping[str, Any] = field(default_factory=dict)
    paper: str = "CommonRoad multi-body model (Althoff & Wuersching 2020)"
    mu: float | None = None  # road friction (default: the parameter set's own)

    @property
    def vehicle(self) -> str:
        """Preset name of the vehicle file derived from the parameter set."""
        return f"commonroad_{self.params}"


CR_SCENARIOS: dict[str, CommonRoadScenario] = {
    s.name: s
    for s in (
        CommonRoadScenario(
            "cr_step_steer",
            "CommonRoad multi-body VW Vanagon: 1.15 deg road-wheel step steer at 80 km/h, flat",
            "vw_vanagon", 10.0, _step_steer, 80.0 / 3.6,
        ),
        CommonRoadScenario(
            "cr_slalom",
            "CommonRoad multi-body VW Vanagon: 0.5 Hz slalom, 1.4 deg road wheel, 60 km/h, flat",
            "vw_vanagon", 20.0, _slalom, 60.0 / 3.6,
        ),
        CommonRoadScenario(
            "cr_circle",
            "CommonRoad multi-body VW Vanagon: constant 2.9 deg road-wheel circle at 45 km/h, "
            "flat",
            "vw_vanagon", 60.0, _circle, 45.0 / 3.6,
        ),
        CommonRoadScenario(
            "cr_limit_slalom",
            "CommonRoad multi-body BMW 320i on mu 0.6: 0.4 Hz slalom at 60 km/h with the rear "
            "axle saturating (beta to 5.5 deg), GNSS multipath bursts",
            "bmw_320i", 26.0, _limit_slalom, 60.0 / 3.6, LIMIT_BURSTS, mu=0.6,
        ),
        CommonRoadScenario(
            "cr_limit_ramp",
            "CommonRoad multi-body BMW 320i on mu 0.6: ramp steer at 60 km/h into front-axle "
            "saturation (0.95 mu g), GNSS multipath bursts",
            "bmw_320i", 30.0, _limit_ramp, 60.0 / 3.6, LIMIT_BURSTS, mu=0.6,
        ),
    )
}  # fmt: skip


@functools.lru_cache(maxsize=8)
def scenario_truth(name: str, dt: float = 0.01) -> Truth:
    """The (deterministic) CommonRoad truth of a scenario in :data:`CR_SCENARIOS`, cached."""
    s = CR_SCENARIOS[name]
    return commonroad_truth(s.steer, s.speed, s.duration_s, dt, s.params, mu=s.mu)


def commonroad_drive(
    truth: Truth,
    params: str = "vw_vanagon",
    seed: int = 0,
    config: SensorConfig | None = None,
    scenario: str = "commonroad",
) -> Drive:
    """A validated drive from a CommonRoad truth through the sensor models.

    The sensor lever arms and ``meta["vehicle"]`` come from the preset
    ``commonroad_<params>`` (see :func:`vehicle_toml`).
    """
    from sideslip.vehicle import load_vehicle

    vehicle_name = f"commonroad_{params}"
    return drive_from_truth(
        truth, load_vehicle(vehicle_name), seed=seed, config=config, scenario=scenario,
        vehicle_ref=vehicle_name, source="sideslip simulator (CommonRoad multi-body truth)",
    )  # fmt: skip
