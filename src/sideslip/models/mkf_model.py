"""Seed 001's model-based Kalman filter (MKF) model: continuous matrices, the per-row discrete
model table, and the steady-state accuracy of its Table I.

State x = [beta (rad), r (rad/s), psi (rad), b_gyro (rad/s)]; input u = [delta (front
road-wheel angle, rad), bank (rad, roll sign)].  Dynamics: the linear single-track model of
:mod:`sideslip.models.single_track` (seed 001 eq 1) with psi' = r and b' = w_b (random walk).
Process noise w = [w_delta (through the steering column of B), w_beta, w_r] plus the bias walk.

Measurements (seed 001 eq 5): gyro  w_z = r + b_gyro  (H = [0 1 0 1]); GNSS course
nu = psi + beta + (rx / V) r  (H = [1 rx/V 1 0], rx the antenna's forward lever arm).

Below ``v_gate`` or reversing the single-track dynamics (singular at V = 0) are replaced by the
kinematic relation beta -> lr/L delta (first order, time constant :data:`TAU_LOW_S`) with a
random-walk yaw rate carried by the gyro (:func:`low_speed_continuous`).

Exact discretisation of every row step (A_d = exp(A T), B_d by the zero-order-hold integral,
Q_d by Van Loan instead of the paper's first-order Q_d ~ B_w Q_c B_w' T;
:mod:`sideslip.filters.discretise`), tabulated over the distinct (speed, T) pairs of the drive
with the speed quantised to :data:`SPEED_LOG_STEP` (0.2 % relative).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from sideslip.filters.discretise import discretise_batch
from sideslip.filters.kalman import steady_state
from sideslip.models.single_track import continuous_arrays, van_loan
from sideslip.vehicle import Vehicle

FloatArray = NDArray[np.float64]

V_GATE = 3.0  # m/s: single-track model (and GNSS course) used above this speed only
TAU_LOW_S = 0.3  # s: low-speed beta relaxes to the kinematic lr/L delta with this time constant
SPEED_LOG_STEP = 0.002  # speed quantisation of the discretised model (0.2 % relative)
BETA_LOW_PSD = math.radians(2.0) ** 2  # rad^2/s: low-speed kinematic beta
YAW_RATE_LOW_PSD = 1.0  # (rad/s)^2/s: low speed, r carried by the gyro alone
H_GYRO = np.array([0.0, 1.0, 0.0, 1.0])


@dataclass(frozen=True)
class MkfNoise:
    """Continuous process-noise power spectral densities of the MKF.

    ``steer_psd`` rad^2 s (steering input / tyre-force model error, through B);
    ``beta_psd`` rad^2/s (lateral force disturbance: wind, bank, grade); ``yaw_accel_psd``
    (rad/s)^2/s (yaw moment disturbance); ``gyro_bias_psd`` (rad/s)^2/s (bias random walk).
    Defaults: typical automotive values (not fitted to any drive).
    """

    steer_psd: float = math.radians(0.3) ** 2
    beta_psd: float = math.radians(0.1) ** 2
    yaw_accel_psd: float = math.radians(1.0) ** 2
    gyro_bias_psd: float = math.radians(0.005) ** 2

    def scaled(self, factor: float) -> MkfNoise:
        """The model-error densities (steer, beta, yaw) times ``factor``; bias walk unchanged."""
        return MkfNoise(
            self.steer_psd * factor, self.beta_psd * factor, self.yaw_accel_psd * factor,
            self.gyro_bias_psd,
        )  # fmt: skip


def mkf_continuous(
    vehicle: Vehicle, speed: NDArray, noise: MkfNoise = MkfNoise()
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Continuous 4-state MKF matrices at N speeds: A (N,4,4), B (N,4,2), Qc (N,4,4)."""
    a2, b2, _, _ = continuous_arrays(vehicle, speed)
    n = a2.shape[0]
    A = np.zeros((n, 4, 4))
    A[:, :2, :2] = a2
    A[:, 2, 1] = 1.0
    B = np.zeros((n, 4, 2))
    B[:, :2, :] = b2
    Gw = np.zeros((n, 4, 3))
    Gw[:, :2, 0] = b2[:, :, 0]
    Gw[:, 0, 1] = 1.0
    Gw[:, 1, 2] = 1.0
    qd = np.diag([noise.steer_psd, noise.beta_psd, noise.yaw_accel_psd])
    Qc = Gw @ qd @ np.transpose(Gw, (0, 2, 1))
    Qc[:, 3, 3] = noise.gyro_bias_psd
    return A, B, Qc


