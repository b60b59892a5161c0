"""Roll and bank from IMU, wheel speed and steering (seed 003, IEEE Access 2020, Sec. III).

Two registered methods:

* ``roll_index`` -- the paper's proposal (eqs 41-61): the total roll (suspension roll + road
  bank) is the static bank angle ``phi_ss`` (eq 46) while the roll index lambda = 1, and the
  last static value plus the change of the suspension roll (eq 41) while lambda = 0 (eq 61).
* ``roll_dfc`` -- Tseng's dynamic bank (eqs 49-58), the paper's comparison.

Both write ``roll`` (total roll, rad, ISO sign: right side down positive) and ``bank`` (rad,
roll sign).  ``roll_index`` writes ``bank = roll - phi_sus`` with phi_sus from eq 41;
``roll_dfc`` writes ``bank = w (phi_ss - phi_sus)`` with w the factor of eq 58.

Measurements (held onto every row; only the IMU rows carry new samples): ``ay`` a_ym (m/s^2,
lateral specific force), ``wz`` r (rad/s, zeroed at standstill, see :func:`sensor_inputs`),
v_x (m/s, undriven = rear wheels, else all wheels, else ``v_can``), ``steer`` delta (front
road-wheel angle, rad).  Signs: see :mod:`sideslip.models.roll` (the paper's Phi is minus ours).

The roll index (eq 60), as implemented -- the extracted text cannot be taken literally
-------------------------------------------------------------------------------------
Eq 60 writes lambda = f g h k, but with the flags as printed the product is never 1 (h needs
|r| < 0.3 deg/s while k needs delta r > 1500 deg^2/s), and g as printed (phi_ay phi_r < 0)
contradicts its own description ("presence of a road bank"): on a bank in a steady state
eqs 55 and 56 both return the bank angle and share its sign, while opposite signs are what a
steering transient on flat ground produces (r lags the steering, so eq 56 and eq 55 swing
opposite ways).  We keep every flag, threshold and hold time of the paper and combine them as
their descriptions say:

    lambda = f * k * (g or h)          (and lambda = 1 below ``V_MIN``)

* f = 1: steady state, |d/dt(|phi_ay' - phi_ss'| - |phi_r' - phi_ss'|)| < 25 deg/s^2 for 0.4 s;
* g = 1: bank present, phi_ay phi_r > 0 for 0.4 s.  Eq 56 is fragile: a steering offset d0
  moves phi_r by d0/(K_us g) at any speed (0.1 deg on seed 003's car, K_us = 6e-4 rad/(m/s^2):
  17 deg), and in a turn it cancels two large terms that depend on K_us.  Where its error
  (:func:`yaw_bank_resolution`: steering offset, 30 % understeer-gradient error, gyro bias)
  exceeds |phi_ay|, the yaw channel cannot resolve the bank and the sign test is skipped
  (counts as agreeing); it bites for strongly understeering cars, large banks, small steering.
  (f keeps its phi_r term: eq 56's swing with the steering rate, delta'/(K_us g), is what makes
  f see steering transients early; its price is the delay at the end of a bank ramp, where
  the steering unwinds -- the delay the paper reports in Fig 7a);
* h = 1: straight and flat, |delta| < 0.5 deg, |delta'| < 0.1 deg/s (road-wheel angle, the
  paper's delta_f), |r| < 0.3 deg/s for ``T_STRAIGHT`` s (the paper gives no value for t_TH3);
* k = 1: no urgent steering, i.e. |delta_sw r| <= 1500 deg^2/s throughout the last 1.5 s,
  with delta_sw = steering_ratio * delta the steering-wheel angle: with the road-wheel angle
  this threshold would be unreachable (1500 deg^2/s needs r = 300 deg/s at 5 deg), so the
  paper's K_TH must refer to the steering wheel.  (With the steering wheel, h's 0.5 deg would
  in turn be below a typical steering-sensor offset of 0.1 deg road wheel = 1.6 deg wheel.)
lambda = 1 when straight (h) re-anchors the integration to phi_ss ~ 0 on a level road; when the
static estimate is trusted on a bank (f g k) it tracks the bank; everywhere else (steering
transients, urgent steering) eq 61 adds the suspension-roll change to the last static value.

Noise handling: the flags differentiate twice, so their inputs are low-passed (second-order
Butterworth, ``FLAG_CUTOFF_HZ``); the roll inputs at ``ROLL_CUTOFF_HZ``.  The filters start at
the mean of the first ``START_S`` seconds (the only look-ahead; everything else is causal).
Sensor errors: the paper assumes zeroed sensors; here the gyro is zeroed at standstill only,
so a gyro bias b moves the static bank by v b / g (0.2 deg/s at 140 km/h: ~0.8 deg) -- the
main error on flat high-speed drives.  Low speed and standstill: below ``V_MIN`` the Tseng
gains degenerate, lambda is forced to 1 and phi_ss is the accelerometer's tilt (exact at
standstill, a_ym = g sin(phi)); the outputs stay finite on every row (NaN gaps are held by a
zero-order hold; rows before a sensor's first sample take that first sample).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import numba
import numpy as np
from numpy.typing import NDArray
from scipy.signal import butter, sosfilt, sosfilt_zi

from sideslip.calibrate.result import Fitted
from sideslip.calibrate.sensors import drive_gyro_bias, gyro_zero_params, subtracted_zero
from sideslip.calibrate.steer_zero import drive_steer_offset, steer_zero_params, subtracted_offset
from sideslip.drive import Drive
from sideslip.estimate import Estimate
from sideslip.methods.observer_health import stale_health
from sideslip.methods.registry import SPEED, register
from sideslip.methods.roll_gradient import RollGradient, identify_roll_gradient
from sideslip.models.roll import (
    TsengGains,
    dynamic_bank_weight,
    dynamic_factor,
    roll_dynamics,
    sin_roll_from_ay,
    sin_roll_from_r,
    suspension_roll,
    tseng_gains,
)
from sideslip.signals import STANDSTILL_SPEED, speed_raw
from sideslip.vehicle import G, Vehicle

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

DEG = math.pi / 180.0
V_MIN = 5.0  # m/s: below, lambda = 1 (Tseng's gains degenerate; v_y' is small when slow)
ROLL_CUTOFF_HZ = 2.0  # low-pass of a_ym, r, delta for the roll estimates (IMU noise)
FLAG_CUTOFF_HZ = 1.0  # low-pass of the signals the flags differentiate
# Paper's thresholds (Sec. III-D), SI:
F_TH = 25.0 * DEG  # rad/s^2
T_TH1 = 0.4  # s
T_TH2 = 0.4  # s
G_TH1 = 0.5 * DEG  # rad (road wheel)
G_TH2 = 0.1 * DEG  # rad/s (road wheel)
G_TH3 = 0.3 * DEG  # rad/s
T_STRAIGHT = 1.0  # s: t_TH3, not given in the paper
K_TH = 1500.0 * DEG**2  # rad^2/s (steering wheel x yaw rate)
T_TH4 = 1.5  # s
START_S = 0.2  # s: initial level of the low-pass filters
STEER_OFFSET_TOL = 0.1 * DEG  # rad: typical steering-angle offset (road wheel) after calibration
KUS_REL_TOL = 0.3  # relative error of the understeer gradient (tyre stiffness 30 % off)
GYRO_BIAS_TOL = 0.2 * DEG  # rad/s: typical MEMS gyro turn-on bias
STANDSTILL_MIN_S = 0.5  # s of standstill before its gyro mean is used as the gyro bias

# roll inertia and damping are used when given, typical values otherwise (models.roll)
ROLL_PARAMS = (
    "mass", "lf", "lr", "cf", "cr", "cg_height", "roll_axis_height", "roll_stiffness",
    "steering_ratio",
)  # fmt: skip


@dataclass(frozen=True)
class RollSettings:
    """Tuning of ``roll_index`` and ``roll_dfc``: ``roll_cutoff_hz`` (Hz, low-pass of the roll
    channels), ``identify_roll_gradient`` (use the drive's suspension roll gradient where it
    contradicts the file, :mod:`sideslip.methods.roll_gradient`), ``zero_gyro`` (subtract the
    drive's own gyro zero before the standstill zeroing starts, :func:`sensor_inputs`),
    ``zero_steer`` (subtract the drive's own steering offset, :func:`sensor_inputs`; the
    straight-and-flat test |delta| < 0.5 deg and the yaw/steer roll read the steer)."""

    roll_cutoff_hz: float = ROLL_CUTOFF_HZ
    identify_roll_gradient: bool = True
    zero_gyro: bool = True
    zero_steer: bool = True

    def __post_init__(self) -> None:
        if not (math.isfinite(self.roll_cutoff_hz) and 0.05 <= self.roll_cutoff_hz <= 20.0):
            raise ValueError(f"RollSettings.roll_cutoff_hz = {self.roll_cutoff_hz}: expected "
                             "0.05 ... 20 Hz")


@dataclass(frozen=True)
class Inputs:
    """Sensor signals held onto every row of the drive (SI units).

    ay_m: lateral specific force; r: yaw rate minus ``gyro_bias``; vx: longitudinal speed
    (signed when the sensor is); delta: road-wheel angle; gyro_bias: the standstill gyro mean
    used (rad/s; until ``STANDSTILL_MIN_S`` of standstill has been seen, the drive's own zero
    ``gyro_zero`` where it has one, else 0); ax: longitudinal specific force (zeros when the
    drive has no ``ax``); speed_fresh: rows with a new speed sample; speed_dt: time since the
    previous speed sample at those rows (s); gyro_zero: the drive's zero that was asked for
    (None when not); steer_zero: the drive's steering offset that was asked for (None when
    not), subtracted from ``delta`` where significant.
    """

    t: FloatArray
    ay_m: FloatArray
    ax: FloatArray
    r: FloatArray
    vx: FloatArray
    delta: FloatArray
    gyro_bias: FloatArray
    speed_fresh: BoolArray
    speed_dt: FloatArray
    gyro_zero: Fitted | None = None
    steer_zero: Fitted | None = None

    def gyro_zero_params(self) -> dict[str, object]:
        """The drive's gyro zero and steering offset for a method's params (empty where they
        were not asked for)."""
        out: dict[str, object] = {}
        if self.gyro_zero is not None:
            out.update(gyro_zero_params(self.gyro_zero),
                       gyro_zero_use="the rows before STANDSTILL_MIN_S of standstill")
        if self.steer_zero is not None:
            out.update(steer_zero_params(self.steer_zero))
        return out


@numba.njit(cache=True)
def hold_first(values: FloatArray) -> FloatArray:  # pragma: no cover - compiled
    """Zero-order hold of the finite samples onto every row, rows before the first sample
    taking that first sample (0 when there is none): ``signals.hold(values, t,
    fill=first sample)`` in one pass."""
    n = values.size
    last = 0.0
    for k in range(n):
        if math.isfinite(values[k]):
            last = values[k]
            break
    out = np.empty(n)
    for k in range(n):
        if math.isfinite(values[k]):
            last = values[k]
        out[k] = last
    return out


def _held(drive: Drive, name: str) -> FloatArray:
    if name not in drive:
        return np.zeros_like(drive.t)
    return np.asarray(hold_first(drive[name]))


@numba.njit(cache=True)
def _gyro_bias_nb(t: FloatArray, wz: FloatArray, still: BoolArray, min_s: float,
                  before: float) -> FloatArray:  # pragma: no cover - compiled
    """Running standstill mean of ``wz`` (see :func:`standstill_gyro_bias`), one pass;
    ``before`` on the rows before enough standstill has been seen."""
    n = t.size
    out = np.empty(n)
    count = 0
    total = 0.0
    seen = 0.0
    for k in range(n):
        if still[k] and math.isfinite(wz[k]):
            count += 1
            total += wz[k]
            seen += t[k] - t[k - 1] if k > 0 else 0.0
        bias = total / max(count, 1) if count > 0 else 0.0
        out[k] = bias if seen >= min_s else before
    return out


def standstill_gyro_bias(t: FloatArray, wz: FloatArray, still: BoolArray, before: float = 0.0
                         ) -> FloatArray:
    """Causal gyro zeroing (the paper assumes zeroed sensors, refs [26, 27]).

    Running mean of ``wz`` over the standstill rows seen so far, used once at least
    ``STANDSTILL_MIN_S`` of standstill has accumulated; ``before`` (rad/s, e.g. the drive's
    own zero, :func:`sideslip.calibrate.sensors.drive_gyro_bias`) until then.  rad/s on every
    row.
    """
    return np.asarray(_gyro_bias_nb(np.asarray(t, dtype=float), np.asarray(wz, dtype=float),
                                    np.asarray(still, dtype=np.bool_), STANDSTILL_MIN_S,
                                    float(before)))


@numba.njit(cache=True)
def _sample_steps(t: FloatArray, fresh: BoolArray, first_dt: float
                  ) -> FloatArray:  # pragma: no cover - compiled
    """Time since the previous fresh row at each fresh row (``first_dt`` at the first), 0 else."""
    out = np.zeros(t.size)
    prev = -1
    for k in range(t.size):
        if fresh[k]:
            out[k] = t[k] - t[prev] if prev >= 0 else first_dt
            prev = k
    return out


def sensor_inputs(drive: Drive, gyro_vehicle: Vehicle | None = None,
                  steer_vehicle: Vehicle | None = None) -> Inputs:
    """Hold the sensors onto every row; zero the gyro and the steering; see :class:`Inputs`.

    The gyro is zeroed at standstill (:func:`standstill_gyro_bias`, causal); on the rows
    before ``STANDSTILL_MIN_S`` of standstill, with the drive's own zero (the bias of its GNSS
    course windows and standstill, else its rear wheel speeds,
    :func:`sideslip.calibrate.sensors.drive_gyro_bias`, a calibration of the whole drive as the
    papers' "zeroed sensors" are) when ``gyro_vehicle`` (the vehicle file) is given and the
    zero is more than 2 sigma from 0 (:func:`sideslip.calibrate.sensors.subtracted_zero`),
    else 0.  The standstill rows
    are those of :func:`sideslip.signals.standstill`, computed from the held speed ``vx`` (the
    same hold of the same samples) rather than a second pass.  With ``steer_vehicle`` (the
    vehicle file) the drive's own steering offset
    (:func:`sideslip.calibrate.steer_zero.drive_steer_offset`) is subtracted from the steer
    where it is more than 2 sigma from 0 (:func:`sideslip.calibrate.steer_zero.subtracted_offset`)."""
    t = drive.t
    raw_speed = speed_raw(drive)
    if raw_speed is None:
        vx = np.zeros_like(t)
        fresh = np.zeros(t.size, dtype=bool)
        still = np.zeros(t.size, dtype=bool)
    else:
        vx = np.asarray(hold_first(raw_speed))
        fresh = np.isfinite(raw_speed)
        still = np.abs(vx) < STANDSTILL_SPEED
    speed_dt = np.asarray(_sample_steps(t, fresh, drive.dt_median if fresh.any() else 0.0))
    wz = drive["wz"] if "wz" in drive else np.zeros_like(t)
    zero = drive_gyro_bias(drive, gyro_vehicle) if gyro_vehicle is not None and "wz" in drive else None
    bias = standstill_gyro_bias(t, wz, still, subtracted_zero(zero) if zero is not None else 0.0)
    delta = _held(drive, "steer")
    steer_zero = None
    if steer_vehicle is not None and "steer" in drive:
        steer_zero = drive_steer_offset(drive, steer_vehicle, zero)
        delta = delta - subtracted_offset(steer_zero)
    return Inputs(
        t=t,
        ay_m=_held(drive, "ay"),
        ax=_held(drive, "ax"),
        r=np.asarray(hold_first(wz)) - bias,
        vx=vx,
        delta=delta,
        gyro_bias=bias,
        speed_fresh=fresh,
        speed_dt=speed_dt,
        gyro_zero=zero,
        steer_zero=steer_zero,
    )


@functools.lru_cache(maxsize=32)
def _butter_sos(wn: float) -> tuple[FloatArray, FloatArray]:
    """Second-order Butterworth low-pass at normalised cutoff ``wn`` as SOS and its initial
    state per unit input (designed once per cutoff: shared, callers pass copies on)."""
    sos = np.asarray(butter(2, wn, output="sos"), dtype=float)
    return sos, np.asarray(sosfilt_zi(sos), dtype=float)


def lowpass(x: FloatArray, t: FloatArray, cutoff_hz: float, dt: float | None = None
            ) -> FloatArray:
    """Causal second-order Butterworth low-pass at the drive's median rate, started at rest
    on the mean of the first ``START_S`` seconds (a single noisy first sample would otherwise
    bias the start).  Returns ``x`` unchanged when too short to filter.  ``dt``: the median
    sample interval of ``t`` (s) when the caller has it (computed otherwise)."""
    if x.size < 8:
        return x.copy()
    if dt is None:
        dt = float(np.median(np.diff(t)))
    nyq = 0.5 / dt
    if cutoff_hz >= 0.9 * nyq:
        return x.copy()
    sos, zi = _butter_sos(cutoff_hz / nyq)
    x0 = float(np.mean(x[t <= t[0] + START_S]))
    y, _ = sosfilt(sos.copy(), x, zi=zi * x0)
    return np.asarray(y, dtype=float)


def ddt(x: FloatArray, t: FloatArray) -> FloatArray:
    """Causal backward difference dx/dt (0 on the first row)."""
    out = np.zeros_like(x)
    out[1:] = np.diff(x) / np.diff(t)
    return out


@numba.njit(cache=True)
def _held_for_nb(cond: BoolArray, t: FloatArray, duration: float
                 ) -> BoolArray:  # pragma: no cover - compiled
    out = np.empty(cond.size, dtype=np.bool_)
    last = -1  # latest row where cond was false
    for k in range(cond.size):
        if not cond[k]:
            last = k
        since = t[k] - t[last] if last >= 0 else t[k] - t[0] + duration
        out[k] = cond[k] and since >= duration
    return out


@numba.njit(cache=True)
def _seen_within_nb(cond: BoolArray, t: FloatArray, duration: float
                    ) -> BoolArray:  # pragma: no cover - compiled
    out = np.empty(cond.size, dtype=np.bool_)
    last = -1  # latest row where cond was true
    for k in range(cond.size):
        if cond[k]:
            last = k
        out[k] = last >= 0 and t[k] - t[last] <= duration
    return out


def held_for(cond: BoolArray, t: FloatArray, duration: float) -> BoolArray:
    """True where ``cond`` has held on every row of the last ``duration`` seconds (one
    compiled pass)."""
    return np.asarray(_held_for_nb(np.asarray(cond, dtype=np.bool_), np.asarray(t, dtype=float),
                                   float(duration)))


def seen_within(cond: BoolArray, t: FloatArray, duration: float) -> BoolArray:
    """True where ``cond`` was true on some row of the last ``duration`` seconds (one
    compiled pass)."""
    return np.asarray(_seen_within_nb(np.asarray(cond, dtype=np.bool_),
                                      np.asarray(t, dtype=float), float(duration)))


@dataclass(frozen=True)
class RollEstimate:
    """Roll-index result: rad, on every row.  Flags are 0/1 arrays; ``lam`` is lambda."""

    roll: FloatArray
    bank: FloatArray
    lam: BoolArray
    f: BoolArray
    g: BoolArray
    h: BoolArray
    k: BoolArray
    params: dict[str, object] = field(default_factory=dict)


def _channels(inp: Inputs, vehicle: Vehicle, cutoff: float, dt: float | None = None,
              gains: TsengGains | None = None
              ) -> tuple[FloatArray, FloatArray, FloatArray, TsengGains, FloatArray, FloatArray]:
    """sin of phi_ss (eq 46), phi_ay (eq 55), phi_r (eq 56) on low-passed inputs, Tseng's
    gains (eqs 49-52) at |v_x| and the low-passed a_y, delta.  ``dt``: median sample interval
    (s, see :func:`lowpass`) and ``gains`` when the caller has them already."""
    t = inp.t
    if dt is None and t.size >= 8:
        dt = float(np.median(np.diff(t)))
    ay = lowpass(inp.ay_m, t, cutoff, dt)
    r = lowpass(inp.r, t, cutoff, dt)
    d = lowpass(inp.delta, t, cutoff, dt)
    v = np.abs(inp.vx)
    if gains is None:
        gains = tseng_gains(v, vehicle.wheelbase, vehicle.understeer_gradient)
    s_ss = np.clip((ay - r * v) / G, -1.0, 1.0)
    s_ay = sin_roll_from_ay(ay, d, gains)
    s_r = sin_roll_from_r(r, d, gains)
    return s_ss, s_ay, s_r, gains, ay, d


def yaw_bank_resolution(vehicle: Vehicle, speed: FloatArray, delta: FloatArray) -> FloatArray:
    """Error (rad, per row) of eq 56's roll from typical sensor and parameter errors.

    sin(phi_r) = (r - H_delta->r delta)/H_phi->r with H_delta->r/|H_phi->r| = 1/(K_us g):
    a steering offset d0 and a relative error e_K of the understeer gradient (a cancellation of
    two large terms in a turn) move it by (d0 + e_K |delta|)/(K_us g); a gyro bias b_r by
    b_r (L + K_us v^2)/(v K_us g).  d0 = ``STEER_OFFSET_TOL``, e_K = ``KUS_REL_TOL``,
    b_r = ``GYRO_BIAS_TOL``.
    """
    kus = abs(vehicle.understeer_gradient)
    if kus < 1e-9:
        return np.full(speed.shape, np.inf)
    v = np.maximum(speed, 1.0)
    steer = (STEER_OFFSET_TOL + KUS_REL_TOL * np.abs(delta)) / (kus * G)
    gyro = GYRO_BIAS_TOL * (vehicle.wheelbase + kus * v**2) / (v * kus * G)
    return np.asarray(steer + gyro, dtype=float)


def roll_vehicle(vehicle: Vehicle, grad: RollGradient) -> Vehicle:
    """The vehicle with its roll stiffness set so that m h / k is the identified gradient
    (when it was identified; the file's roll inertia and damping, or the typical roll
    dynamics, are kept)."""
    if not grad.applied:
        return vehicle
    inertia, damping, _ = roll_dynamics(vehicle)
    return vehicle.with_changes(
        roll_stiffness=vehicle.mass * (vehicle.cg_height - vehicle.roll_axis_height) / grad.value,
        roll_inertia=inertia, roll_damping=damping,
    )


def estimate_roll_index(inp: Inputs, vehicle: Vehicle, identify_gradient: bool = True,
                        roll_cutoff_hz: float = ROLL_CUTOFF_HZ) -> RollEstimate:
    """Eqs 41-61 with the roll index as described in the module docstring.

    ``identify_gradient``: the suspension roll gradient of eq 41-43 from the drive where it
    informs it and contradicts the file (:mod:`sideslip.methods.roll_gradient`), else the
    file's m h / k.
    """
    t = inp.t
    dt = float(np.median(np.diff(t))) if t.size >= 8 else None  # for every low-pass below
    moving = np.abs(inp.vx) >= V_MIN
    # (each per-row intermediate is freed once used: a day at 100 Hz is 69 MB a channel)
    s_ss, _, _, gains, ay_f, _ = _channels(inp, vehicle, roll_cutoff_hz, dt)
    phi_ss = np.arcsin(s_ss)
    del s_ss
    # flags on more strongly smoothed channels
    fs_ss, fs_ay, fs_r, _, _, d_f = _channels(inp, vehicle, FLAG_CUTOFF_HZ, dt, gains)
    f_ss, f_ay, f_r = np.arcsin(fs_ss), np.arcsin(fs_ay), np.arcsin(fs_r)
    del fs_ss, fs_ay, fs_r
    d_ss, d_ay, d_r = ddt(f_ss, t), ddt(f_ay, t), ddt(f_r, t)
    del f_ss
    shape = ddt(np.abs(d_ay - d_ss) - np.abs(d_r - d_ss), t)
    del d_ss, d_ay, d_r
    shape = lowpass(shape, t, FLAG_CUTOFF_HZ, dt)
    f = held_for(np.abs(shape) < F_TH, t, T_TH1)
    del shape
    # the yaw channel resolves a bank only beyond its own error (docstring)
    resolves = yaw_bank_resolution(vehicle, np.abs(inp.vx), d_f) < np.abs(f_ay)
    g = held_for((f_ay * f_r > 0.0) | ~resolves, t, T_TH2)
    del f_ay, f_r, resolves
    r_f = lowpass(inp.r, t, FLAG_CUTOFF_HZ, dt)
    h = held_for(
        (np.abs(d_f) < G_TH1) & (np.abs(ddt(d_f, t)) < G_TH2) & (np.abs(r_f) < G_TH3),
        t, T_STRAIGHT,
    )
    d_sw = vehicle.steering_ratio * d_f
    del d_f
    k = ~seen_within(np.abs(d_sw * r_f) > K_TH, t, T_TH4)
    del d_sw, r_f
    lam = (f & k & (g | h)) | ~moving
    grad = identify_roll_gradient(t, ay_f, phi_ss, f & k & moving, moving).validated(
        vehicle.static_roll_gain)
    if not identify_gradient:
        grad = RollGradient(grad.value, grad.sigma, grad.rows, grad.curves, False,
                            "identification switched off (settings): file value used")
    params = grad.params(vehicle.static_roll_gain)
    used = roll_vehicle(vehicle, grad)
    phi_sus = suspension_roll(t, ay_f, used)
    # eq 61: anchor = last row with lambda = 1 (phi*_ss is phi_ss there)
    idx = np.where(lam, np.arange(t.size), -1)
    np.maximum.accumulate(idx, out=idx)
    anchor = np.maximum(idx, 0)
    roll = np.where(lam, phi_ss, phi_ss[anchor] + phi_sus - phi_sus[anchor])
    del phi_ss, idx, anchor
    return RollEstimate(roll=roll, bank=roll - phi_sus, lam=lam, f=f, g=g, h=h, k=k, params=params)


def estimate_roll_dfc(inp: Inputs, vehicle: Vehicle, roll_cutoff_hz: float = ROLL_CUTOFF_HZ
                      ) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Tseng's dynamic bank (eqs 55-58): returns (roll, bank), rad.

    roll = asin(sin(phi_ss) w), w = max(0, 1 - |DFC| - |d sin(phi_ss)/dt|) (eq 58, DFC in
    m/s^2 as written); bank = w (phi_ss - phi_sus) removes the suspension roll of eq 41 (the
    steady phi_ss is bank + suspension roll).  Below ``V_MIN``, w = 1.
    """
    t = inp.t
    s_ss, s_ay, s_r, gains, ay_f, _ = _channels(inp, vehicle, roll_cutoff_hz)
    dfc = dynamic_factor(s_ay, s_r, s_ss, np.abs(inp.vx), gains)
    w = dynamic_bank_weight(dfc, ddt(s_ss, t))
    w = np.where(np.abs(inp.vx) >= V_MIN, w, 1.0)
    phi_sus = suspension_roll(t, ay_f, vehicle)
    roll = np.arcsin(np.clip(s_ss * w, -1.0, 1.0))
    return roll, w * (np.arcsin(s_ss) - phi_sus), w


