"""Sideslip from a slip gain K identified with GNSS Doppler; slip-corrected dead reckoning.

Seed 000: Takikawa, Meguro et al., "Vehicular trajectory estimation utilizing slip angle based
on GNSS Doppler/IMU", Robomech J 8:5 (2021).  No steering angle and no tyre parameters: GNSS
Doppler velocity, the yaw gyro, the lateral accelerometer and a speed are enough.

Steps (each a module of its own):

1. Heading psi and gyro offset (``doppler_heading``): least squares of the integrated yaw rate
   (eq 3, with pitch and roll) against the Doppler course, outliers rejected.  Ours beyond the
   paper: the course samples' modelled sideslip is steady-state, so the fit carries a nuisance
   coefficient on the yaw acceleration r' (the transient rear slip I_z r' / (L c_r) of the
   single track, prior 1-sigma ``TRANSIENT_SLIP_PRIOR_S2``).  In a slalom r' moves with the
   integrated gyro, so without it the gyro scale absorbed the transient (11 % off on our low-mu
   slalom, 14 % at a CommonRoad limit slalom with 5-sigma claims); with it the scale falls
   back to its prior there and is still identified from turns with a net heading change.
2. Lateral-accelerometer error and roll (``doppler_roll``, eqs 16-19, restated in our sign).
   The scan uses a *stiff* heading fit (offset knots 600 s apart): with the 60 s knots of the
   output heading, the offset would close each curve's heading by itself and eq 19 would see
   nothing.  Heading, roll and K are iterated ``N_PASSES`` times (each uses the others' last
   values: roll in eq 3, modelled sideslip in the course).
3. Slip gain K (eqs 10-14, 20).  Steady-state linear single track, steering eliminated: the
   sideslip of the rear-axle centre is

       beta_r = -K G_y,   K = m l_f / (2 L K_r)   (K_r per tyre; = m l_f / (L c_r) per axle)

   with G_y the lateral tyre force per unit mass.  Note on checking K against a vehicle file:
   with roll (eq 14 with eq 16) G_y is the corrected accelerometer reading, which also holds
   the suspension roll's gravity part g phi_s ~ g (m h / k_phi) a_y that the tyres do not
   carry, so the K fitted is m l_f / (L c_r) / (1 + g m h / k_phi) (``K_vehicle_accel``, about
   10 % below K for the minivan); beta = -K G_y is unaffected (the same factor cancels).
   In the paper's roll sign G_y = psi' V - g sin(phi) (eq 14); in ours (ISO roll,
   a_y,m = a_y + g sin(phi)) it is ``G_y = psi' V + g sin(phi)``, which with eq 16 equals the
   corrected accelerometer reading a_y,m - b_ay.  Re-derived from the rear-axle force balance
   F_yr = m (l_f/L) G_y and F_yr = c_r alpha_r = -c_r beta_r: K > 0, beta_r < 0 in a left turn.
   GNSS gives beta_r directly (eq 20): our course nu = psi + beta, so the Doppler sideslip is
   course minus heading (the paper writes H_Doppler/IMU - H_Doppler with its own heading sign):

       beta_r,Doppler = nu - psi - (x_a + l_r) r / V + w_x z_a / V

   (antenna at (x_a, ., z_a) from the CG: the lever arm adds x_a r and -z_a w_x to the antenna's
   lateral velocity; eq 8 moves the CG sideslip to the rear axle).  K is the least-squares slope
   of beta_r,Doppler against G_y over fresh GNSS samples above ``K_MIN_SPEED`` with
   |G_y| > ``K_MIN_GY`` (curves), with an intercept (constant heading residue), iterative 3.5
   sigma outlier rejection, and a 1-sigma from the fit inflated for the samples' correlation
   (one independent sample per ``K_CORR_S``).
4. beta at the CG by eq 8: beta = beta_r + l_r r / V (l_r from the vehicle file; when it is
   missing the rear-axle sideslip is output and ``params['beta_point']`` says so).
5. Dead reckoning (``models.dead_reckoning``, eqs 1-4) with the identified heading, wheel-speed
   scale factor SF (Doppler speed over wheel speed, least squares) and pitch, started at the
   first GNSS fix (antenna lever arm removed).  ``e``/``n`` with the slip correction,
   ``e_noslip``/``n_noslip`` without it, ``roll_raw`` the roll without the delta G_y correction
   (the paper's comparisons).

Guards (failure modes of the open ROS implementation, designed out):
* K is accepted only when enough curve data span a range of G_y, its 1-sigma is below half its
  value, and it lies in (0, ``K_MAX``] s^2/m.  Otherwise the vehicle file's K = m l_f / (L c_r)
  is used when the file gives it (``K_source = "vehicle file"``, 40 % uncertainty in
  ``beta_std``), and failing that no slip correction is applied (beta_r = 0; beta = l_r r / V,
  the kinematic part; ``K_source = "none"``, ``slip_correction_applied = False``).  The reason
  is always in ``slip_correction_note``: never a silent disable.
* The yaw-rate sign is checked against the GNSS course change (InputError naming ``wz``).
* ``beta_std`` is an explicit function of the current G_y (sigma_K |G_y| with a 10 % model
  term and a 0.1 deg floor), so it cannot grow without bound after a turn; the no-roll
  variant adds K |a_y,m - psi' V| where the drive has an accelerometer (the gravity term it
  leaves out).
* Honest identified parameters (:mod:`sideslip.methods.doppler_stats`): the 1-sigmas of K,
  the wheel-speed scale and delta G_y are the larger of the t-scaled formal one and a
  jackknife over 10 s blocks (K, SF) or over curves (delta G_y, with the gyro scale's Schur
  complement); delta G_y is applied only when that 1-sigma is at most
  ``DopplerSlipSettings.dgy_max_sigma_m_s2`` (0.15 m/s^2) with enough curves, else 0 and the
  reason in ``dGy_note`` / ``ay_bias_note``.
* Self-check (:mod:`sideslip.methods.doppler_health`): the Doppler sideslip at every fresh
  epoch is the innovation of the slip model; its windowed NIS gives ``health`` and inflates
  ``beta_std`` where the model stops fitting; a first-order lag of the slip relation in
  transients (``slip_lag_s``) is identified from the same innovations and applied when it is
  significant (3 sigma), its uncertainty entering ``beta_std`` otherwise.
* Params follow the package's naming (``slip_gain_k_s2_m``, ``ay_bias_m_s2``,
  ``wheel_speed_scale``, ``gyro_scale`` as measured/true, ``gyro_bias_rad_s``, each with
  ``*_sigma``); the older keys (``K``, ``K_std``, ``dGy_*``, ``wheel_scale_factor`` = eq 4's
  SF, true/measured) stay.

Low speed: below ``V_KIN`` = 1 m/s the kinematic term uses 1 m/s; at standstill and reversing
beta is 0 (beta = atan2(v_y, v_x) jumps to +-pi backwards; we report the forward-equivalent 0).
GNSS outages: heading from the integrated gyro with the offset held (doppler_heading), K and
b_ay from the rest of the drive; with no usable GNSS at all the heading is the integrated gyro
from 0 and no slip correction is applied (said in ``params``).

Variants: ``doppler_slip`` (full), ``doppler_slip_noroll`` (roll left out everywhere: eq 3
without cos(phi), G_y = psi' V in eqs 14/20, no roll output; needs no accelerometer).

Output series (every row): ``beta`` (rad, CG), ``beta_std`` (rad), ``r`` (rad/s, gyro corrected
for offset and scale), ``yaw`` (rad, wrapped), ``e``/``n`` (m, slip-corrected dead reckoning),
``e_noslip``/``n_noslip``, ``gyro_bias`` (rad/s, measured - true); full method also ``roll``
(rad), ``roll_raw`` (rad, delta G_y = 0), ``ay_bias`` (m/s^2, measured - true = -delta G_y).
``params``: ``K``, ``K_std`` (s^2/m), ``K_intercept_rad``, ``K_samples``, ``K_vehicle``,
``K_vehicle_accel``, ``slip_correction_applied``, ``slip_correction_note`` (why not),
``wheel_scale_factor`` (eq 4's SF) and its note, ``pitch_source``, ``beta_point``,
``yaw_rate_course_correlation``, heading-fit diagnostics (``gyro_scale``, samples used and
rejected, residual), and the delta G_y scan's ``dGy_*`` (value, 1-sigma, combination rule, the
paper's mean and the median for comparison, per-curve values and weights, note).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sideslip.drive import Drive
from sideslip.estimate import Estimate
from sideslip.frames import wrap_angle
from sideslip.methods.doppler_heading import (
    HEADING_MIN_SPEED,
    HeadingFit,
    check_yaw_rate_sign,
    course_samples,
    fit_heading,
)
from sideslip.methods.doppler_health import (
    LAG_MAX_S,
    LAG_MIN_Z,
    SlipLag,
    doppler_health,
    fit_slip_lag,
)
from sideslip.methods.doppler_roll import (
    DGY_MAX_STD,
    MIN_CURVES,
    AyBiasScan,
    curve_windows,
    moving_average,
    roll_from_lateral,
    scan_ay_bias,
)
from sideslip.methods.doppler_stats import (
    block_jackknife_sums_std,
    honest_std,
    ratio_of_sums,
    time_blocks,
)
from sideslip.methods.registry import SPEED, register
from sideslip.models.dead_reckoning import dead_reckon, horizontal_speed, horizontal_yaw_rate
from sideslip.signals import hold, speed_raw, vehicle_speed
from sideslip.vehicle import G, Vehicle

FloatArray = NDArray[np.float64]

K_MAX = 0.03  # s^2/m: beyond any road car (passenger cars 0.002-0.015)
K_MIN_SPEED = 5.0  # m/s: default speed gate of the K samples (Doppler course noise sigma_v/V)
K_MIN_GY = 0.5  # m/s^2: "in curves"
K_MIN_SAMPLES = 50
K_MIN_GY_SPAN = 1.0  # m/s^2: the G_y values must span at least this much
K_CORR_S = 1.0  # s: one independent K sample per this time
K_BLOCK_S = 10.0  # s: jackknife blocks of the K samples (longer than a curve's model error)
HEADING_MAX_GY = 1.0  # m/s^2: heading fit only where the sideslip is small
SMOOTH_S = 0.5  # s: centred moving average of a_y,m and psi' V (roll, G_y)
V_KIN = 1.0  # m/s: floor of V in the kinematic term l_r r / V
BETA_FLOOR = np.radians(0.1)  # rad: floor of beta_std
SF_BOUNDS = (0.8, 1.25)
SF_MODEL_SIGMA = 1e-3  # -: longitudinal tyre slip / rolling-radius term of the SF 1-sigma
N_PASSES = 3
SCAN_KNOT_S = 600.0  # s: offset knots of the stiff heading fit behind the delta G_y scan
SCAN_BIAS_RW = 3.0e-4  # rad/s per SCAN_KNOT_S, 1-sigma
# s^2: prior 1-sigma of the heading fit's transient-slip coefficient (rad per rad/s^2); a car's
# I_z / (L C_r) ~ K l_r is 0.003-0.01 s^2 (K 0.002-0.007 s^2/m, l_r ~1.4 m), more at low mu
TRANSIENT_SLIP_PRIOR_S2 = 0.02


@dataclass(frozen=True)
class DopplerSlipSettings:
    """Tuning of ``doppler_slip`` and ``doppler_slip_noroll`` (defaults: module docstring).

    ``k_min_speed_m_s``: speed gate of the eq-20 samples (m/s); ``dgy_max_sigma_m_s2``: the
    honest 1-sigma of delta G_y (m/s^2) above which it is not applied; ``dgy_min_curves``:
    curve windows needed for delta G_y; ``slip_lag``: identify and apply the transient lag of
    the slip relation (doppler_health); ``slip_lag_min_z``: its significance, in sigma.
    """

    k_min_speed_m_s: float = K_MIN_SPEED
    dgy_max_sigma_m_s2: float = DGY_MAX_STD
    dgy_min_curves: int = MIN_CURVES
    slip_lag: bool = True
    slip_lag_min_z: float = LAG_MIN_Z

    def __post_init__(self) -> None:
        checks = (("k_min_speed_m_s", self.k_min_speed_m_s, 0.5, 50.0),
                  ("dgy_max_sigma_m_s2", self.dgy_max_sigma_m_s2, 0.0, 5.0),
                  ("dgy_min_curves", self.dgy_min_curves, 3, 1000),
                  ("slip_lag_min_z", self.slip_lag_min_z, 0.0, 100.0))  # fmt: skip
        for name, value, lo, hi in checks:
            if not (np.isfinite(value) and lo <= value <= hi):
                raise ValueError(f"DopplerSlipSettings.{name} = {value}: expected {lo:g} ... {hi:g}")


@dataclass(frozen=True)
class SlipGain:
    """Slip gain fit: K (s^2/m), its 1-sigma, intercept (rad), samples, accepted or why not."""

    k: float
    k_std: float
    intercept: float
    n_samples: int
    applied: bool
    reason: str
    residual_std: float


def fit_slip_gain(
    gy: FloatArray, beta_r: FloatArray, per_second: float, t: FloatArray | None = None
) -> SlipGain:
    """Eq 20: least-squares slope of beta_r,Doppler (rad) on G_y (m/s^2), with guards.

    ``per_second``: samples per second (for the correlation inflation of the 1-sigma).
    ``t``: the samples' times (s); when given, the 1-sigma is also the block jackknife's over
    ``K_BLOCK_S`` blocks (:mod:`sideslip.methods.doppler_stats`), whichever is larger.
    Returns ``applied = False`` with the reason when the data cannot support K.
    """
    ok = np.isfinite(gy) & np.isfinite(beta_r)
    x, y = gy[ok], beta_r[ok]
    ts = t[ok] if t is not None else None
    if x.size < K_MIN_SAMPLES:
        return SlipGain(0.0, np.inf, 0.0, int(x.size), False,
                        f"too few curve samples ({x.size} < {K_MIN_SAMPLES}): "
                        "no slip correction applied", np.inf)
    keep = np.ones(x.size, dtype=bool)
    k = c = 0.0
    res_std = np.inf
    for _ in range(8):
        A = np.column_stack([x[keep], np.ones(keep.sum())])
        sol = np.linalg.lstsq(A, y[keep], rcond=None)[0]
        k, c = -float(sol[0]), float(sol[1])
        res = y - (-k * x + c)
        r_keep = res[keep]
        res_std = 1.4826 * float(np.median(np.abs(r_keep - np.median(r_keep))))
        new = np.abs(res) <= 3.5 * max(res_std, 1e-5)
        if new.sum() < K_MIN_SAMPLES or np.array_equal(new, keep):
            break
        keep = new
    xs = x[keep]
    span = float(np.percentile(xs, 95) - np.percentile(xs, 5)) if xs.size else 0.0
    sxx = float(np.sum((xs - xs.mean()) ** 2))
    inflate = np.sqrt(max(per_second * K_CORR_S, 1.0))
    k_std = float(res_std / np.sqrt(sxx) * inflate) if sxx > 0 else np.inf
    n = int(keep.sum())
    if ts is not None and np.isfinite(k_std):
        xk, yk = x[keep], y[keep]
        labels = time_blocks(ts[keep], K_BLOCK_S)

        # centred on the kept samples' means first (the slope does not move; the sums'
        # round-off stays that of the two-pass form)
        xc, yc = xk - xk.mean(), yk - yk.mean()

        def slope(loo: FloatArray) -> FloatArray:
            n_, sx, sy, sxx_, sxy = loo
            d = sxx_ - sx * sx / n_
            return np.where(d > 0, -(sxy - sx * sy / n_) / np.where(d > 0, d, 1.0), np.nan)

        n_blocks = int(np.unique(labels).size)
        jack = block_jackknife_sums_std(
            labels, np.stack([np.ones_like(xc), xc, yc, xc * xc, xc * yc]), slope)
        k_std = honest_std(k_std, max(n_blocks - 2, 1), jack)
    reason = ""
    if span < K_MIN_GY_SPAN:
        reason = f"G_y of the curve samples spans {span:.2f} m/s^2 < {K_MIN_GY_SPAN}"
    elif not (0.0 < k <= K_MAX):
        reason = f"fitted K = {k:.4g} s^2/m outside (0, {K_MAX}]"
    elif k_std > 0.5 * k:
        reason = f"K = {k:.4g} +- {k_std:.2g} s^2/m too uncertain (1-sigma above half its value)"
    if reason:
        return SlipGain(0.0, k_std, c, n, False, reason + ": no slip correction applied", res_std)
    return SlipGain(k, k_std, c, n, True, "", res_std)


def wheel_scale_factor(
    v_gnss: FloatArray, v_wheel: FloatArray, t: FloatArray | None = None
) -> tuple[float, float, str]:
    """Eq 4's SF (true over measured): least squares of GNSS speed on wheel speed, outliers out.

    Returns (SF, its 1-sigma, note).  The 1-sigma is the larger of the formal one (t-scaled,
    one independent sample per ``K_CORR_S``) and the block jackknife's over ``K_BLOCK_S``
    blocks of the samples' times ``t`` (s; inf when ``t`` is not given and too few samples).
    """
    ok = np.isfinite(v_gnss) & np.isfinite(v_wheel) & (v_wheel > HEADING_MIN_SPEED)
    x, y = v_wheel[ok], v_gnss[ok]
    if x.size < 20:
        return 1.0, float("inf"), "too few moving GNSS samples: SF = 1"
    keep = np.ones(x.size, dtype=bool)
    sf = 1.0
    s = 1e-3
    for _ in range(6):
        sf = float(np.sum(x[keep] * y[keep]) / np.sum(x[keep] ** 2))
        res = y - sf * x
        s = 1.4826 * float(np.median(np.abs(res[keep] - np.median(res[keep]))))
        new = np.abs(res) <= 4.0 * max(s, 1e-3)
        if new.sum() < 20 or np.array_equal(new, keep):
            break
        keep = new
    sigma = float("inf")
    if t is not None:
        tk = t[ok][keep]
        xk, yk = x[keep], y[keep]
        span = max(float(tk[-1] - tk[0]), 1e-6)
        corr = max(keep.sum() / span * K_CORR_S, 1.0)
        formal = max(s, 1e-3) / float(np.sqrt(np.sum(xk**2))) * float(np.sqrt(corr))
        labels = time_blocks(tk, K_BLOCK_S)

        n_blocks = int(np.unique(labels).size)
        jack = block_jackknife_sums_std(labels, np.stack([xk * yk, xk * xk]), ratio_of_sums)
        sigma = honest_std(formal, max(n_blocks - 1, 1), jack)
        # GNSS speed and rolling speed also differ by the driven tyres' longitudinal slip and
        # the radius' growth with speed (0.1-0.3 % for road cars, Gillespie 1992 ch. 2): a
        # model term the residuals cannot show, since it moves every sample alike
        sigma = float(np.hypot(sigma, SF_MODEL_SIGMA))
    if not SF_BOUNDS[0] <= sf <= SF_BOUNDS[1]:
        return 1.0, float("inf"), f"fitted SF = {sf:.3f} implausible: SF = 1"
    return sf, sigma, ""


def _pitch(drive: Drive, speed: FloatArray, width: int) -> tuple[FloatArray, str]:
    """Pitch (rad, ISO: nose down positive) from GNSS vertical velocity, else from a_x, else 0.

    GNSS: theta = -atan2(v_u, v_h) (climbing is nose up, negative).  Accelerometer: a_x,m =
    dV/dt - g sin(theta)  ->  theta = arcsin((dV/dt - a_x,m) / g), smoothed over 1 s.
    """
    t = drive.t
    if "gnss_vu" in drive and "gnss_ve" in drive:
        vu, _ = hold(drive["gnss_vu"], t)
        ve, _ = hold(drive["gnss_ve"], t)
        vn, _ = hold(drive["gnss_vn"], t)
        vh = np.hypot(ve, vn)
        th = np.where(vh > HEADING_MIN_SPEED, -np.arctan2(vu, np.maximum(vh, 1e-3)), 0.0)
        return moving_average(th, 2 * width), "gnss_vu"
    if "ax" in drive:
        ax, _ = hold(drive["ax"], t)
        dv = np.gradient(moving_average(speed, 2 * width), t) if t.size > 1 else np.zeros_like(t)
        th = np.arcsin(np.clip((dv - moving_average(ax, 2 * width)) / G, -0.3, 0.3))
        return np.where(np.abs(speed) > 1.0, th, 0.0), "ax"
    return np.zeros_like(t), "none"


def _antenna_offset(
    r: FloatArray, wx: FloatArray, speed: FloatArray, lr: float, arm: tuple[float, float, float]
) -> FloatArray:
    """Known part of the antenna sideslip minus beta_r: ((x_a + l_r) r - z_a w_x) / V, rad."""
    v = np.maximum(np.abs(speed), V_KIN)
    return np.asarray(((arm[0] + lr) * r - arm[2] * wx) / v, dtype=float)


def run_doppler_slip(drive: Drive, vehicle: Vehicle, use_roll: bool = True,
                     settings: DopplerSlipSettings | None = None) -> Estimate:
    """The full pipeline of the module docstring; ``use_roll=False`` is the no-roll variant."""
    st = settings or DopplerSlipSettings()
    t = drive.t
    n = t.size
    dt = drive.dt_median if n > 1 else 0.01
    width = max(round(SMOOTH_S / max(dt, 1e-6)), 1)
    wz, _ = hold(drive["wz"], t)
    ay = hold(drive["ay"], t)[0] if use_roll else np.zeros(n)
    wx = hold(drive["wx"], t)[0] if "wx" in drive else np.zeros(n)
    speed = vehicle_speed(drive)
    still = np.abs(speed) < 0.1
    lr = float(vehicle.lr) if np.isfinite(vehicle.lr) else 0.0
    arm = tuple(float(a) for a in vehicle.gnss_xyz)
    arm3: tuple[float, float, float] = (arm[0], arm[1], arm[2])
    params: dict[str, Any] = {"use_roll": use_roll}
    # a_y at the accelerometer = r V + d/dt(V beta_r + (l_r + x_imu) r)  (v_y = V beta_r + l_r r
    # at the CG; beta_r from the previous pass)
    arm_ay = lr + float(vehicle.imu_xyz[0])

    # --- GNSS Doppler samples, IMU sign check, wheel-speed scale factor, pitch ----------------
    samples = course_samples(drive, speed)
    params["yaw_rate_course_correlation"] = check_yaw_rate_sign(t, wz, samples, drive.path)
    raw = speed_raw(drive)
    sf_reason = "no GNSS Doppler: SF = 1"
    sf, sf_sigma = 1.0, float("inf")
    if raw is not None and samples.rows.size:
        v_w = hold(raw, t)[0][samples.rows]
        sf, sf_sigma, sf_reason = wheel_scale_factor(samples.speed, np.abs(v_w), t[samples.rows])
    pitch, pitch_src = _pitch(drive, speed, width)
    v_h = horizontal_speed(speed, sf, pitch)
    params.update(
        wheel_scale_factor=sf, wheel_scale_factor_note=sf_reason, pitch_source=pitch_src,
        # naming convention (measured/true): the inverse of eq 4's SF
        wheel_speed_scale=1.0 / sf, wheel_speed_scale_sigma=sf_sigma / sf**2,
    )

    # --- iterate: heading -> ay bias and roll -> slip gain -> heading ...------------------------
    still_rows = np.flatnonzero(still)
    roll = np.zeros(n)
    roll_raw = np.zeros(n)
    beta_r_model = np.zeros(n)
    gain = SlipGain(0.0, np.inf, 0.0, 0, False, "not fitted", np.inf)
    scan = AyBiasScan(0.0, 0.0, 0.0, 0.0, 0.0, np.inf, [], [], 0, "joint", "roll not used")
    fit: HeadingFit | None = None
    ay_s = moving_average(ay, width)
    gy_raw = ay_s.copy()
    rows = samples.rows
    rate_gnss = rows.size / max(t[-1] - t[0], 1e-6) if rows.size else 1.0
    for _ in range(N_PASSES):
        rate_h = horizontal_yaw_rate(wz, 0.0, roll if use_roll else None, pitch)
        r_est = wz if fit is None else fit.gyro_scale * wz - fit.gyro_bias * fit.gyro_scale
        offset_rows = (_antenna_offset(r_est, wx, v_h, lr, arm3) + beta_r_model)[rows]
        gy_rows = (np.abs(r_est * v_h) if not use_roll else np.abs(gy_raw))[rows]
        select = (gy_rows < HEADING_MAX_GY) & (np.abs(r_est[rows]) < 0.1)
        # the transient slip the steady model leaves out, ~ K l_r r' (I_z r' / (L C_r)): a
        # nuisance column of the heading fit, so a slalom's swing does not set the gyro scale
        r_dot = np.gradient(moving_average(r_est, width), t)[rows] if n > 1 else np.zeros(rows.size)
        if use_roll:
            # eqs 17-19 need a gyro offset that cannot close each curve by itself: a stiff fit
            # (offset knots SCAN_KNOT_S apart), so the curves' heading closure carries the roll
            stiff = fit_heading(t, rate_h, samples, select, offset_rows, still_rows, wz, r_dot,
                                TRANSIENT_SLIP_PRIOR_S2,
                                knot_spacing_s=SCAN_KNOT_S, bias_rw=SCAN_BIAS_RW)
            r_stiff = stiff.gyro_scale * wz - stiff.gyro_bias * stiff.gyro_scale
            rate_c = horizontal_yaw_rate(r_stiff, 0.0, None, pitch)
            r_s = moving_average(r_stiff, width)
            windows = curve_windows(t, r_s, v_h, samples, offset_rows, good=stiff.good)
            transient = moving_average(
                np.gradient(r_s * arm_ay + v_h * beta_r_model, t), width
            )
            scan = scan_ay_bias(t, rate_c, ay_s, r_s * v_h + transient, windows,
                                max_std=st.dgy_max_sigma_m_s2, min_curves=st.dgy_min_curves)
            roll = roll_from_lateral(ay_s, r_s, v_h, scan.ay_bias, transient)
            roll_raw = roll_from_lateral(ay_s, r_s, v_h, 0.0, transient)
            rate_h = horizontal_yaw_rate(wz, 0.0, roll, pitch)
            del stiff, r_stiff, rate_c, transient  # memory: per-row arrays of this pass
        fit = fit_heading(t, rate_h, samples, select, offset_rows, still_rows, wz, r_dot,
                          TRANSIENT_SLIP_PRIOR_S2)
        r_corr = fit.gyro_scale * wz - fit.gyro_bias * fit.gyro_scale
        r_s = moving_average(r_corr, width)
        gy = r_s * v_h + (G * np.sin(roll) if use_roll else 0.0)
        gy_raw = gy
        # eq 20: Doppler sideslip at the rear axle against G_y, in curves above the speed gate
        beta_d = wrap_angle(samples.course - fit.yaw[rows]) - _antenna_offset(
            r_corr, wx, v_h, lr, arm3
        )[rows]
        sel = (samples.speed > st.k_min_speed_m_s) & (np.abs(gy[rows]) > K_MIN_GY) & (
            np.abs(r_s[rows]) < 1.0
        )
        gain = fit_slip_gain(gy[rows][sel], beta_d[sel], rate_gnss, t[rows][sel])
        beta_r_model = -gain.k * gy

    if fit is None:  # pragma: no cover - N_PASSES >= 1
        raise RuntimeError("heading fit did not run")
    del rate_h, r_est, gy_raw, ay_s, beta_r_model, still  # memory: the passes' per-row arrays
    r_corr = fit.gyro_scale * wz - fit.gyro_bias * fit.gyro_scale
    r_s = moving_average(r_corr, width)
    gy = r_s * v_h + (G * np.sin(roll) if use_roll else 0.0)
    forward = speed >= 0.1
    # K: identified from this drive's GNSS; else the vehicle file's m lf / (L cr) (scaled as
    # the identified K would be when G_y includes the roll term); else no correction.
    k_vehicle = vehicle.slip_gain_k
    k_vehicle_accel = k_vehicle
    if use_roll and np.isfinite(vehicle.static_roll_gain):
        k_vehicle_accel = k_vehicle / (1.0 + G * vehicle.static_roll_gain)
    if gain.applied:
        k_used, k_source = gain.k, "identified"
    elif np.isfinite(k_vehicle_accel) and 0.0 < k_vehicle_accel <= K_MAX:
        k_used, k_source = float(k_vehicle_accel), "vehicle file"
    else:
        k_used, k_source = 0.0, "none"
    beta_r = np.where(forward, -k_used * gy, 0.0)
    if np.isfinite(vehicle.lr):
        kin = np.arctan(vehicle.lr * r_s / np.maximum(v_h, V_KIN))
        beta = np.where(forward, beta_r + kin, 0.0)
        params["beta_point"] = "cg (eq 8 with the vehicle file's lr)"
    else:
        beta = beta_r
        params["beta_point"] = "rear axle (vehicle file gives no lr)"
    beta = np.clip(beta, -0.5, 0.5)
    if k_source == "identified":
        k_unc = np.hypot(gain.k_std, 0.1 * gain.k)
    elif k_source == "vehicle file":
        k_unc = 0.4 * k_used  # users' cornering stiffnesses are often 30 % off or worse
    else:
        k_unc = k_vehicle if np.isfinite(k_vehicle) else 0.01
    beta_std = np.hypot(k_unc * np.abs(gy), BETA_FLOOR)
    if not use_roll and "ay" in drive:
        # the no-roll relation leaves out g sin(roll) (bank, body roll); where the drive has an
        # accelerometer the size of what it leaves out is known: K |a_y,m - psi' V|
        ay_chk = moving_average(hold(drive["ay"], t)[0], width)
        beta_std = np.hypot(beta_std, k_used * np.abs(ay_chk - gy))
    # self-check against the Doppler sideslip (doppler_health): transient lag, inflation, health
    gate = samples.speed > st.k_min_speed_m_s
    b_dopp = wrap_angle(samples.course - fit.yaw[rows]) - _antenna_offset(
        r_corr, wx, v_h, lr, arm3
    )[rows]
    rate_term = k_used * moving_average(np.gradient(gy, t) if n > 1 else np.zeros(n), width)
    lag = fit_slip_lag(t[rows][gate], rate_term[rows][gate],
                       wrap_angle(b_dopp - beta_r[rows] - gain.intercept)[gate], st.slip_lag_min_z)
    if not st.slip_lag and lag.applied:
        lag = SlipLag(lag.tau_s, lag.tau_s_sigma, False, "slip lag switched off (settings)")
    params.update(lag.params())
    if lag.applied:
        beta_r = np.where(forward, beta_r + lag.tau_s * rate_term, 0.0)
        beta = np.clip(np.where(forward, beta + lag.tau_s * rate_term, 0.0), -0.5, 0.5)
        beta_std = np.hypot(beta_std, lag.tau_s_sigma * np.abs(rate_term))
    else:  # the unmodelled lag is an error of up to hypot(max(tau, 0), sigma_tau) K dG_y/dt
        lag_unc = min(float(np.hypot(max(lag.tau_s, 0.0), lag.tau_s_sigma)), LAG_MAX_S)
        beta_std = np.hypot(beta_std, lag_unc * np.abs(rate_term))
    check = doppler_health(
        t, rows[gate], b_dopp[gate], beta_r[rows][gate] + gain.intercept, samples.sigma[gate],
        beta_std, forward, speed <= -0.1,
        np.isfinite(drive["wz"]) & (np.isfinite(drive["ay"]) if use_roll else True),
    )
    beta_std = check.beta_std
    params["health"] = check.summary
    if gain.applied and gain.intercept != 0.0:
        # The eq-20 fit's intercept c.  The heading is fitted on the straights with the
        # relation's value there (0 at G_y = 0), so a c left on the curves is the relation's
        # own offset: a curvature of beta_r(G_y) the straight line does not follow (tyres
        # leaving their linear range), which the self-check above cannot see because the
        # innovation carries c while beta does not.  The line's error on the curves is of
        # that size (cr_limit_ramp: c = 0.46 deg, the CG beta 0.9 deg off mid-ramp against a
        # 1-sigma of 0.3, 73 % of the errors inside 2 sigma; with the term 100 %).  It fades to
        # 0 towards G_y = 0, where the straights pin the relation.  Not kept: the scatter of
        # the Doppler sideslip about the line beyond the course noise as a further term (it
        # tripled the 1-sigma on the race lap, median 0.12 -> 0.40 deg at an RMSE of 0.23).
        curve = np.minimum(np.abs(gy) / K_MIN_GY, 1.0)
        beta_std = np.hypot(beta_std, np.where(forward, abs(gain.intercept) * curve, 0.0))
        params["K_intercept_in_beta_std"] = True

    # --- dead reckoning (eqs 1-4) from the first GNSS fix ---------------------------------------
    yaw = fit.yaw
    start, e0, n0 = 0, 0.0, 0.0
    if "gnss_e" in drive and "gnss_n" in drive:
        fix = np.flatnonzero(np.isfinite(drive["gnss_e"]) & np.isfinite(drive["gnss_n"]))
        if fix.size:
            start = int(fix[0])
            c, s = np.cos(yaw[start]), np.sin(yaw[start])
            e0 = float(drive["gnss_e"][start] - (c * arm3[0] - s * arm3[1]))
            n0 = float(drive["gnss_n"][start] - (s * arm3[0] + c * arm3[1]))
    e, nn = dead_reckon(t, v_h, yaw, beta, e0, n0, start)
    e_ns, n_ns = dead_reckon(t, v_h, yaw, None, e0, n0, start)

    series = {
        "beta": beta,
        "beta_std": beta_std,
        "r": r_corr,
        "yaw": wrap_angle(yaw),
        "e": e,
        "n": nn,
        "e_noslip": e_ns,
        "n_noslip": n_ns,
        "gyro_bias": fit.gyro_bias,
        "health": check.health,
    }
    if use_roll:
        series["roll"] = roll
        series["roll_raw"] = roll_raw  # eq 16 without delta G_y: the paper's "no correction"
        series["ay_bias"] = np.full(n, scan.ay_bias)
        params.update(scan.params())
    params.update(
        K=gain.k,
        K_std=gain.k_std,
        K_intercept_rad=gain.intercept,
        K_samples=gain.n_samples,
        K_residual_std_deg=float(np.degrees(gain.residual_std)),
        K_vehicle=k_vehicle,
        K_vehicle_accel=k_vehicle_accel,
        K_used=k_used,
        K_source=k_source,
        # naming convention (identified value, its 1-sigma): K as used for beta
        slip_gain_k_s2_m=k_used,
        slip_gain_k_s2_m_sigma=float(gain.k_std if k_source == "identified" else k_unc),
        slip_correction_applied=k_source != "none",
        slip_correction_note=gain.reason
        + ("; using the vehicle file's K instead" if k_source == "vehicle file" else ""),
        **fit.params(),
    )
    for key, value in series.items():
        arr = np.asarray(value, dtype=float)
        if not np.isfinite(arr).all():  # copy only the series that need it (memory)
            arr = np.nan_to_num(arr, nan=0.0, posinf=0.0, neginf=0.0)
        series[key] = arr
    innovations = {"doppler_sideslip": check.innovation, "doppler_sideslip_nis": check.nis}
    return Estimate("doppler_slip" if use_roll else "doppler_slip_noroll", t, series, params,
                    innovations)


@register(
    "doppler_slip",
    columns=("wz", "ay", SPEED, "gnss_ve", "gnss_vn"),
    summary="slip gain K from GNSS Doppler/IMU heading, roll via the a_y error scan, "
    "slip-corrected dead reckoning (no steering, no tyre data)",
    paper="seed 000 (Takikawa et al. 2021)",
    settings=DopplerSlipSettings,
    accelerometer="own",
)
def doppler_slip(drive: Drive, vehicle: Vehicle, settings: DopplerSlipSettings | None = None
                 ) -> Estimate:
    """Seed 000's full method; see the module docstring."""
    return run_doppler_slip(drive, vehicle, use_roll=True, settings=settings)


@register(
    "doppler_slip_noroll",
    columns=("wz", SPEED, "gnss_ve", "gnss_vn"),
    summary="doppler_slip without the roll term (G_y = psi' V; eq 3 without cos(roll))",
    paper="seed 000 (Takikawa et al. 2021)",
    settings=DopplerSlipSettings,
    accelerometer="own",
)
def doppler_slip_noroll(drive: Drive, vehicle: Vehicle,
                        settings: DopplerSlipSettings | None = None) -> Estimate:
    """Seed 000 without roll (the paper's comparison); see the module docstring."""
    return run_doppler_slip(drive, vehicle, use_roll=False, settings=settings)
