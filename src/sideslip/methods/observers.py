"""Sideslip observers of seed 003 (IEEE Access 2020, Sec. II): bicycle, kinematic, modified.

Four registered methods, all causal, all at the IMU rate (the drive's rows):

``obs_bicycle`` -- simple bicycle-model Luenberger observer (eqs 10-17)
    state x = [beta (rad), r (rad/s)], input u = delta (front road-wheel angle, rad), output
    y = r (gyro ``wz``, rad/s).  x' = A(v) x + B(v) u + K_b (y - C x), C = [0, 1]; gains by
    pole placement with both poles at ``P_BICYCLE`` at every speed
    (:func:`sideslip.filters.pole_placement.single_output_gain`; eqs 16-17 are garbled in the
    paper, so re-derived).  Reads no accelerometer: immune to roll/bank in a_y, but exposed to
    model error (cornering stiffness, road friction) and to the road bank's side force.
    beta is seen through r only via a21 = (cr lr - cf lf)/I_z, and the full placement reads
    a yaw-moment model error e (rad/s^2: tyres past their linear range, a wrong yaw inertia)
    as a steady beta error (p - a11)^2 e / (a21 p^2), about e / |a21|, where the open-loop
    model's own is |a12| e / |det A|, about e / (a11 a22) for a near-neutral car (derived
    here from the steady states of the error dynamics).  So the double pole is placed at
    ``P_BICYCLE`` only where |a21| >= |a11 a22| / ``YAW_ERROR_GAIN`` (the observer makes at
    most 3x the model's own sideslip of such an error); below, it moves towards the model's
    own sideslip pole a11 = -(cf + cr)/(m v_x) in proportion
    (:func:`~sideslip.filters.pole_placement.reachable_pole`), and for a neutral car beta
    follows the model.  a11 a22 falls as 1/v_x^2: the model alone is trusted most at low
    speed.  The earlier rule (full placement beyond 3 % of cf lf + cr lr at every speed) blew
    up on a CommonRoad file made rough (near neutral, 3.0 %): cr_limit_slalom 7.10 deg,
    cr_limit_ramp 7.50 (now 0.70 / 1.33).  Measured (16 comparison scenarios, seed 0, mean
    beta RMSE right / 30 %-soft / rough file; the real Revs lap right / soft), gain 10 / 3 /
    1: 0.366 / 0.436 / 0.675, Revs 0.595 / 0.708; 0.362 / 0.422 / 0.439, Revs 0.622 / 0.708;
    0.346 / 0.393 / 0.421, Revs 0.932 / 0.503 (old rule 0.367 / 0.436 / 1.214, Revs 0.595 /
    0.708).  A gain of 1 costs the real lap half again with its own file; 3 costs it 5 % and
    ends the blow-up.

``obs_kinematic`` -- kinematic observer (eqs 18-30)
    state x = [v_x, v_y] (m/s), inputs u = [a_x, a_y] (m/s^2, a_y compensated for roll as the
    paper assumes, by the roll index), output y = v_x from the undriven (rear) wheel speeds,
    else all wheels, else ``v_can``.  v_x' = r v_y + a_x, v_y' = -r v_x + a_y; frozen-time
    gains K1 = 2 alpha |r|, K2 = (alpha^2 - 1) r put the poles at -alpha |r| (eq 23).
    Between wheel samples the state is propagated exactly (a rotation by r dt plus the
    integrated input); at a fresh wheel sample the correction K (y - v_x) is applied over the
    time since the previous sample.  beta = atan2(v_y, v_x).
    r -> 0: with r = 0 the lateral velocity is unobservable (the output matrix loses rank and
    K2 = 0), and v_x would go uncorrected.  Two documented changes: K1 uses
    max(|r|, ``R_OBSERVABLE``) so v_x keeps tracking the wheels (poles stay in the left half
    plane: s^2 + K1 s + alpha^2 r^2), and v_y is pulled towards 0 with time constant
    ``TAU_STRAIGHT`` scaled by max(0, 1 - |r|/R_OBSERVABLE) -- straight driving has beta ~ 0 --
    which bounds the drift of an uncorrected accelerometer bias when nothing corrects it.
    Sensitivity (steady state of eqs 21-22 in a constant turn, derived here): accelerometer
    biases b_x, b_y and a wheel-speed error s leave v_y off by
    b_x/r - (2/alpha) b_y/|r| + (2/alpha) sign(r) s, which is why the paper calls the
    kinematic model "not robust to the sensor error".  ``ALPHA`` = 2 (the paper gives no
    value): larger alpha shrinks the b_y and s terms but not b_x/r, and K2 = (alpha^2 - 1) r
    then amplifies the wheel-speed noise.

``obs_modified`` -- the paper's modified bicycle observer (eqs 31-39), with compensation
    state x = [beta, r], input delta, outputs y = [r, a_y] with the gravity-free a_y =
    a_ym - g sin(roll) (eq 62 restated in our sign: the paper writes a_ym + g sin(Phi) with
    its Phi = minus our roll), roll from the ``roll_index`` estimator (eq 61).
    a_y = v_x (beta' + r) = C2 x + D2 delta with C2 = [-(cf+cr)/m, (cr lr - cf lf)/(m v_x)],
    D2 = cf/m (per-axle stiffness; eq 32).  K12 = 1/v_x makes the beta error obey
    beta~' = -(1 + K11) r~ (eq 36); the other gains put both poles at ``P_MODIFIED``
    (:func:`sideslip.filters.pole_placement.two_output_gain`, K22 = a22/c22 as in eq 37).
    Road bank, re-derived: eq 32 is the tyre force over m, while the gravity-free a_y on a
    road banked by ``phi_b`` is tyre force / m - g sin(phi_b) (the bank term the paper keeps
    in its own eq 47).  So the estimated bank (roll index roll minus eq-41 suspension roll)
    enters as a known input u = [delta, sin(phi_b)] with B = [..., -g/v_x] and
    D = [..., -g] (:func:`sideslip.models.single_track.continuous_arrays`).  With
    K12 = 1/v_x the bank drops out of the beta row (beta' = a_y/v_x - r + ...), as eq 38;
    it corrects the yaw-rate row, which otherwise reads the bank's gravity as tyre force and
    feeds that error back into beta through (1 + K11).  On a level road it changes nothing.
``obs_modified_nocomp`` -- the same fed with the uncompensated a_ym and no bank (the paper's
    mod-bic-w/g): the flat-road model of eqs 31-39 as printed.

Pole choice (the paper gives no value): -20 rad/s for both bicycle observers.  The
single-track model's own poles lie at about -8 to -15 rad/s at road speeds (seed 003's car at
80 km/h: -11 +- 2i); an observer no faster than its plant is nearly an open-loop model and
inherits all of the model's error, so the poles are set at about twice the plant's speed
(time constant 50 ms, still far inside the 100 Hz IMU's bandwidth).

Outputs: ``beta`` (rad, CG), ``r`` (rad/s: the observer's r_hat for ``obs_bicycle``; the zeroed
gyro for the modified observers, whose r_hat absorbs the mismatch between a_y and the model by
design -- eq 36 frees the beta error from the model precisely by letting r~ carry it -- and is
no yaw-rate estimate), ``gyro_bias`` (the gyro zeroing), and for the observers that run
the roll index ``roll`` and ``bank``; ``vx``, ``vy`` for ``obs_kinematic``.

Discretisation: the closed-loop matrix A - K C has the double eigenvalue p by construction, so
each step is exact (e^{p dt}(I + N dt), :func:`~sideslip.filters.pole_placement.double_pole_step`)
with the input and measurement held over the step.  Rows without a fresh gyro (or, for the
modified observer, accelerometer) sample propagate the model open-loop (RK4, sub-stepped).

Low speed, standstill, reversing: the model matrices use max(|v_x|, ``V_GATE``).  Below
``V_GATE`` (or reversing) the observers are not run: the state is set to the kinematic
(no-slip) bicycle value beta = atan2(v_x l_r tan(delta)/L, v_x) (about pi when reversing,
following beta = atan2(v_y, v_x)), r = measured, and the observer restarts from there when the
speed rises again.  The state is clipped to |beta| <= 1.2 rad, |r| <= 5 rad/s; every output is
finite on every row.  The gyro is zeroed at standstill (see
:func:`sideslip.methods.roll_index.standstill_gyro_bias`) and, before the first standstill, by
the drive's own zero from its GNSS course, else its rear wheel speeds
(:func:`sideslip.calibrate.sensors.drive_gyro_bias`: a raw phone gyro's 3.9 deg/s put
obs_kinematic 24.9 deg off on the comma2k19 minute, 0.21 with the zero; realdata_check.md;
0.19 from the wheels alone with the GNSS removed, gyro_zero_wheels.md).  The steering
sensor is zeroed with the drive's own offset
(:func:`sideslip.calibrate.steer_zero.drive_steer_offset`, where more than 2 sigma from 0): the
observers read an offset d0 as a front-axle force c_f d0, i.e. as sideslip on every row.  The
accelerometer is assumed zeroed (the paper's assumption) and the IMU at the CG (lever arms are ignored).
Reversing follows the contract's beta = atan2(v_y, v_x) (about +-pi, as the reference
``ref_beta`` of the simulator and of the converters), not a forward-equivalent small angle.

Health and settings: every observer outputs ``health`` (0 good ... 1 unusable) and
``params["health"]`` from what it can check itself -- output error against its model, linear
range of the tyres, rows where it is not run (below the gate, standstill, reversing) and, for
the kinematic observer, weak observability at small |r|
(:mod:`sideslip.methods.observer_health`).  Poles and gains are settings
(:class:`BicycleObserverSettings`, :class:`KinematicObserverSettings`; ``--set
obs_modified.pole_rad_s=-15``), fixed by default for the reason given there.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import NDArray

from sideslip.drive import Drive
from sideslip.estimate import Estimate
from sideslip.filters.pole_placement import (
    bicycle_coupling,
    closed_loop,
    double_pole_step,
    reachable_pole,
    single_output_gain,
    two_output_gain,
)
from sideslip.methods.observer_health import observer_health
from sideslip.methods.registry import SPEED, register
from sideslip.methods.roll_index import ROLL_PARAMS, Inputs, estimate_roll_index, sensor_inputs
from sideslip.models.roll import compensate_ay
from sideslip.models.single_track import V_MIN as SINGLE_TRACK_V_MIN
from sideslip.models.single_track import continuous_arrays, single_track_row
from sideslip.signals import hold, sample_step
from sideslip.vehicle import Vehicle

FloatArray = NDArray[np.float64]

V_GATE = 5.0  # m/s: observers run above this forward speed
P_BICYCLE = -20.0  # rad/s: double pole of the simple bicycle observer (see module docstring)
P_MODIFIED = -20.0  # rad/s: double pole of the modified bicycle observer
ALPHA = 2.0  # kinematic observer: poles at -ALPHA |r|
R_OBSERVABLE = 0.05  # rad/s (~3 deg/s): below, v_y is taken as weakly observable
TAU_STRAIGHT = 2.0  # s: pull of v_y towards 0 when |r| -> 0
# obs_bicycle: the full pole placement may read a yaw-moment model error as at most this many
# times the sideslip error the open-loop model itself makes of it (module docstring)
YAW_ERROR_GAIN = 3.0
BETA_MAX = 1.2  # rad
R_MAX = 5.0  # rad/s

MODEL_PARAMS = ("mass", "yaw_inertia", "lf", "lr", "cf", "cr")


# ------------------------------------------------------------------------------------------
# compiled loops
# ------------------------------------------------------------------------------------------
@numba.njit(cache=True)
def _open_loop(x0: float, x1: float, A: NDArray, bu: NDArray, h: float
               ) -> tuple[float, float]:  # pragma: no cover - compiled
    """RK4 of x' = A x + bu over h, sub-stepped so that |lambda h_sub| <= 0.5."""
    scale = max(abs(A[0, 0]) + abs(A[0, 1]), abs(A[1, 0]) + abs(A[1, 1]))
    n_sub = min(10000, int(h * scale / 0.5) + 1)
    hs = h / n_sub
    for _ in range(n_sub):
        k10 = A[0, 0] * x0 + A[0, 1] * x1 + bu[0]
        k11 = A[1, 0] * x0 + A[1, 1] * x1 + bu[1]
        y0, y1 = x0 + 0.5 * hs * k10, x1 + 0.5 * hs * k11
        k20 = A[0, 0] * y0 + A[0, 1] * y1 + bu[0]
        k21 = A[1, 0] * y0 + A[1, 1] * y1 + bu[1]
        y0, y1 = x0 + 0.5 * hs * k20, x1 + 0.5 * hs * k21
        k30 = A[0, 0] * y0 + A[0, 1] * y1 + bu[0]
        k31 = A[1, 0] * y0 + A[1, 1] * y1 + bu[1]
        y0, y1 = x0 + hs * k30, x1 + hs * k31
        k40 = A[0, 0] * y0 + A[0, 1] * y1 + bu[0]
        k41 = A[1, 0] * y0 + A[1, 1] * y1 + bu[1]
        x0 += hs / 6.0 * (k10 + 2.0 * k20 + 2.0 * k30 + k40)
        x1 += hs / 6.0 * (k11 + 2.0 * k21 + 2.0 * k31 + k41)
    return x0, x1