def _fraction(x: BoolArray) -> float:
    return float(np.mean(x)) if x.size else 0.0


def _imu_fresh(drive: Drive) -> BoolArray:
    ok = np.ones(len(drive), dtype=bool)
    for name in ("wz", "ay"):
        if name in drive:
            ok &= np.isfinite(drive[name])
    return ok


HOLD_FULL_S = 10.0  # s of eq-61 integration from the last static anchor at which health = 0.5
SLOW_HEALTH = 0.2  # moving below V_MIN: lambda forced to 1, v_y' and Tseng's gains unchecked


def roll_index_health(inp: Inputs, est: RollEstimate, imu_fresh: BoolArray | None = None
                      ) -> tuple[FloatArray, dict[str, object]]:
    """Health of the roll index (0 good ... 1 unusable) from what it checks itself.

    0 where the static relation is trusted (lambda = 1, all flags agree); while lambda = 0 the
    roll is the last static value plus eq 41's change, and a bank change since the anchor goes
    unseen: health rises linearly to 0.5 at ``HOLD_FULL_S`` s from the anchor; rolling slower
    than ``V_MIN``: ``SLOW_HEALTH``; standstill 0 (the accelerometer tilt is exact).
    """
    t = inp.t
    idx = np.where(est.lam, np.arange(t.size), -1)
    np.maximum.accumulate(idx, out=idx)
    since = np.where(idx >= 0, t - t[np.maximum(idx, 0)], t - t[0])
    moving = np.abs(inp.vx) >= V_MIN
    rolling = np.abs(inp.vx) >= 0.1
    health = np.where(moving, np.clip(0.5 * since / HOLD_FULL_S, 0.0, 0.5),
                      np.where(rolling, SLOW_HEALTH, 0.0))
    if imu_fresh is not None:  # held IMU samples (a sensor gap): observer_health.stale_health
        health = np.maximum(health, stale_health(t, imu_fresh))
    return health, {
        "criterion": f"time since the last static anchor (0.5 at {HOLD_FULL_S:g} s), slow rolling",
        "flagged_share": _fraction(health > 0),
        "max_hold_s": float(since[moving].max()) if moving.any() else 0.0,
    }


