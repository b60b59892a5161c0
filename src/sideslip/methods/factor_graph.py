"""Factor-graph sideslip estimation on the linear single-track model (seed 002).

Leanza, Reina, Blanco-Claraco (2021), "A factor graph-based approach to vehicle sideslip
angle estimation" (seed 002_eed16832cdab0792).  Three registered methods share one graph:

* ``fg_batch``  -- the whole drive solved at once (off-line), with marginal 1-sigma of beta
  from a banded selected inverse of the information matrix (paper section 3.1, Fig. 9).
* ``fg_lag``    -- fixed-lag smoother, window of ``window`` samples (paper: 5, section 3.2);
  the oldest state is marginalised exactly into the next window's prior.
* ``kf_linear`` -- the paper's comparison: a linear Kalman filter on the same model, with the
  same noise settings (paper section 4).

States (one variable node each per time step k, at the table's rows, i.e. the IMU rate)
    x_k = [beta_k (rad, sideslip at the CG), r_k (rad/s, yaw rate)]
Input
    delta_k (rad, front road-wheel angle, ``steer``, zero-order held), V_k (m/s, longitudinal
    speed from :func:`sideslip.signals.vehicle_speed`, held).
Factors (paper eqs 6-7, 16; digest "002")
    prior      beta_0 = 0, r_0 = 0                        sigmas prior_beta / prior_yaw_rate
    dynamic    beta_{k+1} - beta_k - dt (A11 beta_k + A12 r_k + B1 delta_k) = 0   model_beta
               r_{k+1}    - r_k    - dt (A21 beta_k + A22 r_k + B2 delta_k) = 0   model_yaw_rate
               (ternary: forward Euler of the single-track model, paper eq 6)
    yaw rate   r_k = wz_k                         (unary, fresh gyro samples only)  yaw_rate
    lat. acc.  C1 beta_k + C2 r_k + D delta_k = ay_k   (binary, fresh samples)   lateral_accel.
with, per axle cornering stiffness cf, cr (N/rad; the digest's C_f, C_r are per axle):
    A11 = -(cf+cr)/(m V),  A12 = (cr lr - cf lf)/(m V^2) - 1,  B1 = cf/(m V)
    A21 = (cr lr - cf lf)/Iz, A22 = -(cf lf^2 + cr lr^2)/(Iz V), B2 = cf lf/Iz
    C1 = -(cf+cr)/m,  C2 = (cr lr - cf lf)/(m V),  D = cf/m
(:func:`sideslip.models.single_track.continuous_arrays`; the digest's eq for a_y matches.
Signs re-derived from F_yf = cf (delta - beta - lf r/V), F_yr = cr (-beta + lr r/V),
m V (beta' + r) = F_yf + F_yr, Iz r' = lf F_yf - lr F_yr, a_y = (F_yf + F_yr)/m.)

Gaussian factors make the problem a linear weighted least squares problem; one Gauss-Newton
step (a single banded Cholesky solve, :mod:`sideslip.filters.banded`) is its exact solution.

Fixed-lag smoother.  The paper keeps "the most reliable estimate as a set of priors for the
next estimation" without saying with which covariance.  Here the oldest state of the window is
marginalised exactly (Schur complement of its factors onto the next state), so fg_lag gives,
for row k, the exact posterior mean and 1-sigma of x_k given all data up to row k + window:
with window = 0 it is the Kalman filter, with window >= N - 1 the batch smoother (both
tested).  On-line this is an output delay of window x dt (50 ms at 100 Hz).  The drive is
streamed in chunks of ``LAG_CHUNK`` rows, so the working memory does not grow with the drive.
Because the paper's 34 % gain of its FG over its KF came with different tunings of the two
(its Section 4 says so), while here both use the same settings, fg_lag improves on kf_linear
only by what 5 samples of smoothing give (about 1 % in beta, 4x in r on race_lap).

Noise settings (:class:`FactorGraphSettings`).  The paper's numeric sigmas were lost in the
text extraction; it states only their ordering: a small yaw-rate sigma (precise gyro), a larger
lateral-acceleration sigma (a linear model compared with the real acceleration), and small
model sigmas.  The defaults follow that ordering with values from physics, not from our
scenarios (see the dataclass).  The model sigmas are per step at ``reference_dt`` (0.01 s) and
scale with sqrt(dt/reference_dt) so that the same settings describe the same continuous
process noise at other sampling rates.

Accelerometer.  The paper uses the lateral accelerometer raw; so do we.  It reads specific
force: the tyre forces over m plus g sin(suspension roll).  The model's right side C x + D delta
is exactly the tyre forces over m, so on a banked road the raw reading is the right quantity
(road bank cancels between gravity and the contact forces; "gravity compensation" with the
body roll would be wrong here).  What remains is the suspension-roll term, about
g m (h_cg - h_roll)/k_roll ~ 5 % of a_y for the ferrari_250lm preset: it acts like a 5 % error
of the cornering stiffness.  Road bank does enter the dynamics (beta' gains -g sin(bank)/V,
single_track's bank input); it is unknown here and set to zero, so the model sigmas absorb it.
The IMU is assumed at the CG (lever-arm terms in a_y ignored, as in the paper).

Low speed, standstill, reversing.  The model is singular at V -> 0 (A, B, C ~ 1/V), and forward
Euler is unstable when dt (cf+cr)/(m V) > 2.  The model matrices therefore use
V_model = max(V, speed_gate) in the a_y factor and additionally >= dt max((cf+cr)/m,
(cf lf^2 + cr lr^2)/Iz) in the dynamic factors (which keeps every Euler diagonal term within
[0, 1]).  A time step longer than ``max_step`` (a gap in the recording) restarts the chain.
Below ``speed_gate`` (and when reversing, V < 0) the lateral-acceleration factor is dropped,
the model sigmas are multiplied by ``low_speed_inflation``, and a unary pseudo-measurement
ties beta to the kinematic low-speed sideslip atan(lr tan(delta)/L) (sigma
``low_speed_beta``), so the estimate is finite and returns smoothly to the kinematic value at
standstill.  Gaps (NaN runs) in wz / ay simply have no measurement factors: the model bridges
them and the 1-sigma grows.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numba
import numpy as np
from numpy.typing import NDArray

from sideslip.drive import Drive
from sideslip.estimate import Estimate
from sideslip.filters.banded import assemble_chain, fixed_lag_chain, selected_inverse, solve_chain
from sideslip.methods.registry import SPEED, register
from sideslip.models.single_track import continuous_arrays
from sideslip.signals import hold, vehicle_speed
from sideslip.vehicle import Vehicle

FloatArray = NDArray[np.float64]

PAPER = "seed 002 (Leanza, Reina, Blanco-Claraco 2021), eqs 4-7, 16-18"
COLUMNS = ("wz", "ay", "steer", SPEED)
VEHICLE_PARAMS = ("mass", "yaw_inertia", "lf", "lr", "cf", "cr")


@dataclass(frozen=True)
class FactorGraphSettings:
    """Sigmas (1-sigma of each factor's residual) and options of the seed-002 graph.

    Attributes
    ----------
    prior_beta : rad.  Prior on beta_0 = 0: drives start near straight running; 3 deg.
    prior_yaw_rate : rad/s.  Prior on r_0 = 0; the first gyro sample overrides it.
    yaw_rate : rad/s.  Yaw-rate factor r_k = wz_k: MEMS gyro white noise (~0.005 rad/s at
        100 Hz) plus an uncompensated bias of the same order; the paper's "small" sigma.
    lateral_acceleration : m/s^2.  a_y factor: accelerometer noise (~0.05 m/s^2) is small
        against the linear-tyre model error near the grip limit (~0.5 m/s^2 at 0.6 g with
        tyres 10 % past linear) and the suspension-roll term (~5 % of a_y); the paper's
        "larger" sigma.
    model_beta : rad per ``reference_dt`` step.  beta dynamic factor: an error of 1 m/s^2 in
        the modelled tyre force per mass at 10 m/s is 0.1 rad/s of beta rate, 0.001 rad/step.
    model_yaw_rate : rad/s per ``reference_dt`` step.  r dynamic factor: a yaw-moment error of
        ~1000 N m on Iz ~ 1000 kg m^2 is 1 rad/s^2, 0.01 rad/s per step.
    reference_dt : s.  Step at which the model sigmas are quoted (sigma ~ sqrt(dt)).
    speed_gate : m/s.  Below it (and reversing) the low-speed handling of the module docstring.
    low_speed_beta : rad.  Sigma of the low-speed kinematic pseudo-measurement on beta.
    low_speed_inflation : factor on the model sigmas below the speed gate.
    window : samples.  fg_lag's window: the dynamic steps after the prior block (paper: 5).
    max_step : s.  A time step longer than this (a gap in the recording) carries no model
        information: the dynamic factor across it becomes a fresh prior (restart).
    """

    prior_beta: float = 0.05
    prior_yaw_rate: float = 0.05
    yaw_rate: float = 0.01
    lateral_acceleration: float = 0.5
    model_beta: float = 0.001
    model_yaw_rate: float = 0.01
    reference_dt: float = 0.01
    speed_gate: float = 3.0
    low_speed_beta: float = 0.02
    low_speed_inflation: float = 10.0
    window: int = 5
    max_step: float = 0.25

    def __post_init__(self) -> None:
        for name in (
            "prior_beta", "prior_yaw_rate", "yaw_rate", "lateral_acceleration", "model_beta",
            "model_yaw_rate", "reference_dt", "speed_gate", "low_speed_beta",
            "low_speed_inflation", "max_step",
        ):  # fmt: skip
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"FactorGraphSettings.{name} = {value!r}: expected a number > 0")
        if int(self.window) != self.window or self.window < 0:
            raise ValueError(
                f"FactorGraphSettings.window = {self.window!r}: expected an integer >= 0"
            )


DEFAULT_SETTINGS = FactorGraphSettings()
LAG_CHUNK = 4096  # rows per chunk of the streamed fixed-lag smoother


@dataclass(frozen=True)
class SideslipGraph:
    """The seed-002 graph as chain factors (layout of :mod:`sideslip.filters.banded`).

    ``F`` (N-1, 2, 2) = I + dt A_k and ``g`` (N-1, 2) = dt B_k delta_k: the dynamic factors
    x_{k+1} - F_k x_k - g_k with sigmas ``sigma_q`` (N-1, 2).  Unary factors ``Hu`` (N, 3, 2),
    ``zu`` (N, 3), ``sigma_u`` (N, 3) (inf = absent): row 0 yaw rate, row 1 lateral
    acceleration, row 2 low-speed kinematic beta.  Prior mean ``x0`` and sigmas ``sigma0``.
    """

    F: FloatArray
    g: FloatArray
    sigma_q: FloatArray
    Hu: FloatArray
    zu: FloatArray
    sigma_u: FloatArray
    x0: FloatArray
    sigma0: FloatArray
    low_speed: NDArray[np.bool_]

    @property
    def wq(self) -> FloatArray:
        """Weights 1/sigma^2 of the dynamic factors, (N-1, 2)."""
        return np.asarray(1.0 / self.sigma_q**2, dtype=float)

    @property
    def wu(self) -> FloatArray:
        """Weights 1/sigma^2 of the unary factors, (N, 3); 0 where a factor is absent."""
        with np.errstate(divide="ignore"):
            return np.asarray(np.where(np.isfinite(self.sigma_u), 1.0 / self.sigma_u**2, 0.0))

    @property
    def prior_information(self) -> tuple[FloatArray, FloatArray]:
        """The prior on x_0 in information form (Lam0, Lam0 x0)."""
        lam0 = np.diag(1.0 / self.sigma0**2)
        return lam0, lam0 @ self.x0


@dataclass(frozen=True)
class GraphInputs:
    """Per-row inputs of the graph on the drive's time base (light: a few floats per row).

    ``delta`` held road-wheel angle (rad); ``v_dynamics`` and ``v_measurement`` the speeds
    (m/s) used in the dynamic and the a_y factors (clamped, module docstring); ``low_speed``
    rows below the speed gate or reversing; ``time_gap`` steps longer than ``max_step``
    (length N - 1); ``wz`` and ``ay`` the raw samples (NaN where the sensor has no fresh
    sample).
    """

    t: FloatArray
    delta: FloatArray
    v_dynamics: FloatArray
    v_measurement: FloatArray
    time_gap: NDArray[np.bool_]
    low_speed: NDArray[np.bool_]
    wz: FloatArray
    ay: FloatArray


def graph_inputs(
    drive: Drive, vehicle: Vehicle, settings: FactorGraphSettings = DEFAULT_SETTINGS
) -> GraphInputs:
    """Held steering and speed, the clamped model speed and the low-speed rows of ``drive``."""
    vehicle.need(*VEHICLE_PARAMS)
    t = drive.t
    delta, _ = hold(drive["steer"], t, fill=0.0)
    speed = vehicle_speed(drive)
    low = ~(speed >= settings.speed_gate)
    dt = np.diff(t)
    stiff = max(
        (vehicle.cf + vehicle.cr) / vehicle.mass,
        (vehicle.cf * vehicle.lf**2 + vehicle.cr * vehicle.lr**2) / vehicle.yaw_inertia,
    )
    gap = dt > settings.max_step
    dt_row = np.append(np.where(gap, 0.0, dt), 0.0)
    v_measurement = np.maximum(speed, settings.speed_gate)
    v_dynamics = np.maximum(v_measurement, dt_row * stiff)
    return GraphInputs(t, delta, v_dynamics, v_measurement, gap, low, drive["wz"], drive["ay"])


def build_graph(
    inputs: GraphInputs,
    vehicle: Vehicle,
    settings: FactorGraphSettings = DEFAULT_SETTINGS,
    start: int = 0,
    stop: int | None = None,
) -> SideslipGraph:
    """The factors of rows ``start .. stop-1`` (module docstring); O(stop - start) memory."""
    sl = slice(start, stop)
    t = inputs.t[sl]
    n = t.size
    delta = inputs.delta[sl]
    low = inputs.low_speed[sl]
    A, B, _, _ = continuous_arrays(vehicle, inputs.v_dynamics[sl], v_min=settings.speed_gate)
    _, _, C, D = continuous_arrays(vehicle, inputs.v_measurement[sl], v_min=settings.speed_gate)

    dt = np.diff(t)
    F = np.eye(2)[None, :, :] + dt[:, None, None] * A[:-1]
    g = dt[:, None] * B[:-1, :, 0] * delta[:-1, None]
    scale = np.sqrt(dt / settings.reference_dt)
    sigma_q = np.empty((n - 1, 2))
    sigma_q[:, 0] = settings.model_beta * scale
    sigma_q[:, 1] = settings.model_yaw_rate * scale
    sigma_q[low[:-1]] *= settings.low_speed_inflation
    # a time gap restarts the chain: no dynamics across it, the prior's sigmas instead
    gap = inputs.time_gap[start : start + n - 1]
    F[gap] = 0.0
    g[gap] = 0.0
    sigma_q[gap] = (settings.prior_beta, settings.prior_yaw_rate)

    wz = inputs.wz[sl]
    ay = inputs.ay[sl]
    Hu = np.zeros((n, 3, 2))
    zu = np.zeros((n, 3))
    sigma_u = np.full((n, 3), np.inf)
    # yaw rate (unary on r_k)
    Hu[:, 0, 1] = 1.0
    ok = np.isfinite(wz)
    zu[ok, 0] = wz[ok]
    sigma_u[ok, 0] = settings.yaw_rate
    # lateral acceleration (binary on beta_k, r_k), above the speed gate only
    Hu[:, 1, :] = C[:, 1, :]
    ok = np.isfinite(ay) & ~low
    zu[ok, 1] = ay[ok] - D[ok, 1, 0] * delta[ok]
    sigma_u[ok, 1] = settings.lateral_acceleration
    # low-speed kinematic sideslip (unary on beta_k)
    Hu[:, 2, 0] = 1.0
    zu[low, 2] = np.arctan(vehicle.lr * np.tan(np.clip(delta[low], -1.2, 1.2)) / vehicle.wheelbase)
    sigma_u[low, 2] = settings.low_speed_beta
    return SideslipGraph(
        F=np.ascontiguousarray(F),
        g=np.ascontiguousarray(g),
        sigma_q=sigma_q,
        Hu=Hu,
        zu=zu,
        sigma_u=sigma_u,
        x0=np.zeros(2),
        sigma0=np.array([settings.prior_beta, settings.prior_yaw_rate]),
        low_speed=low,
    )


def sideslip_graph(
    drive: Drive, vehicle: Vehicle, settings: FactorGraphSettings = DEFAULT_SETTINGS
) -> SideslipGraph:
    """The whole seed-002 graph of ``drive`` (used by fg_batch, kf_linear and the peers)."""
    return build_graph(graph_inputs(drive, vehicle, settings), vehicle, settings)


def solve_batch(graph: SideslipGraph) -> tuple[FloatArray, FloatArray]:
    """Batch solution: ``(x, var)`` of shape (N, 2), one banded Cholesky + selected inverse."""
    lam0, eta0 = graph.prior_information
    ab, rhs = assemble_chain(graph.F, graph.g, graph.wq, graph.Hu, graph.zu, graph.wu, lam0, eta0)
    x, cb = solve_chain(ab, rhs)
    sb = selected_inverse(cb)
    return x.reshape(-1, 2), sb[0].reshape(-1, 2)


def solve_lag(
    inputs: GraphInputs,
    vehicle: Vehicle,
    settings: FactorGraphSettings = DEFAULT_SETTINGS,
    chunk: int = LAG_CHUNK,
) -> tuple[FloatArray, FloatArray]:
    """Fixed-lag solution: state k from the data up to k + window, streamed in chunks.

    Each chunk of ``chunk`` rows builds only its own factors plus ``window`` rows of look-ahead
    and hands the marginalised prior to the next chunk, so the working memory is O(chunk +
    window) whatever the drive length (the on-line smoother needs only the window).
    """
    n = inputs.t.size
    lag = int(settings.window)
    x = np.zeros((n, 2))
    var = np.zeros((n, 2))
    lam = np.diag(1.0 / np.array([settings.prior_beta, settings.prior_yaw_rate]) ** 2)
    eta = np.zeros(2)  # prior mean 0
    for a in range(0, n, chunk):
        b = min(a + chunk, n)
        graph = build_graph(inputs, vehicle, settings, a, min(b + max(lag, 1), n))
        xs, vs, ok, lam, eta = fixed_lag_chain(
            graph.F, graph.g, graph.wq, graph.Hu, graph.zu, graph.wu, lam, eta, lag, b - a
        )
        if not ok:
            raise np.linalg.LinAlgError("fixed-lag window not positive definite")
        x[a:b] = xs
        var[a:b] = vs
    return x, var


@numba.njit(cache=True)
def _kalman(
    F: FloatArray,
    g: FloatArray,
    wq: FloatArray,
    Hu: FloatArray,
    zu: FloatArray,
    wu: FloatArray,
    x0: FloatArray,
    P0: FloatArray,
) -> tuple[FloatArray, FloatArray]:
    """Linear KF: scalar Joseph-form updates with each present unary factor, then predict.

    Written out with preallocated buffers so the loop allocates nothing.
    """
    n = Hu.shape[0]
    M = Hu.shape[1]
    nx = Hu.shape[2]
    x = x0.copy()
    P = P0.copy()
    xs = np.zeros((n, nx))
    vs = np.zeros((n, nx))
    Ph = np.zeros(nx)
    xn = np.zeros(nx)
    FP = np.zeros((nx, nx))
    K = np.zeros(nx)
    IKH = np.zeros((nx, nx))
    for k in range(n):
        for m in range(M):
            w = wu[k, m]
            if w == 0.0:
                continue
            s = 1.0 / w
            innov = zu[k, m]
            for i in range(nx):
                acc = 0.0
                for j in range(nx):
                    acc += P[i, j] * Hu[k, m, j]
                Ph[i] = acc
                s += Hu[k, m, i] * acc
                innov -= Hu[k, m, i] * x[i]
            for i in range(nx):
                K[i] = Ph[i] / s
                x[i] += K[i] * innov
            # Joseph form: P = (I - K h') P (I - K h')' + K K' / w
            for i in range(nx):
                for j in range(nx):
                    IKH[i, j] = (1.0 if i == j else 0.0) - K[i] * Hu[k, m, j]
            for i in range(nx):
                for j in range(nx):
                    acc = 0.0
                    for c in range(nx):
                        acc += IKH[i, c] * P[c, j]
                    FP[i, j] = acc
            for i in range(nx):
                for j in range(i + 1):
                    acc = K[i] * K[j] / w
                    for c in range(nx):
                        acc += FP[i, c] * IKH[j, c]
                    P[i, j] = acc
                    P[j, i] = acc
        for i in range(nx):
            xs[k, i] = x[i]
            vs[k, i] = P[i, i]
        if k < n - 1:
            for i in range(nx):
                acc = g[k, i]
                for j in range(nx):
                    acc += F[k, i, j] * x[j]
                xn[i] = acc
                for j in range(nx):
                    acc = 0.0
                    for c in range(nx):
                        acc += F[k, i, c] * P[c, j]
                    FP[i, j] = acc
            for i in range(nx):
                x[i] = xn[i]
                for j in range(i + 1):
                    acc = 0.0
                    for c in range(nx):
                        acc += FP[i, c] * F[k, j, c]
                    P[i, j] = acc
                    P[j, i] = acc
                P[i, i] += 1.0 / wq[k, i]
    return xs, vs


def solve_kalman(graph: SideslipGraph) -> tuple[FloatArray, FloatArray]:
    """Kalman filter on the same factors: F, g, Q = diag(sigma_q^2), R = sigma_u^2, P0."""
    return _kalman(
        graph.F, graph.g, graph.wq, graph.Hu, graph.zu, graph.wu, graph.x0,
        np.diag(graph.sigma0**2),
    )  # fmt: skip


def _estimate(
    name: str,
    drive: Drive,
    low_speed: NDArray[np.bool_],
    x: FloatArray,
    var: FloatArray,
    settings: FactorGraphSettings,
    extra: dict[str, object],
) -> Estimate:
    std = np.sqrt(np.maximum(var, 0.0))
    params: dict[str, object] = {
        "settings": asdict(settings),
        "accelerometer": "raw lateral specific force (no roll/bank compensation, as the paper)",
        "low_speed_fraction": float(low_speed.mean()) if low_speed.size else 0.0,
        **extra,
    }
    return Estimate(
        name,
        drive.t,
        {"beta": x[:, 0].copy(), "r": x[:, 1].copy(), "beta_std": std[:, 0], "r_std": std[:, 1]},
        params,
    )


@register(
    "fg_batch",
    columns=COLUMNS,
    summary="factor-graph batch smoother on the linear single-track model (off-line)",
    paper=PAPER,
    vehicle_params=VEHICLE_PARAMS,
    settings=FactorGraphSettings,
)
def fg_batch(
    drive: Drive, vehicle: Vehicle, settings: FactorGraphSettings = DEFAULT_SETTINGS
) -> Estimate:
    """Batch factor-graph smoother of the whole drive (module docstring), O(N)."""
    graph = sideslip_graph(drive, vehicle, settings)
    x, var = solve_batch(graph)
    return _estimate("fg_batch", drive, graph.low_speed, x, var, settings, {"solver": "banded Cholesky"})


@register(
    "fg_lag",
    columns=COLUMNS,
    summary="factor-graph fixed-lag smoother (window 5) on the linear single-track model",
    paper=PAPER,
    vehicle_params=VEHICLE_PARAMS,
    settings=FactorGraphSettings,
)
def fg_lag(
    drive: Drive, vehicle: Vehicle, settings: FactorGraphSettings = DEFAULT_SETTINGS
) -> Estimate:
    """Fixed-lag factor-graph smoother: each row's state from the data up to ``window`` rows
    later (an on-line delay of window x dt), oldest state marginalised into the next prior."""
    inputs = graph_inputs(drive, vehicle, settings)
    x, var = solve_lag(inputs, vehicle, settings)
    return _estimate(
        "fg_lag", drive, inputs.low_speed, x, var, settings,
        {"window": int(settings.window), "output_delay_samples": int(settings.window)},
    )  # fmt: skip


@register(
    "kf_linear",
    columns=COLUMNS,
    summary="linear Kalman filter on the same single-track model and noise (seed 002's baseline)",
    paper=PAPER,
    vehicle_params=VEHICLE_PARAMS,
    settings=FactorGraphSettings,
)
def kf_linear(
    drive: Drive, vehicle: Vehicle, settings: FactorGraphSettings = DEFAULT_SETTINGS
) -> Estimate:
    """Linear Kalman filter with F = I + dt A, Q = diag(model sigmas^2), R = factor sigmas^2."""
    graph = sideslip_graph(drive, vehicle, settings)
    x, var = solve_kalman(graph)
    return _estimate("kf_linear", drive, graph.low_speed, x, var, settings, {"filter": "Joseph form"})
