"""Seed 001: the model-based Kalman filter ``mkf`` (Bevly-style GPS/INS with a vehicle model).

State x = [beta (rad), r (rad/s), psi (rad), b_gyro (rad/s)]; input u = [delta, bank (zero:
the drive has no bank measurement)]; measurements: gyro w_z = r + b_gyro every IMU row, GNSS
course nu = psi + beta + (rx/V) r at GNSS rows (seed 001 eq 5).  Model and discretisation:
:mod:`sideslip.models.mkf_model`; Joseph-form scalar updates (eq 2,
:func:`sideslip.filters.kalman.update_scalar_ws_nb`) in the order standstill pseudo-measurement,
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
sqrt(inflation) and sets ``health``.  The window is tested pooled and on the course alone
(:meth:`~sideslip.filters.consistency.Consistency.worst`): a 1 Hz course's misfit vanishes in
a mean with a 100 Hz gyro whose NIS sits below 1.  That scales a small P and stays small: at the grip
limit (cr_limit_slalom, CommonRoad's BMW on mu 0.6) the linear tyres miss the slip by up to
4 deg while the inflated 1-sigma stayed near 0.3 deg (0.68 of the errors inside 2 sigma).  So
where the test flags a window, the course innovations' power beyond their S (course = psi +
beta: the model's disagreement with the GNSS course, :mod:`sideslip.filters.excess`) is added
to beta's variance: 1.00 there, 0.99 and more in every cell of compare_methods.md, the
straights' band unchanged.  Model errors that NIS cannot see are added in quadrature:
(i) the sideslip the model adds to the kinematic one (beta - lr/L delta, the part that scales
with 1/cornering stiffness; at least its RMS over the last 2 s) carries a relative
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
from sideslip.calibrate.result import Fitted
from sideslip.calibrate.sensors import drive_gyro_bias, gyro_zero_params
from sideslip.calibrate.steer_zero import drive_steer_offset, steer_zero_params, subtracted_offset
from sideslip.drive import Drive
from sideslip.estimate import Estimate
from sideslip.filters.excess import excess_innovation_variance
from sideslip.filters.kalman import (
    normalised_innovations,
    predict_ws_nb,
    update_scalar_ws_nb,
    whiteness,
)
from sideslip.filters.nis_windows import binned_nis_consistency
from sideslip.frames import wrap_angle
from sideslip.methods.mkf_terms import _bank_source, _nis_into, bank_beta_gain, bank_sigma
from sideslip.methods.mkf_tuning import choose_noise
from sideslip.methods.registry import SPEED, register
from sideslip.models.mkf_model import H_GYRO, V_GATE, MkfNoise, model_table
from sideslip.settings import settings_dict
from sideslip.signals import (
    STANDSTILL_SPEED,
    causal_mean,
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
    zero_gyro : start the gyro-bias state at the drive's own zero with its 1-sigma (the bias of
        its GNSS course windows and standstill over the whole drive,
        :func:`sideslip.calibrate.sensors.drive_gyro_bias`) where the drive tells it, instead
        of 0 +- ``SIGMA_BIAS0`` (1 deg/s; the comma2k19 phone's raw gyro has 3.9).
    zero_steer : subtract the drive's own steering offset from the steer input (the intercept
        of calibrate's steering relation alone,
        :func:`sideslip.calibrate.steer_zero.drive_steer_offset`, where more than 2 sigma from
        0): the model reads an offset d0 as a front-axle force c_f d0.  False: as recorded.
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
    zero_gyro: bool = True
    zero_steer: bool = True

    def __post_init__(self) -> None:
        if self.preset not in ("auto", "paper", "typical"):
            raise ValueError(f"MkfSettings.preset = {self.preset!r}: expected 'auto', 'paper' or 'typical'")
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
    low-speed mode; ``gyro_zero`` the drive's zero the bias prior came from (None: not asked);
    ``steer_zero`` the drive's steering offset, subtracted from ``u[:, 0]`` where significant
    (None: not asked).
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
    gyro_sigma_100hz: float = SIGMA_GYRO_100HZ  # rad/s behind gyro_var, and its source
    gyro_sigma_source: str = "typical"
    gyro_zero: Fitted | None = None
    steer_zero: Fitted | None = None


def initial_heading(t: FloatArray, wz: FloatArray, course: FloatArray, drive: Drive | None = None) -> float:
    """psi(t0) from the first fresh course minus the gyro integrated up to it (beta ~ 0).

    Without Doppler (``drive`` given, positions only) the course is the one over the first
    10 m of fixes (:func:`sideslip.gnss.course_from_fixes`) at the middle of that baseline: a
    course from two successive fixes is noise-dominated at 20 Hz (a 20 Hz drive whose first
    two fixes repeat one position gave kkf a heading 65 deg off that it never recovered,
    since its noisy course rate never looked straight)."""
    fixes = None
    if drive is not None and "gnss_ve" not in drive and "gnss_e" in drive and "gnss_n" in drive:
        fixes = gnss.course_from_fixes(drive)
    if fixes is not None:
        value, t_a, t_b = fixes
        j = int(np.searchsorted(t, 0.5 * (t_a + t_b)))
    else:
        rows = np.flatnonzero(np.isfinite(course))
        if rows.size == 0:
            return 0.0
        j = int(rows[0])
        value = float(course[j])
    w = np.nan_to_num(wz[:j])
    turned = float(np.sum(w * np.diff(t[: j + 1]))) if j > 0 else 0.0
    return float(value - turned)


def mkf_problem(
    drive: Drive,
    vehicle: Vehicle,
    bank: FloatArray | None = None,
    settings: MkfSettings | None = None,
    speed: FloatArray | None = None,
) -> MkfProblem:
    """Assemble the MKF inputs from a drive (bank: known road bank per row, default zero;
    speed: :func:`sideslip.signals.vehicle_speed` of the drive when the caller has it)."""
    st = settings if settings is not None else MkfSettings()
    t = drive.t
    if speed is None:
        speed = vehicle_speed(drive)
    steer, _ = hold(drive["steer"], t) if "steer" in drive else (np.zeros_like(t), None)
    u = np.zeros((t.size, 2))  # C-contiguous rows for the numba loop
    u[:, 0] = steer
    del steer
    if bank is not None:
        u[:, 1] = np.nan_to_num(np.asarray(bank, dtype=float))
    tune_sy, tune_b = st.tuned_groups()
    tab = model_table(vehicle, t, speed, st.noise(), st.v_gate_m_s, split=tune_sy or tune_b)
    cm = gnss.course_at_cg(drive, vehicle, speed, st.v_gate_m_s)
    wz = drive["wz"]
    zero = drive_gyro_bias(drive, vehicle) if st.zero_gyro else None
    steer_zero = drive_steer_offset(drive, vehicle, zero) if st.zero_steer and "steer" in drive else None
    if steer_zero is not None:
        u[:, 0] -= subtracted_offset(steer_zero)
    bias0, sigma_bias0 = (zero.value, zero.sigma) if zero and zero.informed else (0.0, SIGMA_BIAS0)
    x0 = np.array([0.0, 0.0, initial_heading(t, wz - bias0 if bias0 else wz, cm.course, drive), bias0])
    P0 = np.diag([SIGMA_BETA0, SIGMA_R0, SIGMA_PSI0, sigma_bias0]) ** 2
    g_sigma, g_source = gyro_sigma(drive, st)
    prob = MkfProblem(
        tab.Ad, tab.Bd, tab.Qd, tab.idx, u, wz, sample_variance(t, g_sigma), cm.course,
        cm.sigma**2, cm.hr, np.abs(speed) < STANDSTILL_SPEED, x0, P0, tab.low,
        gyro_sigma_100hz=g_sigma, gyro_sigma_source=g_source, gyro_zero=zero,
        steer_zero=steer_zero,
    )  # fmt: skip
    if not (tune_sy or tune_b):
        return prob
    choice = choose_noise(prob, tab.scaled_qd, mkf_scores, tune_sy, tune_b)
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
    store: bool,
) -> tuple[NDArray, NDArray, NDArray, NDArray, NDArray, NDArray, NDArray]:  # fmt: skip
    """One MKF pass.  ``store``: keep the per-row states, variances, innovations and S (else
    arrays of length 0, for the tuning passes that need the scores only).  Always returns
    ``scores`` = [-2 ln L gyro, gyro updates, -2 ln L course, course updates] (sum of
    ln S + nu^2 / S over the updates with finite nu and S > 0, as
    :func:`sideslip.methods.mkf_tuning.neg2_log_likelihood`).  One workspace for every
    predict/update (no per-row allocation)."""
    n = u.shape[0]
    m = n if store else 0
    x = x0.copy()
    P = P0.copy()
    xs = np.empty((m, 4))
    pd = np.empty((m, 4))
    ig = np.full(m, np.nan)
    sg = np.full(m, np.nan)
    ic = np.full(m, np.nan)
    sc = np.full(m, np.nan)
    scores = np.zeros(4)
    work = np.zeros((9, 4))  # filters.kalman.workspace(4)
    gu = np.zeros(4)
    h_r = np.array([0.0, 1.0, 0.0, 0.0])
    h_c = np.zeros(4)
    for k in range(n):
        if k > 0:
            j = idx[k]
            u0 = u[k - 1, 0]
            u1 = u[k - 1, 1]
            for i in range(4):
                gu[i] = Bd[j, i, 0] * u0 + Bd[j, i, 1] * u1
            predict_ws_nb(x, P, Ad[j], Qd[j], gu, work)
        if zero_rate[k]:
            update_scalar_ws_nb(x, P, -x[1], h_r, zero_rate_var, work)
        if np.isfinite(gyro[k]):
            nu = gyro[k] - x[1] - x[3]
            s = update_scalar_ws_nb(x, P, nu, h_g, gyro_var[k], work)
            if np.isfinite(nu) and np.isfinite(s) and s > 0.0:
                scores[0] += math.log(s) + nu * nu / s
                scores[1] += 1.0
            if store:
                sg[k] = s
                ig[k] = nu
        if np.isfinite(course[k]):
            h_c[0] = 1.0
            h_c[1] = hr[k]
            h_c[2] = 1.0
            nu = _wrap(course[k] - (x[0] + hr[k] * x[1] + x[2]))
            s = update_scalar_ws_nb(x, P, nu, h_c, course_var[k], work)
            if np.isfinite(nu) and np.isfinite(s) and s > 0.0:
                scores[2] += math.log(s) + nu * nu / s
                scores[3] += 1.0
            if store:
                sc[k] = s
                ic[k] = nu
        if store:
            for i in range(4):
                xs[k, i] = x[i]
                pd[k, i] = P[i, i]
    return xs, pd, ig, sg, ic, sc, scores


@dataclass(frozen=True)
class MkfResult:
    """States (N,4), their variances (N,4), and the innovations with their variances S."""

    x: FloatArray
    var: FloatArray
    gyro_innov: FloatArray
    gyro_s: FloatArray
    course_innov: FloatArray
    course_s: FloatArray


def _run_loop(prob: MkfProblem, store: bool) -> tuple[NDArray, ...]:
    return _mkf_loop(
        prob.Ad, prob.Bd, prob.Qd, prob.idx, prob.u, prob.gyro, prob.gyro_var, prob.course,
        prob.course_var, prob.hr, prob.zero_rate, prob.x0, prob.P0, SIGMA_ZERO_RATE**2, H_GYRO,
        store,
    )  # fmt: skip


def run_mkf_problem(prob: MkfProblem) -> MkfResult:
    """Run the MKF loop (numba) on an assembled problem."""
    return MkfResult(*_run_loop(prob, True)[:6])


def mkf_scores(prob: MkfProblem) -> tuple[tuple[float, int], tuple[float, int]]:
    """-2 ln L and update count of the gyro and of the GNSS-course innovations of one MKF pass
    (the tuning criterion of :mod:`sideslip.methods.mkf_tuning`), without per-row output: the
    pass allocates O(1) memory."""
    sc = _run_loop(prob, False)[6]
    return (float(sc[0]), int(sc[1])), (float(sc[2]), int(sc[3]))


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


def _process_noise_params(settings: MkfSettings, prob: MkfProblem) -> dict[str, Any]:
    """The process-noise densities the filter ran with and how they were chosen."""
    base = settings.noise()
    fs = float(prob.noise_choice.get("steer_yaw_factor", 1.0))
    fb = float(prob.noise_choice.get("beta_factor", 1.0))
    source = "drive (mkf_tuning)" if prob.noise_choice else ("settings / preset " + repr(settings.preset))
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
    """Run the MKF and package its estimate (series, params, innovations).

    Memory (issue 17): the problem's per-row inputs are freed once the pass has run, the
    residual statistics are taken before the output series exist, and the standard deviations,
    NIS and wrapped yaw are formed in the pass's own arrays."""
    t = drive.t
    speed = vehicle_speed(drive)
    prob = mkf_problem(drive, vehicle, bank, settings, speed=speed)
    res = run_mkf_problem(prob)
    steer = prob.u[:, 0].copy() if settings.stiffness_rel_sigma > 0 else None
    problem_params: dict[str, Any] = {
        "low_speed_fraction": float(np.mean(prob.low)),
        "gnss_course_updates": int(np.isfinite(prob.course).sum()),
    }
    if prob.gyro_zero is not None:
        problem_params["gyro_bias_start"] = {
            **gyro_zero_params(prob.gyro_zero, subtracted=False),
            "else": "0 +- SIGMA_BIAS0 (the drive does not tell it)"}
    if prob.steer_zero is not None:
        problem_params.update(steer_zero_params(prob.steer_zero))
    noise_params = _process_noise_params(settings, prob)
    g_sigma, g_source = prob.gyro_sigma_100hz, prob.gyro_sigma_source
    del prob
    residuals = residual_diagnostics(res)
    course_s = res.course_s.copy()  # S before it becomes the NIS (filters.excess needs it)
    nis_g, nis_c = res.gyro_s, res.course_s  # S becomes the NIS in place
    _nis_into(res.gyro_innov, nis_g)
    _nis_into(res.course_innov, nis_c)
    health = np.zeros(t.size)
    health_params: dict[str, Any] = {"criterion": "off"}
    sd = res.var
    np.sqrt(np.maximum(sd, 0.0, out=sd), out=sd)
    beta_std = np.square(sd[:, 0])
    if settings.consistency_window_s > 0:
        both = np.nan_to_num(nis_g) + np.nan_to_num(nis_c)
        dof = np.isfinite(nis_g).astype(float) + np.isfinite(nis_c).astype(float)
        cons = binned_nis_consistency(t, both, dof, settings.consistency_window_s)
        del both, dof
        # the course's own test as well: pooled with a 100 Hz gyro whose NIS sits below 1, a
        # 1 Hz course's misfit vanished in the window's mean (positions only at CommonRoad's
        # limit slalom: course NIS 3-6 where beta was 3 deg off, pooled window NIS 0.3)
        course_rows = np.isfinite(nis_c)
        if course_rows.any():
            cons = cons.worst(
                binned_nis_consistency(t, nis_c, course_rows.astype(float), settings.consistency_window_s)
            )
        del course_rows
        health, health_params = cons.health, cons.summary(t)
        beta_std *= cons.inflation
        # the course innovation is psi + beta's: where the model stops fitting, beta is no
        # surer than the course power the filter's S does not explain (filters.excess)
        beta_std += excess_innovation_variance(
            t, res.course_innov, course_s, cons.flagged, settings.consistency_window_s
        )
        del course_s
        root = np.sqrt(cons.inflation)
        del cons
        sd[:, 1] *= root
        sd[:, 2] *= root
        del root
    if steer is not None:
        # RMS over the last STIFFNESS_WINDOW_S: a wrong stiffness also shifts the phase of
        # beta in transients, so its error does not vanish where beta crosses lr/L delta
        slip = res.x[:, 0] - vehicle.lr / vehicle.wheelbase * steer
        del steer
        slip_rms = np.sqrt(np.maximum(causal_mean(t, slip**2, STIFFNESS_WINDOW_S), 0.0))
        np.maximum(np.abs(slip, out=slip), slip_rms, out=slip)
        del slip_rms
        beta_std += np.square(settings.stiffness_rel_sigma * slip, out=slip)
        del slip
    if bank is None:
        bank_sd, bank_source = bank_sigma(
            drive, speed, res.x[:, 1], settings.bank_floor_sigma, settings.road_bank_sigma
        )
        bank_sd *= bank_beta_gain(vehicle, speed)
        beta_std += np.square(bank_sd, out=bank_sd)
        del bank_sd
    else:  # the bank is a known input
        bank_source = _bank_source(drive)
    thrust = settings.thrust_angle_sigma_rad
    beta_std += thrust**2
    np.sqrt(beta_std, out=beta_std)
    res.x[:, 2] = wrap_angle(res.x[:, 2])
    series = {
        "beta": res.x[:, 0],
        "r": res.x[:, 1],
        "yaw": res.x[:, 2],
        "gyro_bias": res.x[:, 3],
        "beta_std": beta_std,
        "r_std": sd[:, 1],
        "yaw_std": sd[:, 2],
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
            **problem_params,
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
                **noise_params,
            },
            "residuals": residuals,
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
    accelerometer="cg_causal",
)
def mkf(drive: Drive, vehicle: Vehicle, settings: MkfSettings | None = None) -> Estimate:
    """Model-based Kalman filter of seed 001; see the module docstring."""
    return run_mkf(drive, vehicle, None, settings)