@numba.njit(cache=True)
def _run_bicycle_type(t: NDArray, Phi: NDArray, Gam: NDArray, w: NDArray, A: NDArray,
                      bu: NDArray, fresh: NDArray, active: NDArray, x_init: NDArray,
                      x_start: NDArray, out: NDArray
                      ) -> tuple[float, float]:  # pragma: no cover - compiled
    """x_{k+1} = Phi_k x_k + Gam_k w_k on fresh rows, open loop otherwise; reset when inactive.

    One chunk of n = ``Phi.shape[0]`` rows, from the state ``x_start`` at its first row, written
    to ``out`` (n, 2).  ``t`` and ``x_init`` hold one row more (the next chunk's first) unless
    the chunk ends the drive.  Returns the state at the next chunk's first row.
    """
    n = Phi.shape[0]
    x0, x1 = x_start[0], x_start[1]
    for k in range(n):
        if not active[k]:
            x0, x1 = x_init[k, 0], x_init[k, 1]
        out[k, 0] = x0
        out[k, 1] = x1
        if k + 1 >= t.size:
            break
        h = t[k + 1] - t[k]
        if fresh[k]:
            n0 = Phi[k, 0, 0] * x0 + Phi[k, 0, 1] * x1 + Gam[k, 0, 0] * w[k, 0] + Gam[k, 0, 1] * w[k, 1]
            n1 = Phi[k, 1, 0] * x0 + Phi[k, 1, 1] * x1 + Gam[k, 1, 0] * w[k, 0] + Gam[k, 1, 1] * w[k, 1]
            x0, x1 = n0, n1
        else:
            x0, x1 = _open_loop(x0, x1, A[k], bu[k], h)
        if not (math.isfinite(x0) and math.isfinite(x1)):
            x0, x1 = x_init[k + 1, 0], x_init[k + 1, 1]
        x0 = min(max(x0, -BETA_MAX), BETA_MAX)
        x1 = min(max(x1, -R_MAX), R_MAX)
    return x0, x1


