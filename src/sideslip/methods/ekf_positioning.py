"""GNSS / wheel-speed / steering-angle EKF on the kinematic bicycle model (seed 004).

Seed 004 (GNSS/SAS/WSS integration, DGIST 2015) dead-reckons a car with the kinematic bicycle
model (eqs 2.1-2.6, :mod:`sideslip.models.kinematic`) from the rear wheel speeds (WSS) and the
steering angle (SAS), and corrects it with loosely coupled GNSS positions in an extended Kalman
filter whose error states include the wheel-speed and steering scale factors.  Two methods:

* ``ekf_wss_sas``      wheel speeds + steering + GNSS (the paper);
* ``ekf_wss_sas_imu``  the same plus the gyro yaw rate (with a bias state) - what a gyro buys.

State vector x (14), units in brackets::

    0 e, 1 n     CG position, local ENU [m]
    2 psi        yaw of the body x axis, from East counter-clockwise, unwrapped [rad]
    3 v          longitudinal speed of the rear-axle centre = v_x at the CG [m/s], signed
    4 r          yaw rate [rad/s]
    5 s_w        mean rear wheel-speed scale factor:  v_meas = (1 + s) v_true  [-]
    6 d_w        half the right-minus-left rear scale-factor difference [-]:
                 s_RL = s_w - d_w, s_RR = s_w + d_w  (tyre radius differences; our addition)
    7 k_d        steering scale factor: delta_meas = (1 + k_d) delta + b_d  [-]
    8 b_d        steering sensor offset [rad] (our addition: the paper leaves it out)
    9 K_us       understeer gradient [rad/(m/s^2)] (our addition, prior from the vehicle file)
    10 b_r       road-induced steering offset [rad], Gauss-Markov (our addition, see below)
    11 g_e, 12 g_n  GNSS position error, first-order Gauss-Markov per axis [m]
    13 b_g       gyro bias [rad/s] (``_imu`` variant; frozen at 0 otherwise)

Process model (Euler at the table rate with the mid-step heading; eqs 2.1 and 2.4, signs
re-derived)::

    e' = v cos(psi) - lr r sin(psi),  n' = v sin(psi) + lr r cos(psi),  psi' = r
    v' = w_a,  r' = w_r  (random walks: speed and yaw rate follow the sensors below)
    s_w, d_w, k_d, b_d, K_us, b_g: slow random walks
    b_r' = -b_r / tau_road + w,  g' = -g / tau_gnss + w

Measurements, each used on the rows where its sensor has a fresh sample (a finite cell; the
contract never repeats an old sample), as sequential scalar updates::

    v_RL = (1 + s_w - d_w)(v - r T_r/2),  v_RR = (1 + s_w + d_w)(v + r T_r/2)   eqs 2.5/2.6
    0    = r - v tan(delta_c - b_r) / (L + K_us v^2)                            eq 2.2 (+)
           delta_c = (delta_meas - b_d) / (1 + k_d)
    wz   = r + b_g                                                               (_imu only)
    [gnss_e, gnss_n] = [e, n] + [g_e, g_n] + R(psi) [x_ant, y_ant]               GNSS, gated

Eqs 2.5/2.6 are the paper's *inputs* (speed and yaw rate from the mean and difference of the
rear wheels); here they are written as per-wheel measurements of the speed and yaw-rate states,
which is the same information at the wheel-speed rate but also (i) makes the scale factors and
the gyro bias observable against each other, not only against GNSS, (ii) survives a missing
wheel sample.  Speed and yaw rate carry large process noise, so the states track the sensors
within a few samples: the prediction is effectively driven by the wheel speeds and steering.

Why the additions (each found necessary on simulated drives, and each present on real cars):

* d_w: the paper's eq 2.6 divides a wheel-speed difference by the track, so a 0.5 %
  left/right tyre-radius difference is a yaw-rate error of 0.06 rad/s at 10 m/s - far more
  than any other error.  GNSS heading and the steering make it observable.
* K_us: eq 2.2 (kinematic) over-predicts the yaw rate at speed by (L + K_us v^2)/L; a fixed
  steering scale factor then absorbs an average of that and is biased by several percent.
  With turns at one speed only the product (1 + k_d)(L + K_us v^2) is observable, so the
  vehicle file's K_us is the prior (1-sigma 30 %; 0.0025 +- 0.0015 when the file cannot give
  it).  With K_us = 0 and b_r = 0 the model is the paper's eq 2.2.
* b_r: to drive straight on a road banked or crowned by sin(phi) a driver holds
  delta = K_us g sin(phi) (steady single-track balance) with no yaw rate.  Eq 2.2 reads that
  as a yaw rate (0.005 rad/s at 17 m/s on a 2 deg bank, 8 deg of heading in 30 s).  b_r is a
  Gauss-Markov state with 1-sigma K_us g 0.025 (2.5 % crown) and a 30 s correlation time.

Sideslip output: eq 2.3, beta = atan(lr tan(delta_c) / L) with the corrected steering angle
(atan, not atan2, so reversing keeps the same value: v_y / v_x = lr tan(delta)/L for both
signs of v).  ``beta_std`` combines the steering-calibration covariance (times the windowed-NIS
inflation) with the kinematic model's own error, the rear-axle slip angle ~ k_slip |a_y|
(k_slip = m lf / (L cr), the vehicle's slip gain when the file gives it, else 0.005 s^2/m;
a_y ~ v r; at least its RMS over the last 2 s, as transients shift its phase; times
1 + 2 health, since where the NIS test calls the model unusable the tyres may be sliding,
at up to three times the linear slip), and the road
bank's share, (k_slip + lr/L K_us) g sin(bank) (the car crabs on a bank while the driver holds
the steering that eq 2.3 reads as sideslip), the bank from the accelerometer's gravity cue
(:func:`sideslip.signals.gravity_lateral_sin`) when the drive has ``ay``, else
``EkfTuning.road_bank_sigma``.

Model error stated as noise (sensor-grade numbers, not fitted to any drive): eq 2.2 keeps a
floor of 0.02 rad/s plus 5 % of its value (yaw lag behind the steering, nonlinear tyres);
eq 2.4 assumes no rear-axle slip, so the lateral-velocity error v alpha_r ~ v k_slip |a_y| is
process noise on the lateral position with a 2 s correlation time.  The GNSS error is 90 %
Gauss-Markov (tau 60 s) and 45 % white of the receiver's ``gnss_pos_std`` (1.5 m when the
drive has none): standalone code positions drift, and treating them as white would make the
filter over-confident in its heading.

Models as plain functions with tested Jacobians: :mod:`sideslip.models.kinematic_ekf`; Kalman
steps: :mod:`sideslip.filters.kalman` (sparse-F predict, Joseph-form scalar updates); GNSS
samples, sigma defaults and the Gauss-Markov discretisation: :mod:`sideslip.gnss`; initial
alignment: :mod:`sideslip.methods.ekf_alignment`.  Settings: :class:`EkfTuning`.  Honest
uncertainty: the windowed NIS of the steering, gyro and GNSS updates
(:func:`sideslip.filters.consistency.nis_consistency`) inflates the reported 1-sigmas where the
model stops fitting and gives the ``health`` series.

Paper equations re-derived (see :mod:`sideslip.models.kinematic`): eq 2.6 sign
(r = (v_RR - v_RL)/T_r, ISO), eq 2.4 sign (v_y = +lr r), eq 2.1 (rotation by psi, not
psi + beta).  The paper's 50 Hz / 1 Hz rates are whatever the drive has.

Initial alignment (offline): the first >= 30 m of dead reckoning (eq 2.5 and the steering yaw
rate, eq 2.2; unknown heading 0) is fitted to the GNSS fixes of that stretch by a 2-D rotation and
translation (Kabsch); this gives the yaw and position at the first row, and the filter runs
causally from there.  A drive that never travels 30 m keeps yaw 0 with a 1-sigma of pi.

Robustness: standstill (wheels read 0; v -> 0, r -> 0; the gyro bias is observed there),
reversing (signed wheel speeds drive v < 0; a drive whose wheel speeds are never negative is
taken to report magnitudes: each stretch of motion between standstills starts forward, and once
the wheels have counted ``direction_distance`` and a GNSS fix agrees with that distance, a
displacement against the heading at the start of the stretch flips it to reverse, mirroring
the speed, yaw rate, heading change and position change dead-reckoned so far and widening
their covariance), GNSS outages
(dead reckoning, covariance grows), multipath (fixes whose 2-dof innovation NIS exceeds the
99.9 % chi-square bound are rejected; after ``max_rejects`` rejections in a row the next fix is
accepted after widening the position covariance, so a real jump is not refused forever), NaN
gaps in any sensor (no update; the covariance grows).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from sideslip import gnss, typical
from sideslip.drive import Drive
from sideslip.estimate import Estimate
from sideslip.filters.nis_windows import binned_nis_consistency
from sideslip.methods.ekf_alignment import initial_alignment
from sideslip.methods.ekf_filter import (
    GNSS_FORCED,
    GNSS_REJECTED,
    GNSS_USED,
    ROW_COLUMN,
    LoopConsts,
    LoopTuning,
    ekf_loop,
)
from sideslip.methods.registry import register
from sideslip.models.kinematic import rear_axle_speed
from sideslip.models.kinematic_ekf import (
    BD,
    BG,
    DW,
    GE,
    GN,
    KD,
    KU,
    NX,
    PSI,
    SW,
    E,
    N,
    R,
    V,
)
from sideslip.settings import settings_dict
from sideslip.signals import (
    causal_mean,
    gravity_lateral_sin,
    kernel_input,
    white_noise_sigma_100hz,
)
from sideslip.vehicle import G, Vehicle

FloatArray = NDArray[np.float64]

SLIP_WINDOW_S = 2.0  # s: RMS window of the slip term of beta_std
SATURATED_SLIP_EXCESS = 2.0  # the slip term's growth at health 1 (a saturated axle: 3x linear)
CHI2_2DOF_999 = 13.815510557964274  # 99.9 % quantile of chi-square with 2 degrees of freedom


@dataclass(frozen=True)
class EkfTuning:
    """Noise and initial uncertainty of the EKF (settings of ``ekf_wss_sas`` and
    ``ekf_wss_sas_imu``): 1-sigma per sample (``*_sigma*``), random walks per sqrt(s)
    (``*_walk_*``), power spectral densities (``*_psd_*``), correlation times (``*_tau_s``).

    Sensor grades of a production car and a code-phase GNSS receiver, not fitted to any drive:
    CAN wheel speeds (noise + quantisation + slip), CAN steering angle, a MEMS gyro (its bias
    prior wide enough for an uncalibrated phone), single-frequency standalone GNSS (about 1 m
    error drifting over a minute).  Seed 004 publishes no noise values, so there is no "paper"
    preset.  ``preset="auto"`` (default) takes the GNSS position sigma from the drive's
    ``gnss_pos_std`` (median) and, for the gyro variant, raises the gyro sigma to the drive's
    white noise when that is larger (:func:`sideslip.signals.white_noise_sigma_100hz`; a noisy
    phone gyro); ``"typical"`` uses the fixed values.
    """

    preset: Literal["auto", "typical"] = "auto"
    wheel_sigma_m_s: float = 0.03  # per wheel sample
    wheel_sigma_rel: float = 0.001  # extra per-sample wheel error per m/s of speed (slip), -
    wheel_zero_band_m_s: float = 0.1  # wheel sensors read 0 below about this speed
    steer_sigma_rad: float = 1.0e-3  # road-wheel angle noise incl. compliance
    steer_yaw_rate_sigma_rad_s: float = 0.02  # eq 2.2 yaw-rate error floor (yaw lag, crown)
    steer_yaw_rate_sigma_rel: float = 0.05  # eq 2.2 relative yaw-rate error (tyres, lag), -
    understeer_prior_rad_m_s2: float = 0.0025  # prior when the vehicle file cannot give it
    understeer_prior_sigma_rel: float = 0.3  # prior 1-sigma of the file's K_us, fraction
    understeer_prior_sigma_min: float = 3.0e-4  # floor of that 1-sigma, rad/(m/s^2)
    understeer_prior_sigma_default: float = 1.5e-3  # prior 1-sigma without a file K_us
    road_bank_sigma: float = 0.025  # road crown / bank (sin) behind the road steering offset
    road_tau_s: float = 30.0  # its correlation time along the drive
    understeer_walk_per_sqrt_s: float = 1.0e-6  # rad/(m/s^2)/sqrt(s)
    slip_gain_s2_m: float = 0.005  # rear slip per lateral acceleration when not derivable
    slip_tau_s: float = 2.0  # correlation time of the kinematic lateral-velocity error
    lateral_velocity_sigma_m_s: float = 0.05  # floor of that lateral-velocity error
    gyro_sigma_rad_s: float = 0.005  # per gyro sample (``typical``; ``auto`` identifies it)
    accel_psd_m2_s3: float = 4.0  # speed random walk (2 m/s^2 of unmodelled acceleration)
    yaw_accel_psd_rad2_s3: float = 0.25  # yaw-rate random walk (|r'| < 0.5 rad/s^2)
    wheel_scale_walk_per_sqrt_s: float = 1.0e-5  # scale-factor random walks
    steer_scale_walk_per_sqrt_s: float = 1.0e-5
    steer_offset_walk_rad_sqrt_s: float = 1.0e-5  # sensor offset drift (0.6 mrad per hour)
    gyro_bias_walk_rad_s_sqrt_s: float = 5.0e-5
    gnss_pos_sigma_m: float = gnss.POS_SIGMA_DEFAULT_M  # per axis, without gnss_pos_std
    gnss_gm_fraction: float = 0.9  # share of that 1-sigma that is slow (Gauss-Markov), -
    gnss_white_fraction: float = gnss.POS_WHITE_FRACTION  # share white from fix to fix, -
    gnss_tau_s: float = 60.0  # Gauss-Markov time constant of the GNSS error
    gnss_roll_sigma_rad: float = 0.05  # roll/pitch that moves a high antenna sideways
    gnss_gate_nis: float = CHI2_2DOF_999  # innovation gate on GNSS fixes (NIS, 2 dof)
    gnss_max_rejects: int = 5  # consecutive rejected fixes after which the next is forced
    direction_distance_m: float = 2.5  # GNSS travel that decides forward/reverse (unsigned)
    init_speed_sigma_m_s: float = 0.5  # initial 1-sigma of v
    init_yaw_rate_sigma_rad_s: float = 0.1
    init_wheel_scale_sigma: float = 0.02
    init_wheel_scale_diff_sigma: float = 0.01
    init_steer_scale_sigma: float = 0.1
    init_steer_offset_sigma_rad: float = 0.01
    init_gyro_bias_sigma_rad_s: float = 0.05  # 3 deg/s: uncalibrated consumer MEMS (a phone)
    consistency_window_s: float = 2.0  # windowed-NIS test of the steering/gyro/GNSS updates

    def __post_init__(self) -> None:
        if self.preset not in ("auto", "typical"):
            raise ValueError(f"EkfTuning.preset = {self.preset!r}: expected 'auto' or 'typical'")
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if f.name != "preset" and not (math.isfinite(v) and v >= 0):
                raise ValueError(f"EkfTuning.{f.name} = {v}: expected a number >= 0")
        for name in ("gnss_tau_s", "road_tau_s", "slip_tau_s"):
            if getattr(self, name) <= 0:
                raise ValueError(f"EkfTuning.{name} = {getattr(self, name)}: expected > 0 s")


def _loop_tuning(tu: EkfTuning) -> LoopTuning:
    return LoopTuning(*(float(getattr(tu, name)) for name in LoopTuning._fields))


@dataclass(frozen=True)
class EkfResult:
    """Filter output on the drive's time base (N rows).

    ``x`` (N, 7) the states of :data:`~sideslip.methods.ekf_filter.ROW_STATES` (e, n, yaw, v, r,
    K_us, gyro bias: columns 0-4 are the state indices E ... R, ``ROW_COLUMN[s]`` the column of
    state s) after the updates of each row, ``var`` (N, 7) their variances; ``x_final`` and
    ``var_final`` (14,) every state (``STATE_NAMES``) and its variance after the last row;
    ``cov_en`` (N,) the e-n covariance (for the error ellipse), ``beta`` and ``beta_var`` the
    kinematic sideslip (eq 2.3) and its variance, ``gnss_flag`` (N,) int8
    GNSS_NONE/USED/REJECTED/FORCED, ``align`` the initial-alignment summary,
    ``nis_steer``/``nis_gyro``/``nis_gnss`` the NIS of each row's steering (1 dof), gyro (1 dof)
    and GNSS (2 dof, before gating) updates, NaN where none.
    """

    x: FloatArray
    var: FloatArray
    cov_en: FloatArray
    beta: FloatArray
    beta_var: FloatArray
    gnss_flag: NDArray[np.int8]
    align: dict[str, Any]
    nis_steer: FloatArray
    nis_gyro: FloatArray
    nis_gnss: FloatArray
    x_final: FloatArray
    var_final: FloatArray


# ------------------------------------------------------------------------------------------
# driver
# ------------------------------------------------------------------------------------------
def _vehicle_model_numbers(vehicle: Vehicle, tuning: EkfTuning) -> tuple[float, float, float]:
    """Understeer gradient prior (value, 1-sigma) and rear slip gain from the vehicle file,
    or typical defaults when the file cannot give them."""
    kus = vehicle.understeer_gradient
    if math.isfinite(kus):
        kus = min(max(kus, -0.002), 0.01)
        kus_std = max(tuning.understeer_prior_sigma_rel * abs(kus), tuning.understeer_prior_sigma_min)
    else:
        kus = tuning.understeer_prior_rad_m_s2
        kus_std = tuning.understeer_prior_sigma_default
    slip = vehicle.mass * vehicle.lf / (vehicle.wheelbase * vehicle.cr)
    if not math.isfinite(slip) or slip <= 0.0:
        slip = tuning.slip_gain_s2_m
    return kus, kus_std, min(slip, 0.05)


rear_track = typical.track_rear  # the file's rear track, else its front track, else typical


def _gyro_sigma(drive: Drive, tu: EkfTuning) -> tuple[float, str]:
    """Per-sample gyro 1-sigma (rad/s) at the drive's rate and its source."""
    if tu.preset == "auto" and "wz" in drive:
        ident = white_noise_sigma_100hz(drive.t, drive["wz"])
        if ident is not None:
            # the gyro's measurement noise here also stands for its bias instability between
            # GNSS fixes: the identified white noise raises the typical value, never lowers it
            rate_factor = math.sqrt(0.01 / max(drive.dt_median, 1e-4))
            sigma = max(ident * rate_factor, tu.gyro_sigma_rad_s)
            return sigma, "drive (second differences), >= typical"
    return tu.gyro_sigma_rad_s, "typical"


