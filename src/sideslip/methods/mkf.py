"""Seed 001: the model-based Kalman filter ``mkf`` (Bevly-style GPS/INS with a vehicle model).

State x = [beta (rad), r (rad/s), psi (rad), b_gyro (rad/s)]; input u = [delta, bank (zero:
the drive has no bank measurement)]; measurements: gyro w_z = r + b_gyro every IMU row, GNSS
course nu = psi + beta + (rx/V) r at GNSS rows (seed 001 eq 5).  Model and discretisation:
:mod:`sideslip.models.mkf_model`; Joseph-form scalar updates (eq 2,
:func:`sideslip.filters.kalman.update_scalar_nb`) in the order standstill pseudo-measurement,
gyro, course; the GNSS course from :func:`sideslip.gnss.course_at_cg`.

Noise (:class:`MkfSettings`).  ``preset="auto"`` (default) takes the gyro's white noise from the
drive itself (:func:`sideslip.signals.white_noise_sigma_100hz`, floored at a tenth of the typical
value), the course noise from the receiver's ``gnss_vel_std`` (GNSS layer), and the
process noise from the drive: factors on the typical steering/yaw-moment and sideslip densities
chosen by the likelihood of the gyro and GNSS-course innovations
(:mod:`sideslip.methods.mkf_tuning`; chosen values and scores in ``params['noise']``).
``preset="paper"`` is seed 001's published noise: the gyro 0.3 deg/s at 100 Hz of Table I, and
(the paper gives no process noise) the typical densities of
:class:`sideslip.models.mkf_model.MkfNoise`; ``"typical"`` is the same set under its older name.
Explicit fields override the preset; an explicit density is not tuned (its group keeps
factor 1).

Honest uncertainty (issue 14): the filter's own P describes the error only while the linear
single-track model holds.  Where it stops fitting (tyres past their linear range, a wrong
vehicle file, a banked road) the gyro innovations grow; their windowed NIS
(:func:`sideslip.filters.consistency.nis_consistency`) inflates the reported 1-sigma by
sqrt(inflation) and sets ``health``.  Two model errors that NIS cannot see are added in
quadrature: (i) the sideslip the model adds to the kinematic one (beta - lr/L delta, the part
that scales with 1/cornering stiffness; at least its RMS over the last 2 s) carries a relative
uncertainty ``stiffness_rel_sigma`` (vehicle files are 20-35 % off); (ii) the road bank the
flat-road model ignores, through the model's steady-state bank gain, from the accelerometer's
gravity cue when the drive has ``ay`` (:func:`bank_sigma`); (iii) the rear-axle thrust angle
(``thrust_angle_sigma_rad``): the single-track model assumes the rear wheels point along the
body axis, a thrust angle makes the car crab by it on a straight ("dog tracking"), and it is
unobservable from gyro + course (it adds to the course exactly like a heading offset).

Low speed, standstill, reversing, outages (never NaN): below ``v_gate_m_s`` or reversing the
low-speed model of :mod:`sideslip.models.mkf_model`; the course above the gate only (reversing:
course + pi); at standstill (|v| < 0.1 m/s) a pseudo-measurement r = 0 makes the gyro bias
observable (an addition to the paper, standard for cars); GNSS outages: model + gyro, beta_std
grows; NaN rows are not measurements, inputs are held.

Valid for the linear tyre range (|a_y| below ~0.4 g); beta is biased when the vehicle file is
wrong (see ``params['residuals']``) and on banked roads.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any, Literal

import numba
import numpy as np
from numpy.typing import NDArray

from sideslip import gnss
from sideslip.drive import Drive
from sideslip.estimate import Estimate
from sideslip.filters.kalman import (
    normalised_innovations,
    predict_nb,
    update_scalar_nb,
    whiteness,
)
from sideslip.filters.nis_windows import binned_nis_consistency
from sideslip.frames import wrap_angle
from sideslip.methods.mkf_tuning import choose_noise
from sideslip.methods.registry import SPEED, register
from sideslip.models.mkf_model import H_GYRO, V_GATE, MkfNoise, model_table
from sideslip.models.single_track import continuous_arrays
from sideslip.settings import settings_dict
from sideslip.signals import (
    STANDSTILL_SPEED,
    causal_mean,
    gravity_lateral_sin,
    hold,
    sample_variance,
    vehicle_speed,
    white_noise_sigma_100hz,
)
from sideslip.vehicle import Vehicle

FloatArray = NDArray[np.float64]

SIGMA_GYRO_100HZ = math.radians(0.3)  # rad/s per sample at 100 Hz (seed 001 Table I)
# Rear-axle thrust angle, 1-sigma: OEM alignment specifications accept +-0.15 deg (Chrysler,
# 2000 Dodge Stratus) to +-0.30 deg (2007 Dodge Caravan, 2009 PT Cruiser service manuals); we
# take +-0.2 deg as 2-sigma (cars in service drift within and beyond the acceptance range).
THRUST_ANGLE_SIGMA = math.radians(0.1)
SIGMA_ZERO_RATE = 1.0e-3  # rad/s: pseudo-measurement r = 0 at standstill
SIGMA_BETA0 = math.radians(2.0)
SIGMA_R0 = 0.05
SIGMA_PSI0 = math.radians(20.0)
SIGMA_BIAS0 = math.radians(1.0)
WHITENESS_LAGS = 20
# Heuristic limit of the gyro residual colour (sum of squared autocorrelations over 20 lags of
# the 100 Hz gyro innovations) above which the vehicle file is flagged: white noise gives
# ~20/n; on simulated flat-road drives in the linear range the right file stays below ~0.3,
# a file 30 % off in cornering stiffness or of another vehicle gives 0.7-17, and so do an
# unmodelled bank or tyres beyond the linear range (benchmarks/results/kalman_gps_accuracy.md).
RESIDUAL_COLOUR_MAX = 0.5
GNSS_COLUMNS = ("gnss_ve", "gnss_e")  # Doppler velocity, else differenced positions
STIFFNESS_WINDOW_S = 2.0  # s: window of the stiffness term of beta_std (a slalom half-period)


@dataclass(frozen=True)
class MkfSettings:
    """Noise and options of the MKF (``mkf``, ``mkf_adaptive``).

    preset : "auto" (gyro noise and process noise identified from the drive), "paper"
        (seed 001 Table I gyro noise, typical densities) or "typical" (= "paper"); module
        docstring.
    gyro_sigma_100hz_rad_s : rad/s, 1-sigma per gyro sample at 100 Hz (scaled by sqrt(rate /
        100 Hz) for other rates); None = from the preset.
    steer_psd_rad2_s, beta_psd_rad2_per_s, yaw_accel_psd_rad2_s3, gyro_bias_psd_rad2_s3 :
        continuous process-noise densities (:class:`sideslip.models.mkf_model.MkfNoise`);
        None = the typical value, times the identified factor with ``preset="auto"``.
    v_gate_m_s : m/s, single-track model and GNSS course above this speed only.
    stiffness_rel_sigma : relative 1-sigma of the cornering stiffness of the vehicle file
        (module docstring); 0 turns the term off.
    road_bank_sigma : sin of the unmodelled road bank, 1-sigma, for drives without ``ay``
        (public roads: crown 2-2.5 %, curves banked up to ~6 %).
    bank_floor_sigma : floor of the bank 1-sigma with an accelerometer cue (accelerometer
        bias ~0.1 m/s^2 and the cue's lag).
    consistency_window_s : s, window of the NIS test (0 turns the inflation off).
    thrust_angle_sigma_rad : rad, 1-sigma of the rear-axle thrust angle behind beta_std (module
        docstring); 0 turns the term off.
    """

    preset: Literal["auto", "paper", "typical"] = "auto"
    gyro_sigma_100hz_rad_s: float | None = None
    steer_psd_rad2_s: float | None = None
    beta_psd_rad2_per_s: float | None = None
    yaw_accel_psd_rad2_s3: float | None = None
    gyro_bias_psd_rad2_s3: float | None = None
    v_gate_m_s: float = V_GATE
    stiffness_rel_sigma: float = 0.3
    road_bank_sigma: float = 0.03
    bank_floor_sigma: float = 0.01
    consistency_window_s: float = 2.0
    thrust_angle_sigma_rad: float = THRUST_ANGLE_SIGMA

    def __post_init__(self) -> None:
        if self.preset not in ("auto", "paper", "typical"):
            raise ValueError(
                f"MkfSettings.preset = {self.preset!r}: expected 'auto', 'paper' or 'typical'"
            )
        g = self.gyro_sigma_100hz_rad_s
        if g is not None and not (math.isfinite(g) and g > 0):
            raise ValueError(f"MkfSettings.gyro_sigma_100hz_rad_s = {g}: expected a number > 0")
        for name in ("steer_psd_rad2_s", "beta_psd_rad2_per_s", "yaw_accel_psd_rad2_s3",
                     "gyro_bias_psd_rad2_s3", "stiffness_rel_sigma", "road_bank_sigma",
                     "bank_floor_sigma", "consistency_window_s",
                     "thrust_angle_sigma_rad"):  # fmt: skip
            v = getattr(self, name)
            if v is None and "psd" in name:
                continue
            if v is None or not (math.isfinite(v) and v >= 0):
                raise ValueError(f"MkfSettings.{name} = {v}: expected a number >= 0")
        if not (math.isfinite(self.v_gate_m_s) and self.v_gate_m_s > STANDSTILL_SPEED):
            raise ValueError(f"MkfSettings.v_gate_m_s = {self.v_gate_m_s}: expected > 0.1 m/s")

    def noise(self) -> MkfNoise:
        """The densities before identification: explicit values, else the typical ones."""
        typ = MkfNoise()

        def pick(v: float | None, default: float) -> float:
            return default if v is None else v

        return MkfNoise(
            pick(self.steer_psd_rad2_s, typ.steer_psd), pick(self.beta_psd_rad2_per_s, typ.beta_psd),
            pick(self.yaw_accel_psd_rad2_s3, typ.yaw_accel_psd),
            pick(self.gyro_bias_psd_rad2_s3, typ.gyro_bias_psd),
        )  # fmt: skip

    def tuned_groups(self) -> tuple[bool, bool]:
        """(steering/yaw, sideslip): which density groups ``preset="auto"`` identifies."""
        if self.preset != "auto":
            return False, False
        steer_yaw = self.steer_psd_rad2_s is None and self.yaw_accel_psd_rad2_s3 is None
        return steer_yaw, self.beta_psd_rad2_per_s is None


def gyro_sigma(drive: Drive, settings: MkfSettings) -> tuple[float, str]:
    """Gyro white-noise 1-sigma at 100 Hz (rad/s) and where it came from."""
    if settings.gyro_sigma_100hz_rad_s is not None:
        return settings.gyro_sigma_100hz_rad_s, "settings"
    if settings.preset == "auto":
        ident = white_noise_sigma_100hz(drive.t, drive["wz"])
        if ident is not None:
            # a quantised or filtered gyro can show (almost) no sample-to-sample noise; its
            # error is then bias / vibration, kept above a tenth of the typical white noise
            return max(ident, 0.1 * SIGMA_GYRO_100HZ), "drive (second differences of wz)"
    return SIGMA_GYRO_100HZ, "typical"


@dataclass(frozen=True)
class MkfProblem:
    """Everything the MKF loop consumes (also run by the FilterPy peer).

    ``Ad``/``Bd``/``Qd``: table of discrete models (K,4,4)/(K,4,2)/(K,4,4); ``idx[k]``: the
    entry propagating row k-1 to k; ``u`` (N,2) inputs [delta, bank]; ``gyro`` (N) with NaN
    where no sample and ``gyro_var`` its variance; ``course``/``course_var``/``hr`` GNSS
    course; ``zero_rate`` rows at standstill; ``x0``, ``P0`` the prior; ``low`` rows in the
    low-speed mode.
    """

    Ad: FloatArray
    Bd: FloatArray
    Qd: FloatArray
    idx: NDArray[np.intp]
    u: FloatArray
    gyro: FloatArray
    gyro_var: FloatArray
    course: FloatArray
    course_var: FloatArray
    hr: FloatArray
    zero_rate: NDArray[np.bool_]
    x0: FloatArray
    P0: FloatArray
    low: NDArray[np.bool_]
    noise_choice: dict[str, Any] = field(default_factory=dict)


def initial_heading(t: FloatArray, wz: FloatArray, course: FloatArray) -> float:
    """psi(t0) from the first fresh course minus the gyro integrated up to it (beta ~ 0)."""
    rows = np.flatnonzero(np.isfinite(course))
    if rows.size == 0:
        return 0.0
    j = int(rows[0])
    w = np.nan_to_num(wz[:j])
    turned = float(np.sum(w * np.diff(t[: j + 1]))) if j > 0 else 0.0
    return float(course[j] - turned)


def mkf_problem(
    drive: Drive,
    vehicle: Vehicle,
    bank: FloatArray | None = None,
    settings: MkfSettings | None = None,
) -> MkfProblem:
    """Assemble the MKF inputs from a drive (bank: known road bank per row, default zero)."""
    st = settings if settings is not None else MkfSettings()
    t = drive.t
    speed = vehicle_speed(drive)
    steer, _ = hold(drive["steer"], t) if "steer" in drive else (np.zeros_like(t), None)
    u = np.zeros((t.size, 2))  # C-contiguous rows for the numba loop
    u[:, 0] = steer
    if bank is not None:
        u[:, 1] = np.nan_to_num(np.asarray(bank, dtype=float))
    tab = model_table(vehicle, t, speed, st.noise(), st.v_gate_m_s)
    cm = gnss.course_at_cg(drive, vehicle, speed, st.v_gate_m_s)
    wz = drive["wz"]
    x0 = np.array([0.0, 0.0, initial_heading(t, wz, cm.course), 0.0])
    P0 = np.diag([SIGMA_BETA0, SIGMA_R0, SIGMA_PSI0, SIGMA_BIAS0]) ** 2
    g_sigma, _ = gyro_sigma(drive, st)
    prob = MkfProblem(
        tab.Ad, tab.Bd, tab.Qd, tab.idx, u, wz, sample_variance(t, g_sigma), cm.course,
        cm.sigma**2, cm.hr, np.abs(speed) < STANDSTILL_SPEED, x0, P0, tab.low,
    )  # fmt: skip
    tune_sy, tune_b = st.tuned_groups()
    if not (tune_sy or tune_b):
        return prob
    choice = choose_noise(prob, tab.scaled_qd, run_mkf_problem, tune_sy, tune_b)
    return dataclasses.replace(
        prob, Qd=tab.scaled_qd(choice.steer_yaw_factor, choice.beta_factor),
        noise_choice=choice.as_params(),
    )  # fmt: skip


@numba.njit(cache=True)
def _wrap(a: float) -> float:
    return (a + np.pi) % (2.0 * np.pi) - np.pi


@numba.njit(cache=True)
def _mkf_loop(
    Ad: NDArray, Bd: NDArray, Qd: NDArray, idx: NDArray, u: NDArray,
    gyro: NDArray, gyro_var: NDArray, course: NDArray, course_var: NDArray, hr: NDArray,
    zero_rate: NDArray, x0: NDArray, P0: NDArray, zero_rate_var: float, h_g: NDArray,
) -> tuple[NDArray, NDArray, NDArray, NDArray, NDArray, NDArray]:  # fmt: skip
    n = u.shape[0]
    x = x0.copy()
    P = P0.copy()
    xs = np.empty((n, 4))
    pd = np.empty((n, 4))
    ig = np.full(n, np.nan)
    sg = np.full(n, np.nan)
    ic = np.full(n, np.nan)
    sc = np.full(n, np.nan)
    h_r = np.array([0.0, 1.0, 0.0, 0.0])
    h_c = np.zeros(4)
    for k in range(n):
        if k > 0:
            j = idx[k]
            predict_nb(x, P, Ad[j], Qd[j], Bd[j] @ u[k - 1])
        if zero_rate[k]:
            update_scalar_nb(x, P, -x[1], h_r, zero_rate_var)
        if np.isfinite(gyro[k]):
            nu = gyro[k] - x[1] - x[3]
            sg[k] = update_scalar_nb(x, P, nu, h_g, gyro_var[k])
            ig[k] = nu
        if np.isfinite(course[k]):
            h_c[0] = 1.0
            h_c[1] = hr[k]
            h_c[2] = 1.0
            nu = _wrap(course[k] - (x[0] + hr[k] * x[1] + x[2]))
            sc[k] = update_scalar_nb(x, P, nu, h_c, course_var[k])
            ic[k] = nu
        for i in range(4):
            xs[k, i] = x[i]
            pd[k, i] = P[i, i]
    return xs, pd, ig, sg, ic, sc


@dataclass(frozen=True)
class MkfResult:
    """States (N,4), their variances (N,4), and the innovations with their variances S."""

    x: FloatArray
    var: FloatArray
    gyro_innov: FloatArray
    gyro_s: FloatArray
    course_innov: FloatArray
    course_s: FloatArray


def run_mkf_problem(prob: MkfProblem) -> MkfResult:
    """Run the MKF loop (numba) on an assembled problem."""
    out = _mkf_loop(
        prob.Ad, prob.Bd, prob.Qd, prob.idx, prob.u, prob.gyro, prob.gyro_var, prob.course,
        prob.course_var, prob.hr, prob.zero_rate, prob.x0, prob.P0, SIGMA_ZERO_RATE**2, H_GYRO,
    )  # fmt: skip
    return MkfResult(*out)


def channel_diagnostics(innov: FloatArray, s: FloatArray, lags: int = WHITENESS_LAGS) -> dict[str, Any]:
    """Normalised-innovation statistics and Ljung-Box whiteness of one measurement channel."""
    z = normalised_innovations(innov, s)
    z = z[np.isfinite(z)]
    d: dict[str, Any] = whiteness(z, lags).as_dict()
    d["mean"] = float(np.mean(z)) if z.size else 0.0
    d["rms"] = float(np.sqrt(np.mean(z**2))) if z.size else 0.0
    return d


def residual_diagnostics(res: MkfResult, lags: int = WHITENESS_LAGS) -> dict[str, Any]:
    """Normalised-innovation statistics and Ljung-Box whiteness per measurement channel.

    A correct model gives zero-mean, unit-variance ('nis_mean' ~ 1), white residuals; a wrong
    vehicle file shows as a biased / coloured residual (seed 001 sec. V).  At GNSS rows only
    for the course; at every IMU row for the gyro.
    """
    gyro = channel_diagnostics(res.gyro_innov, res.gyro_s, lags)
    course = channel_diagnostics(res.course_innov, res.course_s, lags)
    suspect = gyro["colour"] > RESIDUAL_COLOUR_MAX
    return {
        "gyro": gyro,
        "course": course,
        "colour_limit": RESIDUAL_COLOUR_MAX,
        "verdict": "model mismatch suspected (coloured residuals)" if suspect else "consistent",
    }


def _nis(innov: FloatArray, s: FloatArray) -> FloatArray:
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(np.isfinite(innov) & (s > 0), innov * innov / np.where(s > 0, s, 1.0), np.nan)


def bank_beta_gain(vehicle: Vehicle, speed: FloatArray) -> FloatArray:
    """Steady-state sideslip per unit road bank of the single-track model (rad/rad) at each
    row's speed: the bank column of -A^-1 B (seed 001 eq 1); 0 below the model's gate."""
    v = np.clip(np.abs(speed), V_GATE, None)
    grid = np.unique(np.round(v, 1))
    a2, b2, _, _ = continuous_arrays(vehicle, grid)
    gain = -np.linalg.solve(a2, b2)[:, 0, 1]
    return np.asarray(np.interp(v, grid, gain), dtype=float)


def bank_sigma(
    drive: Drive, speed: FloatArray, yaw_rate: FloatArray, settings: MkfSettings
) -> tuple[FloatArray, str]:
    """1-sigma (as sin) of the road bank the flat-road model ignores, per row, and its source.

    With an accelerometer: hypot(``bank_floor_sigma``, |g sin(roll + bank)| cue) from
    :func:`sideslip.signals.gravity_lateral_sin` (conservative in turns, where it also holds
    the suspension roll).  Without: ``road_bank_sigma`` (typical crown and bank of public
    roads) on every row.
    """
    cue = gravity_lateral_sin(drive, speed, yaw_rate)
    if cue is None:
        return np.full(drive.t.size, settings.road_bank_sigma), "typical road bank (no ay)"
    return np.hypot(settings.bank_floor_sigma, cue), "accelerometer cue (ay - V r) / g"


def _process_noise_params(settings: MkfSettings, prob: MkfProblem) -> dict[str, Any]:
    """The process-noise densities the filter ran with and how they were chosen."""
    base = settings.noise()
    fs = float(prob.noise_choice.get("steer_yaw_factor", 1.0))
    fb = float(prob.noise_choice.get("beta_factor", 1.0))
    source = "drive (mkf_tuning)" if prob.noise_choice else (
        "settings / preset " + repr(settings.preset))
    return {
        "steer_psd_rad2_s": base.steer_psd * fs,
        "yaw_accel_psd_rad2_s3": base.yaw_accel_psd * fs,
        "beta_psd_rad2_per_s": base.beta_psd * fb,
        "gyro_bias_psd_rad2_s3": base.gyro_bias_psd,
        "process_noise_source": source,
        "process_noise_identification": prob.noise_choice or None,
    }


def mkf_estimate(
    name: str,
    drive: Drive,
    vehicle: Vehicle,
    params: dict[str, Any],
    bank: FloatArray | None,
    settings: MkfSettings,
) -> Estimate:
    """Run the MKF and package its estimate (series, params, innovations)."""
    prob = mkf_problem(drive, vehicle, bank, settings)
    res = run_mkf_problem(prob)
    t = drive.t
    sd = np.sqrt(np.maximum(res.var, 0.0))
    nis_g = _nis(res.gyro_innov, res.gyro_s)
    nis_c = _nis(res.course_innov, res.course_s)
    beta_std = sd[:, 0]
    inflation = np.ones(t.size)
    health = np.zeros(t.size)
    health_params: dict[str, Any] = {"criterion": "off"}
    if settings.consistency_window_s > 0:
        both = np.nan_to_num(nis_g) + np.nan_to_num(nis_c)
        dof = np.isfinite(nis_g).astype(float) + np.isfinite(nis_c).astype(float)
        cons = binned_nis_consistency(t, both, dof, settings.consistency_window_s)
        inflation, health = cons.inflation, cons.health
        health_params = cons.summary(t)
    speed = vehicle_speed(drive)
    model_sigma = np.zeros(t.size)
    if settings.stiffness_rel_sigma > 0:
        steer = prob.u[:, 0]
        kin = vehicle.lr / vehicle.wheelbase * steer
        # RMS over the last STIFFNESS_WINDOW_S: a wrong stiffness also shifts the phase of
        # beta in transients, so its error does not vanish where beta crosses lr/L delta
        slip = res.x[:, 0] - kin
        slip_rms = np.sqrt(np.maximum(causal_mean(t, slip**2, STIFFNESS_WINDOW_S), 0.0))
        model_sigma = settings.stiffness_rel_sigma * np.maximum(np.abs(slip), slip_rms)
    bank_sd, bank_source = bank_sigma(drive, speed, res.x[:, 1], settings)
    bank_beta_sd = np.abs(bank_beta_gain(vehicle, speed)) * bank_sd
    if bank is not None:
        bank_beta_sd = np.zeros(t.size)  # the bank is a known input
    thrust = settings.thrust_angle_sigma_rad
    beta_std = np.sqrt(beta_std**2 * inflation + model_sigma**2 + bank_beta_sd**2 + thrust**2)
    g_sigma, g_source = gyro_sigma(drive, settings)
    series = {
        "beta": res.x[:, 0],
        "r": res.x[:, 1],
        "yaw": wrap_angle(res.x[:, 2]),
        "gyro_bias": res.x[:, 3],
        "beta_std": beta_std,
        "r_std": sd[:, 1] * np.sqrt(inflation),
        "yaw_std": sd[:, 2] * np.sqrt(inflation),
        "gyro_bias_std": sd[:, 3],
        "health": health,
    }
    params = dict(params)
    params.update(
        {
            "cf": vehicle.cf,
            "cr": vehicle.cr,
            "bank_input": "given" if bank is not None else "zero",
            "v_gate_mps": settings.v_gate_m_s,
            "low_speed_fraction": float(np.mean(prob.low)),
            "gnss_course_updates": int(np.isfinite(prob.course).sum()),
            "gyro_bias_rad_s": float(res.x[-1, 3]),
            "gyro_bias_rad_s_sigma": float(sd[-1, 3]),
            "noise": {
                "gyro_sigma_100hz_rad_s": g_sigma,
                "gyro_sigma_source": g_source,
                "course_sigma": "gnss_vel_std / V (floor 0.1 deg), GNSS layer",
                "criterion": (
                    "gyro white noise from second differences of wz (robust MAD)"
                    if g_source.startswith("drive")
                    else g_source
                ),
                **_process_noise_params(settings, prob),
            },
            "residuals": residual_diagnostics(res),
            "health": health_params,
            "beta_std_terms": {
                "filter": "P_beta x windowed-NIS inflation",
                "stiffness": f"{settings.stiffness_rel_sigma:g} x max(|beta - lr/L delta|, its RMS "
                f"over {STIFFNESS_WINDOW_S:g} s)",
                "road_bank": bank_source,
                "thrust_angle": f"{math.degrees(thrust):g} deg (rear-axle alignment, unobservable)",
            },
            "settings": settings_dict(settings),
        }
    )
    innovations = {"gyro": res.gyro_innov, "gyro_nis": nis_g, "course": res.course_innov,
                   "course_nis": nis_c}  # fmt: skip
    return Estimate(name, t, series, params, innovations)


def run_mkf(
    drive: Drive,
    vehicle: Vehicle,
    bank: FloatArray | None = None,
    settings: MkfSettings | None = None,
) -> Estimate:
    """The MKF on a drive; ``bank`` (rad per row) as a known input, else zero (bank-unaware)."""
    return mkf_estimate("mkf", drive, vehicle, {}, bank, settings or MkfSettings())


@register(
    "mkf",
    columns=("wz", "steer", SPEED, GNSS_COLUMNS),
    summary="model-based Kalman filter [beta, r, psi, b_gyro] with gyro + GNSS course",
    paper="seed 001 eqs 1-3, 5",
    vehicle_params=("mass", "yaw_inertia", "lf", "lr", "cf", "cr"),
    settings=MkfSettings,
)
def mkf(drive: Drive, vehicle: Vehicle, settings: MkfSettings | None = None) -> Estimate:
    """Model-based Kalman filter of seed 001; see the module docstring."""
    return run_mkf(drive, vehicle, None, settings)