@numba.njit(cache=True)
def _run_kinematic(t: NDArray, r: NDArray, ax: NDArray, ay: NDArray, y: NDArray,
                   fresh: NDArray, ydt: NDArray, active: NDArray, vx_init: NDArray,
                   vy_init: NDArray, alpha: float, r_obs: float, tau: float
                   ) -> NDArray:  # pragma: no cover - compiled
    """Kinematic observer (module docstring): exact rotation between samples, correction at
    fresh wheel-speed rows, pull of v_y to 0 when |r| < r_obs."""
    n = t.size
    out = np.empty((n, 2))
    vx, vy = vx_init[0], vy_init[0]
    for k in range(n):
        if not active[k]:
            vx, vy = vx_init[k], vy_init[k]
        elif fresh[k] and k > 0 and active[k - 1]:
            rk = r[k]
            k1 = 2.0 * alpha * max(abs(rk), r_obs)
            k2 = (alpha * alpha - 1.0) * rk
            d = min(ydt[k], 0.2)
            if k1 * d > 1.0:  # keep the discrete correction a contraction
                d = 1.0 / k1
            e = y[k] - vx
            vx += k1 * d * e
            vy += k2 * d * e
        out[k, 0] = vx
        out[k, 1] = vy
        if k == n - 1:
            break
        h = t[k + 1] - t[k]
        rk = r[k]
        th = rk * h
        c, s = math.cos(th), math.sin(th)
        if abs(rk) > 1e-9:
            g11, g12 = s / rk, (1.0 - c) / rk
        else:
            g11, g12 = h, 0.5 * rk * h * h
        nvx = c * vx + s * vy + g11 * ax[k] + g12 * ay[k]
        nvy = -s * vx + c * vy - g12 * ax[k] + g11 * ay[k]
        leak = max(0.0, 1.0 - abs(rk) / r_obs)
        vx, vy = nvx, nvy * math.exp(-h * leak / tau)
        if not (math.isfinite(vx) and math.isfinite(vy)):
            vx, vy = vx_init[k + 1], vy_init[k + 1]
        vy = min(max(vy, -abs(vx) * 1.5), abs(vx) * 1.5)
    return out