def run_ekf(
    drive: Drive, vehicle: Vehicle, use_gyro: bool, tuning: EkfTuning | None = None
) -> EkfResult:
    """Run the seed-004 EKF over a drive (see module docstring); the methods wrap this."""
    tu = tuning if tuning is not None else EkfTuning()
    vehicle.need("lf", "lr")
    if not math.isfinite(vehicle.track_rear):
        vehicle = vehicle.with_changes(track_rear=rear_track(vehicle)[0])
    t = drive.t
    v_rl = gnss.column(drive, "v_rl")
    v_rr = gnss.column(drive, "v_rr")
    steer = gnss.column(drive, "steer")
    wz = gnss.column(drive, "wz") if use_gyro else np.full(t.size, np.nan)
    ge = gnss.column(drive, "gnss_e")
    gn = gnss.column(drive, "gnss_n")
    gstd = gnss.column(drive, "gnss_pos_std")
    pos = gnss.position_samples(drive)
    fixes = np.isfinite(ge) & np.isfinite(gn)
    std_ok = np.isfinite(gstd) & (gstd > 0) & fixes
    sigma_gnss = pos.median_sigma() if std_ok.any() else tu.gnss_pos_sigma_m
    if use_gyro:
        tu = dataclasses.replace(tu, gyro_sigma_rad_s=_gyro_sigma(drive, tu)[0])

    align = initial_alignment(t, v_rl, v_rr, steer, ge, gn, vehicle)
    kus, kus_std, slip = _vehicle_model_numbers(vehicle, tu)
    ant = vehicle.gnss_xyz
    consts = LoopConsts(
        lr=float(vehicle.lr),
        wheelbase=float(vehicle.wheelbase),
        track_rear=float(vehicle.track_rear),
        ant_x=float(ant[0]),
        ant_y=float(ant[1]),
        ant_z=float(ant[2]),
        slip_gain=float(slip),
        road_std=float(max(abs(kus), tu.understeer_prior_rad_m_s2) * G * tu.road_bank_sigma),
        wheels_unsigned=bool(
            not (np.nan_to_num(v_rl) < 0.0).any() and not (np.nan_to_num(v_rr) < 0.0).any()
        ),
        gnss_white_default=float(tu.gnss_white_fraction * sigma_gnss),
        gnss_gm_std=float(tu.gnss_gm_fraction * sigma_gnss),
        use_gyro=bool(use_gyro and np.isfinite(wz).any()),
        tuning=_loop_tuning(tu),
    )
    ws = rear_axle_speed(v_rl, v_rr)
    ws_ok = np.isfinite(ws)
    x0 = np.zeros(NX)
    x0[E], x0[N], x0[PSI] = align["e0"], align["n0"], align["yaw0"]
    x0[V] = float(ws[ws_ok][0]) if ws_ok.any() else 0.0
    x0[KU] = kus
    pos_var = sigma_gnss**2 if fixes.any() else 1.0e6
    P0 = np.diag(
        [
            pos_var,
            pos_var,
            align["yaw0_std"] ** 2,
            tu.init_speed_sigma_m_s**2,
            tu.init_yaw_rate_sigma_rad_s**2,
            tu.init_wheel_scale_sigma**2,
            tu.init_wheel_scale_diff_sigma**2,
            tu.init_steer_scale_sigma**2,
            tu.init_steer_offset_sigma_rad**2,
            kus_std**2,
            consts.road_std**2,
            consts.gnss_gm_std**2,
            consts.gnss_gm_std**2,
            tu.init_gyro_bias_sigma_rad_s**2 if consts.use_gyro else 0.0,
        ]
    )
    # the GNSS error and the position start fully correlated (position came from GNSS)
    P0[E, GE] = P0[GE, E] = -0.9 * consts.gnss_gm_std**2 if fixes.any() else 0.0
    P0[N, GN] = P0[GN, N] = P0[E, GE]
    out = ekf_loop(
        kernel_input(t), kernel_input(v_rl), kernel_input(v_rr), kernel_input(steer),
        kernel_input(wz), kernel_input(ge), kernel_input(gn), kernel_input(gstd), x0, P0, consts,
    )  # fmt: skip
    return EkfResult(*out[:6], align, *out[6:])