@register(
    "roll_index",
    columns=("wz", "ay", "steer", SPEED),
    summary="roll/bank by seed 003's roll index: static bank when steady, suspension roll else",
    paper="seed 003 (eqs 41-61)",
    vehicle_params=ROLL_PARAMS,
    settings=RollSettings,
    accelerometer="cg_causal",
)
def roll_index(drive: Drive, vehicle: Vehicle, settings: RollSettings | None = None
               ) -> Estimate:
    """Total roll and road bank by the roll index (see module docstring)."""
    st = settings or RollSettings()
    inp = sensor_inputs(drive, vehicle if st.zero_gyro else None,
                        vehicle if st.zero_steer else None)
    est = estimate_roll_index(inp, vehicle, st.identify_roll_gradient, st.roll_cutoff_hz)
    health, summary = roll_index_health(inp, est, _imu_fresh(drive))
    return Estimate(
        "roll_index",
        drive.t,
        {"roll": est.roll, "bank": est.bank, "gyro_bias": inp.gyro_bias, "health": health},
        {
            **est.params,
            "health": summary,
            "lambda_fraction": _fraction(est.lam),
            "flag_fraction": {"f": _fraction(est.f), "g": _fraction(est.g),
                              "h": _fraction(est.h), "k": _fraction(est.k)},
            "v_min_mps": V_MIN,
            "roll_cutoff_hz": st.roll_cutoff_hz,
            "flag_cutoff_hz": FLAG_CUTOFF_HZ,
            "understeer_gradient": vehicle.understeer_gradient,
            "roll_dynamics_assumed": roll_dynamics(vehicle)[2],
            **inp.gyro_zero_params(),
        },
    )