# ------------------------------------------------------------------------------------------
# shared pieces
# ------------------------------------------------------------------------------------------
def kinematic_beta(vx: FloatArray, delta: FloatArray, vehicle: Vehicle) -> FloatArray:
    """No-slip bicycle sideslip at the CG: atan2(v_x l_r tan(delta)/L, v_x), rad."""
    vy = vx * vehicle.lr * np.tan(np.clip(delta, -1.2, 1.2)) / vehicle.wheelbase
    return np.asarray(np.arctan2(vy, vx), dtype=float)


HELD_SPACINGS = 1.5  # a sample is held this many of its own spacings, then the row is a gap


def _steps(t: FloatArray) -> FloatArray:
    dt = np.diff(t)
    return np.append(dt, dt[-1] if dt.size else 0.01)


def _fresh(drive: Drive, *names: str) -> NDArray[np.bool_]:
    """Rows where each column of ``names`` has a sample no older than
    :data:`HELD_SPACINGS` of its own sample spacing (the observer's correction uses it, held;
    older, the row runs open loop).  A sensor slower than the table, or on a union time line
    of several buses, has NaN between its samples: each such row was taken open loop, which
    an unstable model (the Revs car's single-track matrix at speed) cannot carry;
    obs_modified_nocomp read the Revs lap with its IMU and CAN rows interleaved at 20.8 deg
    (1.18 as logged)."""
    ok = np.ones(len(drive), dtype=bool)
    for name in names:
        if name not in drive:
            return np.zeros(len(drive), dtype=bool)
        col = drive[name]
        age = hold(col, drive.t)[1]
        ok &= age <= HELD_SPACINGS * sample_step(drive.t, col)
    return ok