def _estimate(
    name: str, res: EkfResult, drive: Drive, vehicle: Vehicle, use_gyro: bool, tu: EkfTuning
) -> Estimate:
    x, var = res.x, res.var
    t = drive.t
    # the gyro's identified noise, for params: first, while few per-row arrays exist (memory)
    g_sigma, g_source = _gyro_sigma(drive, tu) if use_gyro else (math.nan, "")
    sd = np.sqrt(np.maximum(var, 0.0, out=var), out=var)  # in place: res is this call's own
    x_last, sd_last = res.x_final, np.sqrt(np.maximum(res.var_final, 0.0))
    bg = ROW_COLUMN[BG]
    inflation = np.ones(t.size)
    health = np.zeros(t.size)
    health_params: dict[str, Any] = {"criterion": "off"}
    nis_sum = np.nan_to_num(res.nis_steer) + np.nan_to_num(res.nis_gyro) + np.nan_to_num(res.nis_gnss)
    dof = (np.isfinite(res.nis_steer).astype(float) + np.isfinite(res.nis_gyro)
           + 2.0 * np.isfinite(res.nis_gnss))  # fmt: skip
    if tu.consistency_window_s > 0:
        cons = binned_nis_consistency(t, nis_sum, dof, tu.consistency_window_s)
        inflation, health, health_params = cons.inflation, cons.health, cons.summary(t)
        del cons  # memory: its other per-row series are not needed
    del nis_sum, dof
    k = np.sqrt(inflation)
    # road bank: the car crabs by k_slip g sin(bank) on a bank while the driver holds
    # delta = K_us g sin(bank) (read by eq 2.3 as lr/L delta of sideslip); the bank from the
    # accelerometer when the drive has ay, else the typical road bank of the tuning
    cue = gravity_lateral_sin(drive, x[:, V], x[:, R])
    sin_bank = np.full(t.size, tu.road_bank_sigma) if cue is None else np.hypot(0.01, cue)
    _, _, slip_gain = _vehicle_model_numbers(vehicle, tu)
    lr_l = vehicle.lr / vehicle.wheelbase
    bank_beta = (slip_gain + lr_l * np.abs(x[:, ROW_COLUMN[KU]])) * G * sin_bank
    # the kinematic model's own error, the rear-axle slip angle ~ k_slip |a_y| (a_y ~ v r),
    # at least its RMS over the last SLIP_WINDOW_S (transients shift its phase)
    ay = x[:, V] * x[:, R]
    slip = slip_gain * np.maximum(np.abs(ay), np.sqrt(causal_mean(t, ay**2, SLIP_WINDOW_S)))
    # where the consistency test calls the model unusable (health 1: tyres at the limit) the
    # rear slip may be up to three times the linear one: the brush model slides at
    # 3 mu F_z / C, the linear model reaches mu F_z at mu F_z / C (Pacejka 2012, sec. 3.2).
    # cr_limit_slalom / cr_limit_ramp: 72 / 75 % of the beta errors inside 2 sigma -> 100 %
    # (ekf_wss_sas_imu on the ramp 70 -> 96 %); race_lap mean beta_std 1.22 -> 2.44 deg at
    # beta RMSE 2.29
    slip *= 1.0 + SATURATED_SLIP_EXCESS * health
    beta_std = np.sqrt(np.maximum(res.beta_var, 0.0) * inflation + slip**2 + bank_beta**2)
    del cue, sin_bank, bank_beta, ay, slip, inflation  # memory: per-row terms used above only
    series = {
        "e": x[:, E],
        "n": x[:, N],
        "yaw": x[:, PSI],
        "beta": res.beta,
        "r": x[:, R],
        "vx": x[:, V],
        "vy": vehicle.lr * x[:, R],
        "e_std": sd[:, E] * k,
        "n_std": sd[:, N] * k,
        "yaw_std": sd[:, PSI] * k,
        "beta_std": beta_std,
        "vx_std": sd[:, V],
        "r_std": sd[:, R] * k,
        "health": health,
    }
    if use_gyro:
        series["gyro_bias"] = x[:, bg]
        series["gyro_bias_std"] = sd[:, bg]
    params: dict[str, Any] = {
        "wheel_speed_scale": float(1.0 + x_last[SW]),
        "wheel_speed_scale_sigma": float(sd_last[SW]),
        "wheel_speed_scale_rl": float(1.0 + x_last[SW] - x_last[DW]),
        "wheel_speed_scale_rr": float(1.0 + x_last[SW] + x_last[DW]),
        "wheel_speed_scale_half_diff": float(x_last[DW]),
        "wheel_speed_scale_half_diff_sigma": float(sd_last[DW]),
        "steer_scale": float(1.0 + x_last[KD]),
        "steer_scale_sigma": float(sd_last[KD]),
        "steer_offset_rad": float(x_last[BD]),
        "steer_offset_rad_sigma": float(sd_last[BD]),
        "understeer_gradient_rad_m_s2": float(x_last[KU]),
        "understeer_gradient_rad_m_s2_sigma": float(sd_last[KU]),
        "scale_convention": "scale = measured / true (1.0 = perfect); offset in the sensor's unit",
        "gnss_fixes_used": int(np.sum(res.gnss_flag == GNSS_USED)),
        "gnss_fixes_rejected": int(np.sum(res.gnss_flag == GNSS_REJECTED)),
        "gnss_fixes_forced": int(np.sum(res.gnss_flag == GNSS_FORCED)),
        "alignment": {k: v for k, v in res.align.items()},
        "track_rear_m": rear_track(vehicle)[0],
        "track_rear_source": rear_track(vehicle)[1],
        "health": health_params,
        "settings": settings_dict(tu),
    }
    if use_gyro:
        params["gyro_bias_rad_s"] = float(x_last[BG])
        params["gyro_bias_rad_s_sigma"] = float(sd_last[BG])
        params["noise"] = {"gyro_sigma_rad_s": g_sigma, "gyro_sigma_source": g_source,
                           "criterion": "gyro white noise from second differences of wz"}  # fmt: skip
    innovations = {"steer_nis": res.nis_steer, "gyro_nis": res.nis_gyro, "gnss_nis": res.nis_gnss}
    return Estimate(name, t, series, params, innovations)