def low_speed_continuous(
    vehicle: Vehicle, noise: MkfNoise
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Low-speed model: beta' = (lr/L delta - beta) / TAU_LOW_S, psi' = r, r random walk."""
    A = np.zeros((4, 4))
    A[0, 0] = -1.0 / TAU_LOW_S
    A[2, 1] = 1.0
    B = np.zeros((4, 2))
    B[0, 0] = vehicle.lr / vehicle.wheelbase / TAU_LOW_S
    Qc = np.diag([BETA_LOW_PSD, YAW_RATE_LOW_PSD, 0.0, noise.gyro_bias_psd])
    return A, B, Qc


@dataclass(frozen=True)
class ModelTable:
    """Discrete models for each row step: ``Ad``/``Bd``/``Qd`` (K,4,4)/(K,4,2)/(K,4,4),
    ``idx[k]`` the entry propagating row k-1 to k, ``low`` rows in the low-speed mode.

    ``Qd_parts`` (3,K,4,4): the discrete process noise split by source, Q_d being linear in
    Q_c (Van Loan): [0] steering + yaw-moment densities, [1] the sideslip density, [2] the
    rest (gyro-bias walk, low-speed model); ``Qd`` = their sum, :meth:`scaled_qd` rescales.
    None when the table was built with ``split=False`` (no noise tuning).
    """

    Ad: FloatArray
    Bd: FloatArray
    Qd: FloatArray
    idx: NDArray[np.intp]
    low: NDArray[np.bool_]
    Qd_parts: FloatArray | None

    def scaled_qd(self, steer_yaw_factor: float, beta_factor: float) -> FloatArray:
        """Q_d with the steering/yaw and sideslip densities times the given factors."""
        if self.Qd_parts is None:
            raise ValueError("model_table(split=False) keeps no Qd_parts to rescale")
        q = steer_yaw_factor * self.Qd_parts[0] + beta_factor * self.Qd_parts[1] + self.Qd_parts[2]
        return np.ascontiguousarray(q)


def model_table(
    vehicle: Vehicle, t: FloatArray, speed: FloatArray, noise: MkfNoise, v_gate: float = V_GATE,
    split: bool = True,
) -> ModelTable:
    """Discretised models for each row step, tabulated by (quantised log-speed, dt).

    ``split``: also keep Q_d by noise source (``ModelTable.Qd_parts``, for the noise tuning;
    three discretisations of the table instead of one)."""
    dt = np.diff(t, prepend=t[0])
    dt[0] = 0.0
    v_prev = np.concatenate(([speed[0]], speed[:-1]))
    low = (np.abs(v_prev) < v_gate) | (v_prev < 0)
    vbin = np.where(low, -1, np.round(np.log(np.maximum(np.abs(v_prev), v_gate)) / SPEED_LOG_STEP))
    dbin = np.round(dt * 1e6)
    keys = (vbin + 2.0) * 2.0**32 + dbin  # exact in float64: both parts are small integers
    # hash-based, O(n) (np.unique sorts all n keys); sort=True orders the K entries as np.unique
    inv, ukeys = pd.factorize(keys, sort=True)
    del keys, vbin, dbin, v_prev
    uniq = np.stack([np.floor(ukeys / 2.0**32) - 2.0, np.mod(ukeys, 2.0**32)], axis=1)
    k = uniq.shape[0]
    A = np.zeros((k, 4, 4))
    B = np.zeros((k, 4, 2))
    n_src = 3 if split else 1
    Qc = np.zeros((n_src, k, 4, 4))  # by source: steer + yaw, beta, rest (ModelTable.Qd_parts)
    sources = (
        MkfNoise(noise.steer_psd, 0.0, noise.yaw_accel_psd, 0.0),
        MkfNoise(0.0, noise.beta_psd, 0.0, 0.0),
        MkfNoise(0.0, 0.0, 0.0, noise.gyro_bias_psd),
    ) if split else (noise,)  # fmt: skip
    fast = uniq[:, 0] >= 0
    if fast.any():
        speeds = np.exp(uniq[fast, 0] * SPEED_LOG_STEP)
        for i, part in enumerate(sources):
            a, b, q = mkf_continuous(vehicle, speeds, part)
            A[fast], B[fast], Qc[i, fast] = a, b, q
    if (~fast).any():
        a, b, q = low_speed_continuous(vehicle, noise)
        A[~fast], B[~fast], Qc[n_src - 1, ~fast] = a, b, q
    dt = uniq[:, 1] * 1e-6
    # one batch: the noise sources share A (Q_d is linear in Q_c)
    Ad3, Bd3, Qd3 = discretise_batch(
        np.concatenate([A] * n_src), np.concatenate([B] * n_src), Qc.reshape(n_src * k, 4, 4),
        np.concatenate([dt] * n_src),
    )  # fmt: skip
    parts = np.ascontiguousarray(Qd3.reshape(n_src, k, 4, 4))
    Ad, Bd = np.ascontiguousarray(Ad3[:k]), np.ascontiguousarray(Bd3[:k])
    Qd = np.ascontiguousarray(parts.sum(axis=0))
    return ModelTable(Ad, Bd, Qd, inv.astype(np.intp, copy=False), low, parts if split else None)


# ==========================================================================================
# seed 001 Table I: steady-state accuracy from the discrete Riccati equation
# ==========================================================================================
TABLE_I_RATES = (5.0, 20.0, 50.0, 100.0)
TABLE_I_SPEED = 30.0
# Measurement noise at 100 Hz from seed 001 Table I's 100 Hz row.  The extracted header reads
# "sigma_beta_hat (deg), sigma_r_hat (deg/s), sigma_r (deg/s), sigma_nu (deg)": we take the
# third and fourth columns as the sensor noises (gyro 0.3 deg/s, GPS course 0.0382 deg) and the
# first two as the filter's predicted errors -- the only reading where the estimated yaw rate
# (0.2845) is better than the gyro (0.3), as a filter's must be.
TABLE_I_SIGMA_GYRO_100HZ = math.radians(0.3)
TABLE_I_SIGMA_COURSE_100HZ = math.radians(0.0382)
# seed 001 Table I as printed: sigma_beta_hat (deg), sigma_r_hat (deg/s), sigma_r gyro (deg/s),
# sigma_nu course (deg)
TABLE_I_PAPER = {
    5.0: (0.0348, 0.0636, 0.0671, 0.0086),
    20.0: (0.0697, 0.1272, 0.1342, 0.0171),
    50.0: (0.1101, 0.2012, 0.2121, 0.0270),
    100.0: (0.1558, 0.2845, 0.3, 0.0382),
}


@dataclass(frozen=True)
class TableIModel:
    """The MKF's time-invariant discrete model at one speed and rate (for Table I)."""

    F: FloatArray
    G: FloatArray
    Q: FloatArray
    H: FloatArray
    R: FloatArray


def table_one_model(
    vehicle: Vehicle,
    rate_hz: float,
    speed: float = TABLE_I_SPEED,
    sigma_gyro_100hz: float = TABLE_I_SIGMA_GYRO_100HZ,
    sigma_course_100hz: float = TABLE_I_SIGMA_COURSE_100HZ,
    noise: MkfNoise = MkfNoise(),
) -> TableIModel:
    """Discrete MKF model at ``speed`` sampled at ``rate_hz``; both measurements every sample,
    their noise 1-sigma growing as sqrt(rate) (fixed noise density)."""
    A, B, Qc = mkf_continuous(vehicle, np.array([speed]), noise)
    dt = 1.0 / rate_hz
    Ad, Qd = van_loan(A[0], Qc[0], dt)
    _, Bd, _ = discretise_batch(A, B, Qc, np.array([dt]))
    H = np.array([H_GYRO, [1.0, 0.0, 1.0, 0.0]])
    f = math.sqrt(rate_hz / 100.0)
    R = np.diag([(sigma_gyro_100hz * f) ** 2, (sigma_course_100hz * f) ** 2])
    return TableIModel(Ad, Bd[0], Qd, H, R)


def table_one(
    vehicle: Vehicle,
    rates: tuple[float, ...] = TABLE_I_RATES,
    speed: float = TABLE_I_SPEED,
    noise: MkfNoise = MkfNoise(),
) -> list[dict[str, float]]:
    """Seed 001 Table I: steady-state 1-sigma (after the update) of beta, r, psi and b_gyro at
    each rate, with the measurement 1-sigmas, in degrees (deg/s for rates)."""
    rows = []
    for rate in rates:
        m = table_one_model(vehicle, rate, speed, noise=noise)
        ss = steady_state(m.F, m.H, m.Q, m.R)
        sd = np.degrees(np.sqrt(np.diag(ss.P_post)))
        rows.append(
            {
                "rate_hz": float(rate),
                "sigma_gyro_deg_s": float(np.degrees(np.sqrt(m.R[0, 0]))),
                "sigma_course_deg": float(np.degrees(np.sqrt(m.R[1, 1]))),
                "sigma_beta_deg": float(sd[0]),
                "sigma_r_deg_s": float(sd[1]),
                "sigma_yaw_deg": float(sd[2]),
                "sigma_bias_deg_s": float(sd[3]),
            }
        )
    return rows