# Rows per chunk of the per-row 2x2 matrices (A, B, K, Phi, Gamma: 32 B/row each): the
# observers build them a chunk at a time, so their memory does not grow with them.
CHUNK_ROWS = 1 << 14

# (Phi, Gam, w, A, bu) of one chunk of rows
ChunkMatrices = tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]


def _chunks(n: int) -> list[slice]:
    return [slice(s, min(n, s + CHUNK_ROWS)) for s in range(0, n, CHUNK_ROWS)]


def run_bicycle_observer(inp: Inputs, vehicle: Vehicle, fresh: NDArray[np.bool_],
                         pole: float = P_BICYCLE, v_gate: float = V_GATE
                         ) -> tuple[FloatArray, FloatArray]:
    """Simple bicycle observer (eqs 12-17) on prepared inputs: returns (beta, r_hat)."""

    def matrices(sl: slice, dt: FloatArray) -> ChunkMatrices:
        v = np.maximum(np.abs(inp.vx[sl]), v_gate)
        A, B, _, _ = continuous_arrays(vehicle, v)
        b = B[:, :, 0]
        # full placement where |a21| >= |a11 a22| / YAW_ERROR_GAIN (module docstring): below,
        # the observer would read a yaw-moment model error as more than YAW_ERROR_GAIN times
        # the sideslip the model itself does
        p_eff = reachable_pole(A, pole, np.abs(A[:, 0, 0] * A[:, 1, 1]) / YAW_ERROR_GAIN)
        K = single_output_gain(A, p_eff)
        M = closed_loop(A, K, np.array([[0.0, 1.0]]))
        Phi, Gam = double_pole_step(M, p_eff, dt)
        bu = b * inp.delta[sl, None]
        return Phi, Gam, b * inp.delta[sl, None] + K * inp.r[sl, None], A, bu

    return _run(inp, vehicle, matrices, fresh, v_gate)


def run_modified_observer(inp: Inputs, vehicle: Vehicle, ay: FloatArray, bank: FloatArray,
                          fresh: NDArray[np.bool_], pole: float = P_MODIFIED,
                          v_gate: float = V_GATE) -> tuple[FloatArray, FloatArray]:
    """Modified bicycle observer (eqs 33-39) with lateral acceleration ``ay`` (m/s^2) and the
    road ``bank`` (rad) as a known input (zeros: the paper's flat-road model)."""
    q = bicycle_coupling(vehicle.cf, vehicle.cr, vehicle.lf, vehicle.lr, vehicle.yaw_inertia)

    def matrices(sl: slice, dt: FloatArray) -> ChunkMatrices:
        v = np.maximum(np.abs(inp.vx[sl]), v_gate)
        A, B, C, D = continuous_arrays(vehicle, v)
        u = np.stack([inp.delta[sl], np.sin(bank[sl])], axis=1)
        bu = np.einsum("nij,nj->ni", B, u)
        du = np.einsum("nij,nj->ni", D, u)
        K = two_output_gain(A, C, pole, q)
        M = closed_loop(A, K, C)
        Phi, Gam = double_pole_step(M, pole, dt)
        y = np.stack([inp.r[sl], ay[sl]], axis=1)
        return Phi, Gam, bu + np.einsum("nij,nj->ni", K, y - du), A, bu

    return _run(inp, vehicle, matrices, fresh, v_gate)


@numba.njit(cache=True)
def _ay_output_error(m: float, iz: float, lf: float, lr: float, cf: float, cr: float,
                     v: NDArray, beta: NDArray, r_hat: NDArray, delta: NDArray,
                     sin_bank: NDArray, ay: NDArray) -> NDArray:  # pragma: no cover - compiled
    """a_y - (C_2 x + D_2 u) per row, the model rows of
    :func:`sideslip.models.single_track.single_track_row` at the speeds ``v`` (m/s)."""
    A = np.empty((2, 2))
    B = np.empty((2, 2))
    C = np.empty((2, 2))
    D = np.empty((2, 2))
    out = np.empty(v.size)
    for k in range(v.size):
        single_track_row(m, iz, lf, lr, cf, cr, v[k], A, B, C, D)
        pred = C[1, 0] * beta[k] + C[1, 1] * r_hat[k] + D[1, 0] * delta[k] + D[1, 1] * sin_bank[k]
        out[k] = ay[k] - pred
    return out


