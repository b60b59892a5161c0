"""Sensor models: turn a :class:`~sideslip.simulate.truth.Truth` into the columns of a drive.

What each sensor reports (contract section 1; frames and signs as in ``sideslip.__doc__``)
-----------------------------------------------------------------------------------------
Rotation body -> ENU: ``R = rot_z(yaw) @ rot_y(pitch) @ rot_x(roll)`` (ISO angles, roll/pitch
relative to the local horizontal).  The IMU sits at ``l_imu = vehicle.imu_xyz`` and the GNSS
antenna at ``l_ant = vehicle.gnss_xyz`` (m from the CG, body axes).

* Accelerometer ``[ax, ay, az]`` (m/s^2), specific force at the IMU in sensor axes::

      f_b = R^T (acc_enu + [0, 0, g]) + d(omega_b)/dt x l_imu + omega_b x (omega_b x l_imu)
      f_m = (1 + s_a) * (C f_b) + b_a(t) + n_a

  With ``R`` as above the gravity part of ``f_b`` is ``g [-sin(pitch), sin(roll) cos(pitch),
  cos(roll) cos(pitch)]``: a positive (right-side-down) roll raises ``ay`` by about
  ``g sin(roll)``, the package convention ``a_y,m = a_y + g sin(phi)``.
* Gyro ``[wx, wy, wz]`` (rad/s): ``w_m = (1 + s_g) * (C omega_b) + b_g(t) + n_g``.
  ``C`` is the IMU mounting misalignment (a small rotation body -> sensor, shared by both
  triads), ``s`` per-axis scale-factor errors (fractions), ``b(t)`` = turn-on bias + random
  walk, ``n`` white noise.  Earth rate is neglected (below MEMS noise).
* Wheel speeds ``v_fl, v_fr, v_rl, v_rr`` (m/s): ``(1 + s_i) v_i + n``, quantised; below
  ``wheel_min_speed`` the sensor sees no pulses and reads exactly 0.  ``s_i`` is the tyre
  rolling-radius error of wheel i.
* ``v_can`` (m/s): mean of the four scaled wheel speeds (no extra noise), quantised, own rate.
* ``steer`` (rad): road-wheel angle ``(1 + s_d) delta + delta_0 + n``, quantised.
* GNSS antenna position ``gnss_e/n/u`` (m) ``= p_cg + R l_ant + e_GM + n_p (+ multipath)`` and
  Doppler velocity ``gnss_ve/vn/vu`` (m/s) ``= v_cg + R (omega_b x l_ant) + n_v
  (+ multipath)``.  ``e_GM`` is first-order Gauss-Markov per axis (time constant
  ``gnss_pos_tau_s``); multipath hits an epoch with probability ``gnss_multipath_prob``
  (large position jump, smaller velocity spike, for that epoch only); multipath *bursts*
  (``gnss_burst_rate_hz`` > 0: reflections that persist while the geometry changes slowly,
  e.g. beside a wall or under trees) start at random (Poisson, that many per second), last an
  exponentially distributed time (mean ``gnss_burst_s``) and add to every epoch inside them a
  Gauss-Markov error of position (1-sigma ``gnss_burst_pos_std`` per horizontal axis) and
  velocity (``gnss_burst_vel_std``) with correlation time ``gnss_burst_tau_s``: a run of
  moderately wrong epochs that agree with each other, which a per-epoch gate does not catch
  (multipath errors correlated over seconds in a moving vehicle: Groves, *Principles of
  GNSS, Inertial, and Multisensor Integrated Navigation Systems*, 2nd ed. 2013, sec. 9.3.5);
  outages remove every GNSS row inside ``[t0, t1)``.  ``gnss_pos_std`` / ``gnss_vel_std``
  report the nominal 1-sigma per horizontal axis (a receiver does not know about its
  multipath).  Options for loggers that differ from the vehicle file:
  ``gnss_doppler = False`` (positions only),
  ``gnss_latency_s`` (each epoch reports the truth that long before its time stamp, rounded
  to the table's step), ``gnss_lever_offset_x/y`` (the antenna is not where the vehicle
  file says).  Their defaults leave every drive as it was.

Scale factors are fractions: ``measured = (1 + scale_factor) * true + offset``; 0.02 is a 2 %
error.  (Seed 000 writes ``V = SF V_can``, i.e. its SF is ``1 / (1 + scale_factor)``.)

Sampling: a sensor at rate ``f`` samples the truth row at which ``floor((t - t0) f)`` steps up
(every row when ``f`` reaches the table rate); its other rows are NaN, so a row never repeats
an old sample.  A rate of 0 removes the sensor's columns.

Defaults match the papers' sensor grades: u-blox M8T-class single-frequency GNSS at 10 Hz
(seed 000: ~1 m drifting position error, 0.05 m/s Doppler), automotive MEMS IMU at 100 Hz
(0.1 deg/s gyro noise, ~0.2 deg/s turn-on bias), CAN wheel speeds at 50 Hz with 0.5 %
tyre-radius errors, CAN steering angle at 50 Hz (seed 001 uses 100 Hz, seed 004 50 Hz).

All randomness comes from the ``numpy.random.Generator`` passed in; the same generator state
gives the same drive.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass, fields, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.signal import lfilter

from sideslip.simulate.truth import Truth
from sideslip.vehicle import G, Vehicle

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]

_DEG = math.pi / 180.0


@dataclass(frozen=True)
class SensorConfig:
    """Sensor grades and error magnitudes (SI units; "_std" = 1-sigma of a random draw).

    Fixed errors (``gyro_scale_factor``, ``wheel_scale_factor``, ``steer_offset``,
    ``steer_scale_factor``) are added to the random draw of the same name, so a scenario can
    force e.g. a 2 % gyro scale factor (seed 001).  Use :meth:`noiseless` for an ideal set.
    """

    # --- IMU (accelerometer + gyro triads, same case) -------------------------------------
    imu_rate_hz: float = 100.0
    gyro_noise_std: float = 0.1 * _DEG  # white, rad/s per sample
    gyro_bias_std: float = 0.2 * _DEG  # turn-on bias per axis, rad/s
    gyro_bias_walk: float = 2.0e-5  # bias random walk, rad/s/sqrt(s)
    gyro_scale_factor: float = 0.0  # fixed scale-factor error, fraction (all axes)
    gyro_scale_factor_std: float = 0.002  # random per-axis scale-factor error, fraction
    accel_noise_std: float = 0.05  # white, m/s^2 per sample (incl. vibration)
    accel_bias_std: float = 0.05  # turn-on bias per axis, m/s^2 (~5 mg)
    accel_bias_walk: float = 2.0e-4  # bias random walk, m/s^2/sqrt(s)
    accel_scale_factor_std: float = 0.003  # random per-axis scale-factor error, fraction
    imu_misalignment_std: float = 0.1 * _DEG  # mounting misalignment per axis, rad
    # --- wheel speeds (CAN) -----------------------------------------------------------------
    wheel_rate_hz: float = 50.0
    wheel_scale_factor: float = 0.0  # fixed error common to all wheels, fraction
    wheel_scale_factor_std: float = 0.005  # per-wheel tyre-radius error, fraction
    wheel_noise_std: float = 0.02  # m/s
    wheel_resolution: float = 0.01  # quantisation step, m/s (0: none)
    wheel_min_speed: float = 0.1  # below this |speed| the sensor reads 0, m/s
    wheel_speed_signed: bool = True  # False: magnitudes only (many real CAN buses)
    # --- vehicle speed on CAN ---------------------------------------------------------------
    can_speed_rate_hz: float = 20.0
    can_speed_resolution: float = 0.01  # m/s
    # --- steering (road-wheel angle) ------------------------------------------------------
    steer_rate_hz: float = 50.0
    steer_offset: float = 0.0  # fixed offset, rad
    steer_offset_std: float = 0.1 * _DEG  # random offset, rad (road wheel)
    steer_scale_factor: float = 0.0  # fixed scale-factor error, fraction
    steer_scale_factor_std: float = 0.02  # random scale-factor error (steering ratio), fraction
    steer_noise_std: float = 0.01 * _DEG  # rad
    steer_resolution: float = 0.1 * _DEG / 16.0  # 0.1 deg steering-wheel step / ratio 16, rad
    # --- GNSS (u-blox M8T class, single frequency, standalone) ---------------------------
    gnss_rate_hz: float = 10.0
    gnss_pos_gm_std: float = 1.0  # Gauss-Markov position error per horizontal axis, m
    gnss_pos_gm_std_up: float = 2.0  # Gauss-Markov vertical error, m
    gnss_pos_tau_s: float = 60.0  # Gauss-Markov time constant, s
    gnss_pos_noise_std: float = 0.1  # white position noise per axis, m
    gnss_vel_std: float = 0.05  # Doppler velocity white noise per horizontal axis, m/s
    gnss_vel_std_up: float = 0.1  # vertical Doppler noise, m/s
    gnss_multipath_prob: float = 0.002  # probability that an epoch is a multipath outlier
    gnss_multipath_pos_std: float = 8.0  # position jump per horizontal axis, m
    gnss_multipath_vel_std: float = 0.5  # velocity spike per horizontal axis, m/s
    gnss_burst_rate_hz: float = 0.0  # multipath bursts starting per second of drive (0: none)
    gnss_burst_s: float = 2.0  # their mean length, s
    gnss_burst_pos_std: float = 3.0  # position error inside a burst per horizontal axis, m
    gnss_burst_vel_std: float = 0.4  # velocity error inside a burst per horizontal axis, m/s
    gnss_burst_tau_s: float = 1.0  # correlation time of the error inside a burst, s
    gnss_outages: tuple[tuple[float, float], ...] = ()  # (t0, t1) windows without GNSS, s
    gnss_doppler: bool = True  # False: positions only (no gnss_ve/vn/vu, no gnss_vel_std)
    gnss_latency_s: float = 0.0  # each epoch reports the truth this long before its stamp, s
    gnss_lever_offset_x: float = 0.0  # antenna sits this far ahead of the file's gnss_xyz, m
    gnss_lever_offset_y: float = 0.0  # ... and this far to the left, m

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name == "gnss_outages":
                for window in value:
                    ok = (
                        isinstance(window, tuple | list)
                        and len(window) == 2
                        and all(math.isfinite(float(x)) for x in window)
                        and float(window[0]) < float(window[1])
                    )
                    if not ok:
                        raise ValueError(
                            f"SensorConfig.gnss_outages: expected (t0, t1) pairs in s with "
                            f"t0 < t1, got {window!r}"
                        )
                object.__setattr__(self, "gnss_outages", tuple((float(a), float(b)) for a, b in value))
                continue
            if isinstance(value, bool):
                continue
            if not math.isfinite(value):
                raise ValueError(f"SensorConfig.{f.name} = {value!r}: expected a finite number")
            signed = f.name in (
                "gyro_scale_factor",
                "wheel_scale_factor",
                "steer_offset",
                "steer_scale_factor",
                "gnss_lever_offset_x",
                "gnss_lever_offset_y",
            )
            if not signed and value < 0:
                raise ValueError(f"SensorConfig.{f.name} = {value!r}: expected a value >= 0")
        if self.gnss_multipath_prob > 1.0:
            raise ValueError(
                f"SensorConfig.gnss_multipath_prob = {self.gnss_multipath_prob!r}: "
                "expected a probability in [0, 1]"
            )
        for name in ("gnss_pos_tau_s", "gnss_burst_s", "gnss_burst_tau_s"):
            if getattr(self, name) <= 0.0:
                raise ValueError(f"SensorConfig.{name}: expected a time > 0 s")

    @classmethod
    def noiseless(cls, **changes: Any) -> SensorConfig:
        """Ideal sensors at the default rates: no noise, bias, scale factor, quantisation,
        misalignment, multipath; wheels read down to 0 m/s.  ``changes`` override fields."""
        zero: dict[str, Any] = {
            f.name: 0.0
            for f in fields(cls)
            if f.name.endswith(("_std", "_std_up", "_walk", "_resolution"))
            and not f.name.startswith(("gnss_multipath", "gnss_burst"))  # sizes kept, rates 0
        }
        zero.update(gnss_multipath_prob=0.0, gnss_burst_rate_hz=0.0, wheel_min_speed=0.0)
        zero.update(changes)
        return cls(**zero)

    def with_overrides(self, overrides: Mapping[str, Any]) -> SensorConfig:
        """A copy with some fields replaced; an unknown field name raises ValueError."""
        known = {f.name for f in fields(self)}
        unknown = sorted(set(overrides) - known)
        if unknown:
            raise ValueError(
                f"unknown SensorConfig field(s) {', '.join(unknown)}: expected some of "
                + ", ".join(sorted(known))
            )
        return replace(self, **dict(overrides))

    def as_dict(self) -> dict[str, Any]:
        """JSON-friendly copy of the fields (outages as lists)."""
        out = asdict(self)
        out["gnss_outages"] = [list(w) for w in self.gnss_outages]
        return out


# ------------------------------------------------------------------------------------------
# helpers
# ------------------------------------------------------------------------------------------
def sample_rows(t: FloatArray, rate_hz: float) -> IntArray:
    """Rows of the time base ``t`` at which a sensor of rate ``rate_hz`` takes a sample.

    The sample instants are ``t0 + k / rate``; each is taken at the first row at or after it
    (1 ns tolerance for round-off).  Every row when the rate reaches the table rate.
    """
    if rate_hz <= 0.0 or t.size == 0:
        return np.zeros(0, dtype=np.intp)
    k = np.floor((t - t[0]) * rate_hz + 1e-9 * rate_hz)
    return np.flatnonzero(np.diff(k, prepend=-1.0) > 0)


def body_to_enu(yaw: FloatArray, pitch: FloatArray, roll: FloatArray) -> FloatArray:
    """(N, 3, 3) rotations R = rot_z(yaw) @ rot_y(pitch) @ rot_x(roll), body -> ENU."""
    cy, sy = np.cos(yaw), np.sin(yaw)
    cp, sp = np.cos(pitch), np.sin(pitch)
    cr, sr = np.cos(roll), np.sin(roll)
    r = np.empty((yaw.size, 3, 3))
    r[:, 0, 0] = cy * cp
    r[:, 0, 1] = cy * sp * sr - sy * cr
    r[:, 0, 2] = cy * sp * cr + sy * sr
    r[:, 1, 0] = sy * cp
    r[:, 1, 1] = sy * sp * sr + cy * cr
    r[:, 1, 2] = sy * sp * cr - cy * sr
    r[:, 2, 0] = -sp
    r[:, 2, 1] = cp * sr
    r[:, 2, 2] = cp * cr
    return r


def _small_rotation(angles: FloatArray) -> FloatArray:
    """Sensor-from-body rotation for misalignment angles (x, y, z), rad: (Rz Ry Rx)^T."""
    r = body_to_enu(np.array([angles[2]]), np.array([angles[1]]), np.array([angles[0]]))[0]
    return np.asarray(r.T)


def _quantise(x: FloatArray, step: float) -> FloatArray:
    return np.round(x / step) * step if step > 0.0 else x


def _random_walk(rng: np.random.Generator, n: int, dt: FloatArray, sigma: float) -> FloatArray:
    """(n, 3) random walk starting at 0 with increments N(0, sigma^2 dt)."""
    if sigma <= 0.0 or n == 0:
        return np.zeros((n, 3))
    steps = rng.standard_normal((n, 3)) * (sigma * np.sqrt(dt))[:, None]
    steps[0] = 0.0
    return np.cumsum(steps, axis=0)


def _gauss_markov(rng: np.random.Generator, n: int, dt: float, tau: float, sigma: FloatArray) -> FloatArray:
    """(n, k) stationary first-order Gauss-Markov sequences with std ``sigma`` (k,)."""
    k = sigma.size
    if n == 0:
        return np.zeros((0, k))
    a = math.exp(-dt / tau)
    x0 = rng.standard_normal(k) * sigma
    w = rng.standard_normal((n, k)) * sigma * math.sqrt(1.0 - a * a)
    out, _ = lfilter([1.0], [1.0, -a], w, axis=0, zi=(a * x0)[None, :])
    return np.asarray(out)


def cg_velocity_enu(truth: Truth) -> FloatArray:
    """(N, 3) CG velocity in ENU, m/s: rot_z(yaw) [vx, vy] and du/dt (heading-frame truth)."""
    c, s = np.cos(truth.yaw), np.sin(truth.yaw)
    vu = np.gradient(truth.u, truth.t) if truth.t.size > 1 else np.zeros_like(truth.u)
    return np.column_stack([c * truth.vx - s * truth.vy, s * truth.vx + c * truth.vy, vu])


# ------------------------------------------------------------------------------------------
# the sensors
# ------------------------------------------------------------------------------------------
def imu(
    truth: Truth, vehicle: Vehicle, config: SensorConfig, rng: np.random.Generator
) -> tuple[dict[str, FloatArray], dict[str, Any]]:
    """Accelerometer and gyro columns (see module docstring) and the drawn errors."""
    n = truth.t.size
    rows = sample_rows(truth.t, config.imu_rate_hz)
    rot = body_to_enu(truth.yaw, truth.pitch, truth.roll)
    omega = np.asarray(truth.omega_body, dtype=float)
    omega_dot = np.gradient(omega, truth.t, axis=0) if n > 1 else np.zeros_like(omega)
    lever = np.asarray(vehicle.imu_xyz, dtype=float)
    acc = np.asarray(truth.acc_enu, dtype=float) + np.array([0.0, 0.0, G])
    f_body = np.einsum("nji,nj->ni", rot, acc)  # R^T (a + g e_z)
    f_body += np.cross(omega_dot, lever) + np.cross(omega, np.cross(omega, lever))

    misalign = rng.standard_normal(3) * config.imu_misalignment_std
    c_sb = _small_rotation(misalign)
    gyro_sf = config.gyro_scale_factor + rng.standard_normal(3) * config.gyro_scale_factor_std
    accel_sf = rng.standard_normal(3) * config.accel_scale_factor_std
    gyro_b0 = rng.standard_normal(3) * config.gyro_bias_std
    accel_b0 = rng.standard_normal(3) * config.accel_bias_std

    ts = truth.t[rows]
    dts = np.diff(ts, prepend=ts[0]) if ts.size else ts
    gyro_bias = gyro_b0 + _random_walk(rng, rows.size, dts, config.gyro_bias_walk)
    accel_bias = accel_b0 + _random_walk(rng, rows.size, dts, config.accel_bias_walk)
    gyro = (1.0 + gyro_sf) * (omega[rows] @ c_sb.T) + gyro_bias
    gyro += rng.standard_normal((rows.size, 3)) * config.gyro_noise_std
    accel = (1.0 + accel_sf) * (f_body[rows] @ c_sb.T) + accel_bias
    accel += rng.standard_normal((rows.size, 3)) * config.accel_noise_std

    cols: dict[str, FloatArray] = {}
    for k, name in enumerate(("ax", "ay", "az")):
        cols[name] = np.full(n, np.nan)
        cols[name][rows] = accel[:, k]
    for k, name in enumerate(("wx", "wy", "wz")):
        cols[name] = np.full(n, np.nan)
        cols[name][rows] = gyro[:, k]
    level = (1.0 + accel_sf) * (c_sb @ np.array([0.0, 0.0, G])) + accel_b0 - np.array([0, 0, G])
    drawn = {
        "gyro_bias": gyro_b0.tolist(),
        "gyro_bias_mean": (gyro_bias.mean(axis=0) if rows.size else gyro_b0).tolist(),
        "gyro_scale_factor": float(gyro_sf[2]),
        "gyro_scale_factor_xyz": gyro_sf.tolist(),
        "accel_bias": accel_b0.tolist(),
        "accel_bias_mean": (accel_bias.mean(axis=0) if rows.size else accel_b0).tolist(),
        "accel_scale_factor_xyz": accel_sf.tolist(),
        "imu_misalignment": misalign.tolist(),
        # What the accelerometer reads at level standstill minus the truth [0, 0, g]: the
        # offset a constant-bias estimator of a_y should find (bias + misalignment x g).
        "accel_offset_level": level.tolist(),
        "ay_bias_level": float(level[1]),
    }
    return cols, drawn


def wheel_speeds(
    truth: Truth, config: SensorConfig, rng: np.random.Generator
) -> tuple[dict[str, FloatArray], dict[str, Any]]:
    """Wheel-speed columns v_fl, v_fr, v_rl, v_rr and v_can (see module docstring)."""
    n = truth.t.size
    scale = config.wheel_scale_factor + rng.standard_normal(4) * config.wheel_scale_factor_std
    scaled = np.asarray(truth.wheel_speed, dtype=float) * (1.0 + scale)
    cols: dict[str, FloatArray] = {}
    rows = sample_rows(truth.t, config.wheel_rate_hz)
    if rows.size:
        meas = scaled[rows] + rng.standard_normal((rows.size, 4)) * config.wheel_noise_std
        meas = _quantise(meas, config.wheel_resolution)
        meas[np.abs(scaled[rows]) < config.wheel_min_speed] = 0.0
        if not config.wheel_speed_signed:
            meas = np.abs(meas)
        for k, name in enumerate(("v_fl", "v_fr", "v_rl", "v_rr")):
            cols[name] = np.full(n, np.nan)
            cols[name][rows] = meas[:, k] + 0.0  # + 0.0 turns -0.0 into 0.0
    can_rows = sample_rows(truth.t, config.can_speed_rate_hz)
    if can_rows.size:
        v_can = _quantise(scaled[can_rows].mean(axis=1), config.can_speed_resolution)
        if not config.wheel_speed_signed:
            v_can = np.abs(v_can)
        cols["v_can"] = np.full(n, np.nan)
        cols["v_can"][can_rows] = v_can + 0.0
    drawn = {"wheel_scale_factor": scale.tolist(), "can_scale_factor": float(scale.mean())}
    return cols, drawn


def steering(
    truth: Truth, config: SensorConfig, rng: np.random.Generator
) -> tuple[dict[str, FloatArray], dict[str, Any]]:
    """The ``steer`` column: road-wheel angle with offset, scale factor, noise, quantisation."""
    offset = config.steer_offset + rng.standard_normal() * config.steer_offset_std
    scale = config.steer_scale_factor + rng.standard_normal() * config.steer_scale_factor_std
    drawn = {"steer_offset": float(offset), "steer_scale_factor": float(scale)}
    rows = sample_rows(truth.t, config.steer_rate_hz)
    if not rows.size:
        return {}, drawn
    meas = (1.0 + scale) * truth.steer[rows] + offset
    meas = _quantise(meas + rng.standard_normal(rows.size) * config.steer_noise_std, config.steer_resolution)
    col = np.full(truth.t.size, np.nan)
    col[rows] = meas
    return {"steer": col}, drawn


def gnss(
    truth: Truth, vehicle: Vehicle, config: SensorConfig, rng: np.random.Generator
) -> tuple[dict[str, FloatArray], dict[str, Any]]:
    """GNSS antenna position and Doppler velocity (see module docstring)."""
    n = truth.t.size
    epochs = sample_rows(truth.t, config.gnss_rate_hz)
    if not epochs.size:
        return {}, {"gnss_multipath_epochs": 0}
    # the truth an epoch reports: latency rounded to the table's step (rows before the stamp)
    src = epochs
    if config.gnss_latency_s > 0.0 and truth.t.size > 1:
        lag_rows = round(config.gnss_latency_s / float(np.median(np.diff(truth.t))))
        src = np.maximum(epochs - lag_rows, 0)
    rot = body_to_enu(truth.yaw[src], truth.pitch[src], truth.roll[src])
    lever = np.asarray(vehicle.gnss_xyz, dtype=float)
    if config.gnss_lever_offset_x or config.gnss_lever_offset_y:
        lever = lever + np.array([config.gnss_lever_offset_x, config.gnss_lever_offset_y, 0.0])
    omega = np.asarray(truth.omega_body, dtype=float)[src]
    pos = np.column_stack([truth.e, truth.n, truth.u])[src] + rot @ lever
    vel = cg_velocity_enu(truth)[src] + np.einsum("nij,nj->ni", rot, np.cross(omega, lever))

    m = epochs.size
    sigma_gm = np.array([config.gnss_pos_gm_std, config.gnss_pos_gm_std, config.gnss_pos_gm_std_up])
    pos += _gauss_markov(rng, m, 1.0 / config.gnss_rate_hz, config.gnss_pos_tau_s, sigma_gm)
    pos += rng.standard_normal((m, 3)) * config.gnss_pos_noise_std
    sigma_v = np.array([config.gnss_vel_std, config.gnss_vel_std, config.gnss_vel_std_up])
    vel += rng.standard_normal((m, 3)) * sigma_v
    hit = rng.random(m) < config.gnss_multipath_prob
    n_hit = int(hit.sum())
    if n_hit:
        up = np.array([1.0, 1.0, 2.0])  # multipath is worse vertically
        pos[hit] += rng.standard_normal((n_hit, 3)) * config.gnss_multipath_pos_std * up
        vel[hit] += rng.standard_normal((n_hit, 3)) * config.gnss_multipath_vel_std * up
    in_burst = np.zeros(m, dtype=bool)
    if config.gnss_burst_rate_hz > 0.0:  # drawn only when asked: other drives keep their bits
        in_burst = _multipath_bursts(rng, truth.t[epochs], config, pos, vel)

    keep = np.ones(m, dtype=bool)
    te = truth.t[epochs]
    for t0, t1 in config.gnss_outages:
        keep &= ~((te >= t0) & (te < t1))
    rows = epochs[keep]
    cols: dict[str, FloatArray] = {}
    names = ("gnss_e", "gnss_n", "gnss_u", "gnss_ve", "gnss_vn", "gnss_vu")
    values = np.column_stack([pos, vel])[keep]
    for k, name in enumerate(names):
        cols[name] = np.full(n, np.nan)
        cols[name][rows] = values[:, k]
    pos_std = math.hypot(config.gnss_pos_gm_std, config.gnss_pos_noise_std)
    cols["gnss_pos_std"] = np.where(np.isfinite(cols["gnss_e"]), pos_std, np.nan)
    cols["gnss_vel_std"] = np.where(np.isfinite(cols["gnss_e"]), config.gnss_vel_std, np.nan)
    if not config.gnss_doppler:
        for name in ("gnss_ve", "gnss_vn", "gnss_vu", "gnss_vel_std"):
            del cols[name]
    drawn = {
        "gnss_multipath_epochs": int((hit & keep).sum()),
        "gnss_multipath_t": truth.t[epochs[hit & keep]].round(6).tolist()[:1000],
    }
    if config.gnss_burst_rate_hz > 0.0:
        drawn["gnss_burst_epochs"] = int((in_burst & keep).sum())
        drawn["gnss_burst_t"] = truth.t[epochs[in_burst & keep]].round(6).tolist()[:1000]
    return cols, drawn


def _multipath_bursts(
    rng: np.random.Generator, te: FloatArray, config: SensorConfig, pos: FloatArray, vel: FloatArray
) -> NDArray[np.bool_]:
    """Add multipath bursts (module docstring) to the epochs at times ``te`` in place; returns
    which epochs lie inside a burst.  Starts: a Poisson process of rate gnss_burst_rate_hz;
    lengths: exponential, mean gnss_burst_s; errors: horizontal Gauss-Markov per burst
    (stationary from its first epoch), vertical twice the horizontal."""
    span = float(te[-1] - te[0]) if te.size else 0.0
    n_bursts = int(rng.poisson(config.gnss_burst_rate_hz * span)) if span > 0 else 0
    starts = np.sort(rng.uniform(te[0], te[-1], n_bursts)) if n_bursts else np.zeros(0)
    lengths = rng.exponential(config.gnss_burst_s, n_bursts)
    inside = np.zeros(te.size, dtype=bool)
    up = np.array([1.0, 1.0, 2.0])
    dt = 1.0 / config.gnss_rate_hz
    for t0, length in zip(starts, lengths, strict=True):
        k = np.flatnonzero((te >= t0) & (te < t0 + length))
        if not k.size:
            continue
        inside[k] = True
        pos[k] += _gauss_markov(rng, k.size, dt, config.gnss_burst_tau_s, config.gnss_burst_pos_std * up)
        vel[k] += _gauss_markov(rng, k.size, dt, config.gnss_burst_tau_s, config.gnss_burst_vel_std * up)
    return inside


def reference_columns(truth: Truth) -> dict[str, FloatArray]:
    """The reference (truth) columns of contract section 1.

    ``ref_beta = atan2(vy, vx)`` at the CG; ``ref_yaw`` the unwrapped body heading;
    ``ref_roll`` total body roll relative to the horizontal (= bank + suspension roll);
    ``ref_vx``/``ref_vy``/``ref_ay`` in the heading frame (``ref_ay = dvy/dt + r vx``,
    gravity-free); ``ref_e/n/u`` the CG position.
    """
    return {
        "ref_beta": np.asarray(truth.beta, dtype=float),
        "ref_yaw": np.asarray(truth.yaw, dtype=float),
        "ref_roll": np.asarray(truth.roll, dtype=float),
        "ref_pitch": np.asarray(truth.pitch, dtype=float),
        "ref_bank": np.asarray(truth.bank, dtype=float),
        "ref_e": np.asarray(truth.e, dtype=float),
        "ref_n": np.asarray(truth.n, dtype=float),
        "ref_u": np.asarray(truth.u, dtype=float),
        "ref_vx": np.asarray(truth.vx, dtype=float),
        "ref_vy": np.asarray(truth.vy, dtype=float),
        "ref_r": np.asarray(truth.r, dtype=float),
        "ref_ay": np.asarray(truth.ay, dtype=float),
    }


def sensor_columns(
    truth: Truth, vehicle: Vehicle, config: SensorConfig, rng: np.random.Generator
) -> tuple[dict[str, FloatArray], dict[str, Any]]:
    """Every sensor and reference column for ``truth`` plus the true sensor errors drawn.

    Returns ``(columns, truth_sensor)``: ``columns`` maps contract names (``t`` included) to
    arrays on the truth time base; ``truth_sensor`` is JSON-friendly.  Draw order is fixed
    (IMU, wheels, steering, GNSS) so a seed always gives the same drive.
    """
    cols: dict[str, FloatArray] = {"t": np.asarray(truth.t, dtype=float)}
    drawn: dict[str, Any] = {
        "convention": "measured = (1 + scale_factor) * true + bias/offset + noise; "
        "angles rad, rates rad/s, accelerations m/s^2, speeds m/s",
    }
    for part in (
        imu(truth, vehicle, config, rng),
        wheel_speeds(truth, config, rng),
        steering(truth, config, rng),
        gnss(truth, vehicle, config, rng),
    ):
        cols.update(part[0])
        drawn.update(part[1])
    cols.update(reference_columns(truth))
    return cols, drawn