_COLUMNS = ("v_rl", "v_rr", "steer", "gnss_e", "gnss_n")
_VEHICLE = ("lf", "lr")  # the rear track: see rear_track()


@register(
    "ekf_wss_sas",
    columns=_COLUMNS,
    vehicle_params=_VEHICLE,
    summary="EKF on the kinematic bicycle: rear wheel speeds + steering + GNSS (positions, "
    "scale factors)",
    paper="seed 004",
    settings=EkfTuning,
    accelerometer="cg_causal",
)
def ekf_wss_sas(drive: Drive, vehicle: Vehicle, settings: EkfTuning | None = None) -> Estimate:
    """Seed 004's GNSS/WSS/SAS EKF (see module docstring); optional column gnss_pos_std."""
    tu = settings if settings is not None else EkfTuning()
    return _estimate("ekf_wss_sas", run_ekf(drive, vehicle, False, tu), drive, vehicle, False, tu)


@register(
    "ekf_wss_sas_imu",
    columns=(*_COLUMNS, "wz"),
    vehicle_params=_VEHICLE,
    summary="seed 004's EKF plus the gyro yaw rate with a bias state",
    paper="seed 004 (+ gyro)",
    settings=EkfTuning,
    accelerometer="cg_causal",
)
def ekf_wss_sas_imu(drive: Drive, vehicle: Vehicle, settings: EkfTuning | None = None) -> Estimate:
    """Seed 004's EKF with the gyro as a yaw-rate measurement (``wz = r + b_g``)."""
    tu = settings if settings is not None else EkfTuning()
    return _estimate("ekf_wss_sas_imu", run_ekf(drive, vehicle, True, tu), drive, vehicle, True, tu)