def modified_output_error(inp: Inputs, vehicle: Vehicle, beta: FloatArray, r_hat: FloatArray,
                          ay: FloatArray, bank: FloatArray, v_gate: float = V_GATE
                          ) -> FloatArray:
    """a_y - (C_2 x_hat + D_2 u) (m/s^2): the modified observer's lateral-acceleration output
    error (eq 32 with the bank input), for its health check; one compiled pass over the rows
    (the model speed clamped as :func:`~sideslip.models.single_track.continuous_arrays` does)."""
    v = np.maximum(np.maximum(np.abs(inp.vx), v_gate), SINGLE_TRACK_V_MIN)
    return np.asarray(_ay_output_error(
        float(vehicle.mass), float(vehicle.yaw_inertia), float(vehicle.lf), float(vehicle.lr),
        float(vehicle.cf), float(vehicle.cr), v, np.asarray(beta, dtype=float),
        np.asarray(r_hat, dtype=float), inp.delta, np.sin(bank), np.asarray(ay, dtype=float)))


def _run(inp: Inputs, vehicle: Vehicle, matrices: Callable[[slice, FloatArray], ChunkMatrices],
         fresh: NDArray[np.bool_], v_gate: float = V_GATE) -> tuple[FloatArray, FloatArray]:
    """Run a bicycle-type observer chunk by chunk (:data:`CHUNK_ROWS`), the state carried from
    one chunk to the next: ``matrices(rows, dt)`` gives that chunk's (Phi, Gam, w, A, bu)."""
    n = inp.t.size
    active = inp.vx >= v_gate
    x_init = np.stack([kinematic_beta(inp.vx, inp.delta, vehicle), inp.r], axis=1)
    dt = _steps(inp.t)
    x = np.empty((n, 2))
    state = x_init[0].copy()
    for sl in _chunks(n):
        Phi, Gam, w, A, bu = matrices(sl, dt[sl])
        ext = slice(sl.start, min(n, sl.stop + 1))
        state = np.array(_run_bicycle_type(inp.t[ext], Phi, Gam, w, A, bu, fresh[sl], active[sl],
                                           x_init[ext], state, x[sl]))
    beta = np.where(active, x[:, 0], x_init[:, 0])
    return beta, x[:, 1].copy()