@register(
    "roll_dfc",
    columns=("wz", "ay", "steer", SPEED),
    summary="roll/bank by Tseng's dynamic factor (seed 003's comparison)",
    paper="seed 003 (eqs 46, 49-58; Tseng)",
    vehicle_params=ROLL_PARAMS[:-1],
    settings=RollSettings,
    accelerometer="cg_causal",
)
def roll_dfc(drive: Drive, vehicle: Vehicle, settings: RollSettings | None = None) -> Estimate:
    """Tseng's dynamic bank estimate as roll, and the bank without suspension roll.

    ``health`` = 1 - w (eq 58's weight: how far the method distrusts its own static bank
    estimate -- the dynamic factor says the channels disagree) while moving, 0 at rest.
    ``identify_roll_gradient`` of the settings does not apply (eq 58's roll does not use it).
    """
    st = settings or RollSettings()
    inp = sensor_inputs(drive, vehicle if st.zero_gyro else None,
                        vehicle if st.zero_steer else None)
    roll, bank, w = estimate_roll_dfc(inp, vehicle, st.roll_cutoff_hz)
    health = np.where(np.abs(inp.vx) >= V_MIN, 1.0 - w, 0.0)
    health = np.maximum(health, stale_health(inp.t, _imu_fresh(drive)))
    return Estimate(
        "roll_dfc",
        drive.t,
        {"roll": roll, "bank": bank, "gyro_bias": inp.gyro_bias, "health": health},
        {"v_min_mps": V_MIN, "roll_cutoff_hz": st.roll_cutoff_hz,
         "understeer_gradient": vehicle.understeer_gradient,
         "health": {"criterion": "1 - w of eq 58", "flagged_share": _fraction(health > 0)},
         **inp.gyro_zero_params()},
    )
