"""Named parameters of the truth model (:mod:`sideslip.simulate.vehicle_model`).

The compiled model reads its constants from one :class:`ModelParams` — a ``NamedTuple`` of
floats, which numba passes by value and reads by field name (``P.mass``) at the cost of an
indexed load: no positional slots to keep in step.  :func:`model_params` is the one place that
fills it from a vehicle file, the model options and the driver's plan.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import NamedTuple

from sideslip.simulate.driver import PathPlan, Plan
from sideslip.simulate.tyre import TyreShape
from sideslip.vehicle import G, Vehicle


@dataclass(frozen=True)
class ModelOptions:
    """Truth-model settings that a vehicle file does not carry.

    front_roll_share   share of the roll stiffness (and damping) on the front axle
    drive_front        share of the drive force on the front axle (0: RWD, 1: FWD)
    brake_front        share of the brake force on the front axle
    power_per_mass     engine power per vehicle mass, W/kg
    brake_max          deceleration limit of the brakes, m/s^2 (tyres limit further)
    cda                drag area C_d A, m^2;  crr  rolling-resistance coefficient
    v_min              slip-angle regularisation speed, m/s
    tau_load           time constant of the load-transfer specific forces, s
    pitch_gain         suspension pitch per longitudinal specific force, rad/(m/s^2)
    tau_pitch          its time constant, s
    tyre               Magic Formula shape factors
    relaxation_m       tyre relaxation length, m: each tyre's lateral force follows its slip
                       angle through a first-order lag over this much travel (0: at once)
    """

    front_roll_share: float = 0.55
    drive_front: float = 1.0
    brake_front: float = 0.65
    power_per_mass: float = 100.0
    brake_max: float = 9.0
    cda: float = 0.7
    crr: float = 0.012
    v_min: float = 0.5
    tau_load: float = 0.05
    pitch_gain: float = math.radians(1.5) / G
    tau_pitch: float = 0.12
    tyre: TyreShape = field(default_factory=TyreShape)
    relaxation_m: float = 0.0


class ModelParams(NamedTuple):
    """Every constant the compiled truth model reads (SI units; all floats for numba)."""

    # vehicle file
    mass: float  # kg
    yaw_inertia: float  # kg m^2
    lf: float  # CG to front axle, m
    lr: float  # CG to rear axle, m
    track_front: float  # m
    track_rear: float  # m
    cg_height: float  # m
    roll_axis_height: float  # m (roll centre height at the CG)
    roll_stiffness: float  # N m/rad
    roll_damping: float  # N m s/rad
    roll_inertia: float  # kg m^2
    cornering_stiffness_tyre_front: float  # N/rad per tyre (half the axle's cf)
    cornering_stiffness_tyre_rear: float  # N/rad per tyre (half the axle's cr)
    understeer_gradient: float  # rad/(m/s^2), the driver's feed-forward
    # model options
    front_roll_share: float
    drive_front: float
    brake_front: float
    power_w: float  # engine power, W
    brake_max: float  # m/s^2
    cda: float  # m^2
    crr: float
    v_min: float  # m/s
    tau_load: float  # s
    pitch_gain: float  # rad/(m/s^2)
    tau_pitch: float  # s
    relaxation_m: float  # tyre relaxation length, m (0: the force follows the slip at once)
    # Magic Formula shape (sideslip.simulate.tyre)
    tyre_c_y: float
    tyre_e_y: float
    tyre_load_exponent: float
    tyre_mu_load: float
    tyre_c_x: float
    tyre_slip_stiffness: float
    # driver (sideslip.simulate.driver)
    preview_s: float  # curvature preview time, s
    lateral_gain_offset: float  # 1/s^2 on the lateral offset (omega^2)
    lateral_gain_rate: float  # 1/s on its rate (2 zeta omega)
    lateral_ki: float  # 1/s^3 on its integral
    yaw_rate_gain: float  # rad steer per rad/s yaw-rate error
    speed_kp: float  # 1/s
    speed_ki: float  # 1/s^2
    speed_tau: float  # s
    speed_preview_s: float  # s
    steer_rate_max: float  # road-wheel steer rate limit, rad/s
    steer_tau: float  # s
    steer_limit: float  # road-wheel steer limit, rad
    stop_decel: float  # m/s^2
    a_acc: float  # speed-command acceleration limit, m/s^2
    a_dec: float  # speed-command deceleration limit, m/s^2
    open_loop: float  # 0.0: path following (PathPlan), 1.0: open-loop tables (OpenLoopPlan)
    road_length: float  # m


def model_params(vehicle: Vehicle, plan: Plan, options: ModelOptions, length: float) -> ModelParams:
    """The model's constants for ``vehicle`` driving ``plan`` with ``options`` on a road of
    ``length`` m (the vehicle's per-axle cornering stiffness is split over its two tyres)."""
    gains = plan.gains
    tyre = options.tyre
    kus = vehicle.understeer_gradient
    return ModelParams(
        mass=float(vehicle.mass),
        yaw_inertia=float(vehicle.yaw_inertia),
        lf=float(vehicle.lf),
        lr=float(vehicle.lr),
        track_front=float(vehicle.track_front),
        track_rear=float(vehicle.track_rear),
        cg_height=float(vehicle.cg_height),
        roll_axis_height=float(vehicle.roll_axis_height),
        roll_stiffness=float(vehicle.roll_stiffness),
        roll_damping=float(vehicle.roll_damping),
        roll_inertia=float(vehicle.roll_inertia),
        cornering_stiffness_tyre_front=0.5 * vehicle.cf,
        cornering_stiffness_tyre_rear=0.5 * vehicle.cr,
        understeer_gradient=float(kus if math.isfinite(kus) else vehicle.understeer_gradient_tyres),
        front_roll_share=float(options.front_roll_share),
        drive_front=float(options.drive_front),
        brake_front=float(options.brake_front),
        power_w=float(options.power_per_mass * vehicle.mass),
        brake_max=float(options.brake_max),
        cda=float(options.cda),
        crr=float(options.crr),
        v_min=float(options.v_min),
        tau_load=float(options.tau_load),
        pitch_gain=float(options.pitch_gain),
        tau_pitch=float(options.tau_pitch),
        relaxation_m=float(options.relaxation_m),
        tyre_c_y=float(tyre.c_y),
        tyre_e_y=float(tyre.e_y),
        tyre_load_exponent=float(tyre.load_exponent),
        tyre_mu_load=float(tyre.mu_load),
        tyre_c_x=float(tyre.c_x),
        tyre_slip_stiffness=float(tyre.slip_stiffness),
        preview_s=float(gains.preview_s),
        lateral_gain_offset=float(gains.lateral_omega**2),
        lateral_gain_rate=float(2.0 * gains.lateral_zeta * gains.lateral_omega),
        lateral_ki=float(gains.lateral_ki),
        yaw_rate_gain=float(gains.yaw_rate_gain),
        speed_kp=float(gains.speed_kp),
        speed_ki=float(gains.speed_ki),
        speed_tau=float(gains.speed_tau),
        speed_preview_s=float(gains.speed_preview_s),
        steer_rate_max=float(math.radians(gains.handwheel_rate_deg) / vehicle.steering_ratio),
        steer_tau=float(gains.steer_tau),
        steer_limit=float(gains.steer_limit),
        stop_decel=float(gains.stop_decel),
        a_acc=float(plan.a_acc),
        a_dec=float(plan.a_dec),
        open_loop=0.0 if isinstance(plan, PathPlan) else 1.0,
        road_length=float(length),
    )


def internal_step(vehicle: Vehicle, options: ModelOptions, dt: float) -> int:
    """Number of RK4 sub-steps per output step: step <= 2.5 ms and <= 1.5 / lambda_max.

    lambda_max bounds the fastest eigenvalue, that of the tyre lateral / yaw damping at the
    regularisation speed v_min: (cf + cr) / (m v_min) and (cf lf^2 + cr lr^2) / (I_z v_min).
    """
    v = options.v_min
    lam_lat = (vehicle.cf + vehicle.cr) / (vehicle.mass * v)
    lam_yaw = (vehicle.cf * vehicle.lf**2 + vehicle.cr * vehicle.lr**2) / (vehicle.yaw_inertia * v)
    lam = max(lam_lat, lam_yaw, 1.0 / options.tau_load)
    h = min(0.0025, 1.5 / lam)
    return max(1, math.ceil(dt / h - 1e-9))