def run_kinematic_observer(inp: Inputs, vehicle: Vehicle, ay: FloatArray,
                           alpha: float = ALPHA, v_gate: float = V_GATE,
                           r_observable: float = R_OBSERVABLE, tau_straight: float = TAU_STRAIGHT
                           ) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Kinematic observer (eqs 18-30) with lateral acceleration ``ay``: (beta, v_x, v_y)."""
    active = inp.vx >= v_gate
    beta_kin = kinematic_beta(inp.vx, inp.delta, vehicle)
    vy_init = inp.vx * np.tan(np.clip(beta_kin, -1.2, 1.2))
    vy_init = np.where(inp.vx >= 0, vy_init, inp.vx * vehicle.lr * np.tan(inp.delta)
                       / vehicle.wheelbase)
    x = _run_kinematic(inp.t, inp.r, inp.ax, ay, inp.vx, inp.speed_fresh, inp.speed_dt,
                       active, inp.vx.copy(), vy_init, alpha, r_observable, tau_straight)
    vx = np.where(active, x[:, 0], inp.vx)
    vy = np.where(active, x[:, 1], vy_init)
    beta = np.where(active, np.arctan2(vy, np.maximum(vx, 0.1)), beta_kin)
    return beta, vx, vy


@dataclass(frozen=True)
class BicycleObserverSettings:
    """Tuning of ``obs_bicycle``, ``obs_modified`` and ``obs_modified_nocomp``.

    ``pole_rad_s``: the observer's double pole (rad/s, negative; module docstring for the
    default); ``v_gate_m_s``: forward speed (m/s) above which the observer runs.
    Fixed gains, not identified from the drive: the output error an observer can see is the
    model's, not beta's (eq 36 makes the modified observer's beta error independent of the
    model precisely by letting r_hat absorb the mismatch), so a pole chosen to minimise it
    would be chosen on the wrong criterion; a faster pole follows the sensors' noise, a slower
    one the model's error, and the drive holds no beta reference to weigh the two.  Measured
    on the 14 comparison scenarios (seed 0) with poles -8 / -20 / -50 rad/s: the best pole
    changes from scenario to scenario with no pattern in what a drive measures (sensor noise,
    speed, a_y), and no fixed choice beats -20 on both files for both observers (mean beta
    RMSE obs_bicycle 0.327 / 0.234 / 0.324 deg, obs_modified 0.167 / 0.139 / 0.132 deg).
    ``zero_gyro``: before the standstill zeroing starts, subtract the drive's own gyro zero
    (module docstring); False keeps the samples as recorded until then.  ``zero_steer``:
    subtract the drive's own steering offset (module docstring); False: the steer as recorded.
    """

    pole_rad_s: float = P_BICYCLE
    v_gate_m_s: float = V_GATE
    zero_gyro: bool = True
    zero_steer: bool = True

    def __post_init__(self) -> None:
        name = type(self).__name__
        if not (math.isfinite(self.pole_rad_s) and -1000.0 <= self.pole_rad_s < 0.0):
            raise ValueError(f"{name}.pole_rad_s = {self.pole_rad_s}: expected a number in "
                             "[-1000, 0) rad/s")
        if not (math.isfinite(self.v_gate_m_s) and 0.5 <= self.v_gate_m_s <= 30.0):
            raise ValueError(f"{name}.v_gate_m_s = {self.v_gate_m_s}: expected 0.5 ... 30 m/s")


@dataclass(frozen=True)
class KinematicObserverSettings:
    """Tuning of ``obs_kinematic``: ``alpha`` (-, poles at -alpha |r|, > 1 so K2 keeps the sign
    of r), ``r_observable_rad_s`` (yaw rate below which v_y is taken as weakly observable),
    ``tau_straight_s`` (pull of v_y to 0 when straight), ``v_gate_m_s`` (speed gate).  Fixed,
    for the reason given in :class:`BicycleObserverSettings`.  ``zero_gyro`` and
    ``zero_steer`` as there (the steer enters through the roll index and the start value)."""

    alpha: float = ALPHA
    r_observable_rad_s: float = R_OBSERVABLE
    tau_straight_s: float = TAU_STRAIGHT
    v_gate_m_s: float = V_GATE
    zero_gyro: bool = True
    zero_steer: bool = True

    def __post_init__(self) -> None:
        name = type(self).__name__
        checks = (("alpha", self.alpha, 1.0, 20.0, ""), ("r_observable_rad_s",
                  self.r_observable_rad_s, 1e-4, 1.0, " rad/s"),
                  ("tau_straight_s", self.tau_straight_s, 0.01, 1000.0, " s"),
                  ("v_gate_m_s", self.v_gate_m_s, 0.5, 30.0, " m/s"))  # fmt: skip
        for field_name, value, lo, hi, unit in checks:
            if not (math.isfinite(value) and lo < value <= hi if field_name == "alpha"
                    else math.isfinite(value) and lo <= value <= hi):
                raise ValueError(f"{name}.{field_name} = {value}: expected {lo:g} ... {hi:g}{unit}"
                                 + (" (greater than 1)" if field_name == "alpha" else ""))


def _params(st: BicycleObserverSettings, health: dict[str, object], **extra: object
            ) -> dict[str, object]:
    return {"pole_rad_s": st.pole_rad_s, "v_gate_m_s": st.v_gate_m_s,
            "gains": "fixed (see BicycleObserverSettings)", "health": health, **extra}


def _observed(inp: Inputs, v_gate: float) -> NDArray[np.bool_]:
    return np.asarray(inp.vx >= v_gate)


def _fresh_residual(values: FloatArray, fresh: NDArray[np.bool_]) -> FloatArray:
    return np.where(fresh, values, np.nan)


# ------------------------------------------------------------------------------------------
# registered methods
# ------------------------------------------------------------------------------------------
@register(
    "obs_bicycle",
    columns=("wz", "steer", SPEED),
    summary="simple bicycle-model Luenberger observer, yaw-rate output, double pole",
    paper="seed 003 (eqs 10-17)",
    vehicle_params=MODEL_PARAMS,
    settings=BicycleObserverSettings,
    accelerometer="cg_causal",
)
def obs_bicycle(drive: Drive, vehicle: Vehicle,
                settings: BicycleObserverSettings | None = None) -> Estimate:
    """Sideslip from the single-track model corrected by the gyro (module docstring)."""
    st = settings or BicycleObserverSettings()
    inp = sensor_inputs(drive, vehicle if st.zero_gyro else None,
                        vehicle if st.zero_steer else None)
    fresh = _fresh(drive, "wz")
    beta, r_hat = run_bicycle_observer(inp, vehicle, fresh, st.pole_rad_s, st.v_gate_m_s)
    health, summary = observer_health(
        inp.t, _observed(inp, st.v_gate_m_s), {"r": _fresh_residual(inp.r - r_hat, fresh)},
        inp.ay_m, inputs_fresh=_fresh(drive, "steer"))
    return Estimate("obs_bicycle", drive.t,
                    {"beta": beta, "r": r_hat, "gyro_bias": inp.gyro_bias, "health": health},
                    _params(st, summary, **inp.gyro_zero_params()))


@register(
    "obs_kinematic",
    columns=("wz", "ax", "ay", "steer", SPEED),
    summary="kinematic observer on v_x, v_y with wheel-speed output, gains 2a|r|, (a^2-1)r",
    paper="seed 003 (eqs 18-30)",
    vehicle_params=ROLL_PARAMS,
    settings=KinematicObserverSettings,
    accelerometer="cg_causal",
)
def obs_kinematic(drive: Drive, vehicle: Vehicle,
                  settings: KinematicObserverSettings | None = None) -> Estimate:
    """Kinematic observer with the roll-compensated lateral acceleration (module docstring)."""
    st = settings or KinematicObserverSettings()
    inp = sensor_inputs(drive, vehicle if st.zero_gyro else None,
                        vehicle if st.zero_steer else None)
    roll = estimate_roll_index(inp, vehicle)
    ay = compensate_ay(inp.ay_m, roll.roll)
    beta, vx, vy = run_kinematic_observer(inp, vehicle, ay, st.alpha, st.v_gate_m_s,
                                          st.r_observable_rad_s, st.tau_straight_s)
    weak = np.clip(1.0 - np.abs(inp.r) / st.r_observable_rad_s, 0.0, 1.0)
    health, summary = observer_health(
        inp.t, _observed(inp, st.v_gate_m_s),
        {"vx": _fresh_residual(inp.vx - vx, inp.speed_fresh)}, inp.ay_m, weak,
        inputs_fresh=_fresh(drive, "wz", "ax", "ay"))
    return Estimate(
        "obs_kinematic", drive.t,
        {"beta": beta, "vx": vx, "vy": vy, "r": inp.r, "roll": roll.roll, "bank": roll.bank,
         "gyro_bias": inp.gyro_bias, "health": health},
        {"alpha": st.alpha, "r_observable_rad_s": st.r_observable_rad_s,
         "tau_straight_s": st.tau_straight_s, "v_gate_m_s": st.v_gate_m_s,
         "gains": "fixed (see KinematicObserverSettings)", "health": summary,
         "speed_source": "rear wheels, else all wheels, else v_can", **roll.params,
         **inp.gyro_zero_params()},
    )


def _modified(drive: Drive, vehicle: Vehicle, st: BicycleObserverSettings, compensate: bool
              ) -> tuple[dict[str, FloatArray], dict[str, object]]:
    inp = sensor_inputs(drive, vehicle if st.zero_gyro else None,
                        vehicle if st.zero_steer else None)
    fresh = _fresh(drive, "wz", "ay")
    series: dict[str, FloatArray] = {}
    extra: dict[str, object] = {}
    if compensate:
        roll = estimate_roll_index(inp, vehicle)
        ay, bank = compensate_ay(inp.ay_m, roll.roll), roll.bank
        series.update(roll=roll.roll, bank=roll.bank)
        extra.update(compensation="roll_index", lambda_fraction=float(np.mean(roll.lam)),
                     **roll.params)
    else:
        ay, bank = inp.ay_m, np.zeros_like(inp.ay_m)
        extra.update(compensation="none")
    beta, r_hat = run_modified_observer(inp, vehicle, ay, bank, fresh, st.pole_rad_s,
                                        st.v_gate_m_s)
    res_ay = modified_output_error(inp, vehicle, beta, r_hat, ay, bank, st.v_gate_m_s)
    health, summary = observer_health(
        inp.t, _observed(inp, st.v_gate_m_s),
        {"r": _fresh_residual(inp.r - r_hat, fresh), "ay": _fresh_residual(res_ay, fresh)},
        inp.ay_m, inputs_fresh=_fresh(drive, "steer"))
    series.update(beta=beta, r=inp.r, gyro_bias=inp.gyro_bias, health=health)
    return series, _params(st, summary, **extra, **inp.gyro_zero_params())


@register(
    "obs_modified",
    columns=("wz", "ay", "steer", SPEED),
    summary="seed 003's modified bicycle observer (outputs r, a_y) with roll-index compensation",
    paper="seed 003 (eqs 31-39, 61-62)",
    vehicle_params=(*MODEL_PARAMS, *ROLL_PARAMS[5:]),
    settings=BicycleObserverSettings,
    accelerometer="cg_causal",
)
def obs_modified(drive: Drive, vehicle: Vehicle,
                 settings: BicycleObserverSettings | None = None) -> Estimate:
    """Modified bicycle observer fed a_y = a_ym - g sin(roll) (module docstring)."""
    series, params = _modified(drive, vehicle, settings or BicycleObserverSettings(), True)
    return Estimate("obs_modified", drive.t, series, params)


@register(
    "obs_modified_nocomp",
    columns=("wz", "ay", "steer", SPEED),
    summary="modified bicycle observer fed the raw a_y (no gravity compensation; comparison)",
    paper="seed 003 (eqs 31-39)",
    vehicle_params=MODEL_PARAMS,
    settings=BicycleObserverSettings,
    accelerometer="cg_causal",
)
def obs_modified_nocomp(drive: Drive, vehicle: Vehicle,
                        settings: BicycleObserverSettings | None = None) -> Estimate:
    """Modified bicycle observer fed the measured a_ym, gravity included (module docstring)."""
    series, params = _modified(drive, vehicle, settings or BicycleObserverSettings(), False)
    return Estimate("obs_modified_nocomp", drive.t, series, params)
