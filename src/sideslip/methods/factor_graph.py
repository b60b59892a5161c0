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
Both use the same settings here (the paper tuned its KF and FG differently, its Section 4).

Noise settings (:class:`FactorGraphSettings`): ``preset`` "auto" (default) identifies the a_y
and beta-model sigmas from the drive (:mod:`sideslip.methods.fg_tuning`: least error of the
gyro predicted 0.3 s ahead), "paper" is the authors' published set, "physics" fixed values
argued in the dataclass; explicit values override.  Model sigmas are per ``reference_dt``
step and scale with sqrt(dt/reference_dt).  Honest 1-sigma: block sums of the graph's Kalman
innovations over 2 s windows inflate the variance where the model stops fitting (``health``),
and a vehicle file's stiffness error, which no test on the drive can see, adds
(``stiffness_rel_sigma`` x slip angle)^2 to beta's variance.

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
from dataclasses import asdict, dataclass, replace
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from sideslip.drive import Drive
from sideslip.estimate import Estimate
from sideslip.filters.banded import fixed_lag_chain
from sideslip.methods import fg_solve
from sideslip.methods.fg_solve import solve_batch as solve_batch
from sideslip.methods.fg_solve import solve_kalman as solve_kalman
from sideslip.methods.fg_tuning import (
    BLOCK_S,
    PRESETS,
    SIGMA_FIELDS,
    WINDOW_S,
    Tuning,
    block_consistency,
    choose_sigmas,
)
from sideslip.methods.registry import SPEED, register
from sideslip.models.single_track import continuous_arrays
from sideslip.signals import hold, vehicle_speed
from sideslip.vehicle import Vehicle

FloatArray = NDArray[np.float64]

PAPER = "seed 002 (Leanza, Reina, Blanco-Claraco 2021), eqs 4-7, 16-18"
COLUMNS = ("wz", "ay", "steer", SPEED)
VEHICLE_PARAMS = ("mass", "yaw_inertia", "lf", "lr", "cf", "cr")


Preset = Literal["auto", "paper", "physics"]


@dataclass(frozen=True)
class FactorGraphSettings:
    """Sigmas (1-sigma of each factor's residual) and options of the seed-002 graph.

    The four sigmas come from ``preset`` unless set explicitly (an explicit value overrides
    the preset):

    * ``"auto"`` (default): ``lateral_acceleration`` and ``model_beta`` identified from the
      drive (:mod:`sideslip.methods.fg_tuning`: least error of the gyro predicted 0.3 s ahead),
      ``yaw_rate`` and ``model_yaw_rate`` from ``"physics"``;
    * ``"paper"``: the seed-002 authors' values (beta dynamic 4e-3, yaw-rate dynamic 0.9e-2,
      yaw-rate observation 1e-2, lateral acceleration 7; their code's defaults);
    * ``"physics"``: the fixed values argued below (this package's earlier default).

    Attributes
    ----------
    preset : "auto", "paper" or "physics" (above).
    yaw_rate : rad/s.  Yaw-rate factor r_k = wz_k: MEMS gyro white noise (~0.005 rad/s at
        100 Hz) plus an uncompensated bias of the same order; physics 0.01.
    lateral_acceleration : m/s^2.  a_y factor: accelerometer noise (~0.05 m/s^2) is small
        against the linear-tyre model error near the grip limit (~0.5 m/s^2 at 0.6 g with
        tyres 10 % past linear) and the suspension-roll term (~5 % of a_y); physics 0.5.
    model_beta : rad per ``reference_dt`` step.  beta dynamic factor: an error of 1 m/s^2 in
        the modelled tyre force per mass at 10 m/s is 0.1 rad/s of beta rate, 0.001 rad/step.
    model_yaw_rate : rad/s per ``reference_dt`` step.  r dynamic factor: a yaw-moment error of
        ~1000 N m on Iz ~ 1000 kg m^2 is 1 rad/s^2, 0.01 rad/s per step.
    prior_beta : rad.  Prior on beta_0 = 0: drives start near straight running; 3 deg.
    prior_yaw_rate : rad/s.  Prior on r_0 = 0; the first gyro sample overrides it.
    reference_dt : s.  Step at which the model sigmas are quoted (sigma ~ sqrt(dt)).
    speed_gate : m/s.  Below it (and reversing) the low-speed handling of the module docstring.
    low_speed_beta : rad.  Sigma of the low-speed kinematic pseudo-measurement on beta.
    low_speed_inflation : factor on the model sigmas below the speed gate.
    window : samples.  fg_lag's window: the dynamic steps after the prior block (paper: 5).
    max_step : s.  A time step longer than this (a gap in the recording) carries no model
        information: the dynamic factor across it becomes a fresh prior (restart).
    consistency : inflate the 1-sigma where the windowed NIS of the factors' residuals exceeds
        its chi^2 bound (:mod:`sideslip.filters.consistency`), and report ``health``.
    stiffness_rel_sigma : 1-sigma relative error of the vehicle file's cornering stiffness,
        added to beta's variance as (stiffness_rel_sigma x the larger axle slip angle)^2.  A stiffness
        scaled by s moves the slip angle inferred from a force by (1 - 1/s) of itself, the same
        for the whole graph, so neither the innovations nor any other test on the drive can see
        it (measured: a file 30 % low leaves the windowed NIS inside its bound).  Users' files
        are 20-35 % off (nominal tyre data against the effective axle stiffness): 0.3 makes a
        file 30 % off a 1-sigma error.  0 trusts the file.
    """

    preset: Preset = "auto"
    yaw_rate: float | None = None
    lateral_acceleration: float | None = None
    model_beta: float | None = None
    model_yaw_rate: float | None = None
    prior_beta: float = 0.05
    prior_yaw_rate: float = 0.05
    reference_dt: float = 0.01
    speed_gate: float = 3.0
    low_speed_beta: float = 0.02
    low_speed_inflation: float = 10.0
    window: int = 5
    max_step: float = 0.25
    consistency: bool = True
    stiffness_rel_sigma: float = 0.3

    def __post_init__(self) -> None:
        if self.preset not in ("auto", *PRESETS):
            raise ValueError(
                f"FactorGraphSettings.preset = {self.preset!r}: expected 'auto', "
                + ", ".join(repr(p) for p in PRESETS)
            )
        for name in (
            *SIGMA_FIELDS, "prior_beta", "prior_yaw_rate", "reference_dt", "speed_gate",
            "low_speed_beta", "low_speed_inflation", "max_step",
        ):  # fmt: skip
            value = getattr(self, name)
            if value is None and name in SIGMA_FIELDS:
                continue
            if isinstance(value, bool) or not (
                isinstance(value, int | float) and math.isfinite(value) and value > 0
            ):
                raise ValueError(f"FactorGraphSettings.{name} = {value!r}: expected a number > 0")
        if not (math.isfinite(self.stiffness_rel_sigma) and 0 <= self.stiffness_rel_sigma < 1):
            raise ValueError(
                f"FactorGraphSettings.stiffness_rel_sigma = {self.stiffness_rel_sigma!r}: "
                "expected a number in [0, 1)"
            )
        if int(self.window) != self.window or self.window < 0:
            raise ValueError(
                f"FactorGraphSettings.window = {self.window!r}: expected an integer >= 0"
            )

    def fixed_sigmas(self) -> dict[str, float | None]:
        """Each sigma as set or given by a named preset; None where "auto" identifies it."""
        table = PRESETS.get(self.preset, {})
        return {k: getattr(self, k) if getattr(self, k) is not None else table.get(k)
                for k in SIGMA_FIELDS}  # fmt: skip

    def with_sigmas(self, sigmas: dict[str, float]) -> FactorGraphSettings:
        """These settings with all four sigmas given."""
        changes: dict[str, Any] = {k: float(sigmas[k]) for k in SIGMA_FIELDS}
        return replace(self, **changes)

    def sigma(self, name: str) -> float:
        """A sigma of resolved settings (:meth:`with_sigmas`); ValueError if still unset."""
        value = getattr(self, name)
        if value is None:
            raise ValueError(f"FactorGraphSettings.{name} is not resolved (preset 'auto')")
        return float(value)


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
    b_steer = B[:, :, 0].copy()  # memory: the steering column is all the graph reads of B
    del B, _

    dt = np.diff(t)
    F = np.eye(2)[None, :, :] + dt[:, None, None] * A[:-1]
    del A
    g = dt[:, None] * b_steer[:-1] * delta[:-1, None]
    del b_steer
    _, _, C, D = continuous_arrays(vehicle, inputs.v_measurement[sl], v_min=settings.speed_gate)
    del _
    scale = np.sqrt(dt / settings.reference_dt)
    sigma_q = np.empty((n - 1, 2))
    sigma_q[:, 0] = settings.sigma("model_beta") * scale
    sigma_q[:, 1] = settings.sigma("model_yaw_rate") * scale
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
    sigma_u[ok, 0] = settings.sigma("yaw_rate")
    # lateral acceleration (binary on beta_k, r_k), above the speed gate only
    Hu[:, 1, :] = C[:, 1, :]
    ok = np.isfinite(ay) & ~low
    zu[ok, 1] = ay[ok] - D[ok, 1, 0] * delta[ok]
    sigma_u[ok, 1] = settings.sigma("lateral_acceleration")
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


@dataclass(frozen=True)
class Prepared:
    """A drive ready to solve: inputs, settings with every sigma resolved, how they were chosen,
    and the graph when the tuning already built it."""

    inputs: GraphInputs
    settings: FactorGraphSettings
    tuning: Tuning
    graph: SideslipGraph | None


def _reweighted(unit: SideslipGraph, s: FactorGraphSettings, gap: NDArray[np.bool_]) -> SideslipGraph:
    """The graph built with unit sigmas (``unit``) rescaled to the sigmas of ``s``."""
    sigma_q = unit.sigma_q.copy()
    move = ~gap
    sigma_q[move, 0] *= s.sigma("model_beta")
    sigma_q[move, 1] *= s.sigma("model_yaw_rate")
    sigma_u = unit.sigma_u.copy()
    sigma_u[:, 0] *= s.sigma("yaw_rate")
    sigma_u[:, 1] *= s.sigma("lateral_acceleration")
    return replace(unit, sigma_q=sigma_q, sigma_u=sigma_u)


def prepare(drive: Drive, vehicle: Vehicle, settings: FactorGraphSettings = DEFAULT_SETTINGS) -> Prepared:
    """Inputs of ``drive`` and the sigmas of ``settings``: from the preset or set, or, for
    "auto", identified from the drive (:func:`sideslip.methods.fg_tuning.choose_sigmas`)."""
    inputs = graph_inputs(drive, vehicle, settings)
    fixed = settings.fixed_sigmas()
    if all(v is not None for v in fixed.values()):
        label = "set" if settings.preset == "auto" else f"{settings.preset} preset"
        source = {k: ("set" if getattr(settings, k) is not None else label) for k in fixed}
        values = {k: float(v) for k, v in fixed.items() if v is not None}
        return Prepared(inputs, settings.with_sigmas(values), Tuning(values, source, None, []), None)
    unit_settings = settings.with_sigmas(dict.fromkeys(SIGMA_FIELDS, 1.0))
    unit = build_graph(inputs, vehicle, unit_settings)
    dt = float(np.median(np.diff(inputs.t))) if inputs.t.size > 1 else settings.reference_dt
    tuning = choose_sigmas(
        fixed, unit.F, unit.g, unit.wq, unit.Hu, unit.zu, unit.wu, unit.x0,
        np.diag(unit.sigma0**2), dt, ~inputs.low_speed, inputs.time_gap,
    )  # fmt: skip
    resolved = settings.with_sigmas(tuning.sigmas)
    return Prepared(inputs, resolved, tuning, _reweighted(unit, resolved, inputs.time_gap))


def sideslip_graph(
    drive: Drive, vehicle: Vehicle, settings: FactorGraphSettings = DEFAULT_SETTINGS
) -> SideslipGraph:
    """The whole seed-002 graph of ``drive`` (used by fg_batch, kf_linear and the peers)."""
    return _graph(prepare(drive, vehicle, settings), vehicle)


def _graph(prep: Prepared, vehicle: Vehicle) -> SideslipGraph:
    return prep.graph if prep.graph is not None else build_graph(prep.inputs, vehicle, prep.settings)


def solve_lag(
    inputs: GraphInputs,
    vehicle: Vehicle,
    settings: FactorGraphSettings,
    chunk: int = LAG_CHUNK,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Fixed-lag solution: state k from the data up to k + window, streamed in chunks;
    ``(x, var, cov)`` as :func:`solve_batch`.  ``settings`` must have its sigmas resolved
    (:func:`prepare`).

    Each chunk of ``chunk`` rows builds only its own factors plus ``window`` rows of look-ahead
    and hands the marginalised prior to the next chunk, so the working memory is O(chunk +
    window) whatever the drive length (the on-line smoother needs only the window).
    """
    n = inputs.t.size
    lag = int(settings.window)
    x = np.zeros((n, 2))
    var = np.zeros((n, 2))
    cov = np.zeros(n)
    lam = np.diag(1.0 / np.array([settings.prior_beta, settings.prior_yaw_rate]) ** 2)
    eta = np.zeros(2)  # prior mean 0
    for a in range(0, n, chunk):
        b = min(a + chunk, n)
        graph = build_graph(inputs, vehicle, settings, a, min(b + max(lag, 1), n))
        xs, vs, cs, ok, lam, eta = fixed_lag_chain(
            graph.F, graph.g, graph.wq, graph.Hu, graph.zu, graph.wu, lam, eta, lag, b - a
        )
        if not ok:
            raise np.linalg.LinAlgError("fixed-lag window not positive definite")
        x[a:b] = xs
        var[a:b] = vs
        cov[a:b] = cs[:, 0]
    return x, var, cov


def _estimate(
    name: str,
    drive: Drive,
    prep: Prepared,
    innovations: tuple[FloatArray, FloatArray] | None,
    x: FloatArray,
    var: FloatArray,
    cov: FloatArray,
    settings: FactorGraphSettings,
    causal: bool,
    extra: dict[str, object],
    vehicle: Vehicle,
) -> Estimate:
    """Series, params and the consistency-inflated 1-sigma of one of the three methods.

    ``innovations``: the graph's Kalman-filter innovations and their variances (N, 3), tested
    in blocks (:func:`sideslip.methods.fg_tuning.block_consistency`) over 2 s windows, trailing for the
    on-line kf_linear and fg_lag, centred for fg_batch; None when ``settings.consistency`` is
    off.  Where a window fails, the variances of beta and r are multiplied by its NIS ratio.
    """
    low_speed = prep.inputs.low_speed
    params: dict[str, object] = {
        "settings": asdict(settings),
        "tuning": prep.tuning.params(),
        "accelerometer": "raw lateral specific force (no roll/bank compensation, as the paper)",
        "low_speed_fraction": float(low_speed.mean()) if low_speed.size else 0.0,
        **extra,
    }
    var = np.maximum(var, 0.0)
    out: dict[str, FloatArray] = {"beta": x[:, 0].copy(), "r": x[:, 1].copy()}
    inn: dict[str, FloatArray] = {}
    if innovations is not None:
        nu, S = innovations
        check = block_consistency(drive.t, nu[:, :2], S[:, :2], causal)
        var *= check.inflation[:, None]  # var is this function's own copy (above)
        out["health"] = check.health
        params["health"] = {**check.summary(drive.t), "test": (
            f"sums of the graph's Kalman innovations (gyro, a_y) over {BLOCK_S:g} s blocks, "
            f"chi2 99 % over {WINDOW_S:g} s windows; variance x NIS ratio where it fails")}
        inn = {"wz": nu[:, 0], "wz_s": S[:, 0], "ay": nu[:, 1], "ay_s": S[:, 1]}
    if settings.stiffness_rel_sigma > 0:
        # axle slip angles (module docstring) at the model speed; the larger one
        v = prep.inputs.v_measurement
        alpha_r = vehicle.lr * x[:, 1] / v - x[:, 0]
        alpha_f = prep.inputs.delta - x[:, 0] - vehicle.lf * x[:, 1] / v
        alpha = np.maximum(np.abs(alpha_f), np.abs(alpha_r))
        var[:, 0] += (settings.stiffness_rel_sigma * alpha) ** 2
        params["stiffness_rel_sigma"] = settings.stiffness_rel_sigma
    std = np.sqrt(var, out=var)
    out["beta_std"] = std[:, 0].copy()
    out["r_std"] = std[:, 1].copy()
    del std, var
    return Estimate(name, drive.t, out, params, inn)


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
    prep = prepare(drive, vehicle, settings)
    graph = _graph(prep, vehicle)
    prep = replace(prep, graph=None)  # memory: the graph goes once assembled
    parts = fg_solve.factor_parts(graph)
    x0, P0, (lam0, eta0) = graph.x0, np.diag(graph.sigma0**2), graph.prior_information
    del graph  # memory: its sigmas go before the filter and the normal equations run
    inn = fg_solve.innovations_on_parts(parts, x0, P0) if settings.consistency else None
    system = fg_solve.assemble_parts(parts, lam0, eta0)
    del parts
    x, var, cov = fg_solve.solve_system(system)
    return _estimate("fg_batch", drive, prep, inn, x, var, cov,
                     settings, False, {"solver": "banded Cholesky"}, vehicle)  # fmt: skip


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
    later (an on-line delay of window x dt), oldest state marginalised into the next prior.
    The "auto" sigmas are identified off-line from the whole drive (module fg_tuning)."""
    prep = prepare(drive, vehicle, settings)
    inn = None
    if settings.consistency:  # the graph's Kalman innovations, its sigmas freed first (memory)
        graph = _graph(prep, vehicle)
        parts, x0, P0 = fg_solve.factor_parts(graph), graph.x0, np.diag(graph.sigma0**2)
        del graph
        prep = replace(prep, graph=None)
        inn = fg_solve.innovations_on_parts(parts, x0, P0)
        del parts
    prep = replace(prep, graph=None)  # memory: the lag solver builds its own chunks
    x, var, cov = solve_lag(prep.inputs, vehicle, prep.settings)
    return _estimate(
        "fg_lag", drive, prep, inn, x, var, cov, settings, True,
        {"window": int(settings.window), "output_delay_samples": int(settings.window)}, vehicle,
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
    prep = prepare(drive, vehicle, settings)
    graph = _graph(prep, vehicle)
    prep = replace(prep, graph=None)  # memory: only the filter's inputs are kept
    parts, x0, P0 = fg_solve.factor_parts(graph), graph.x0, np.diag(graph.sigma0**2)
    del graph  # memory: its sigmas go before the filter runs
    x, var, cov, nu, S = fg_solve.kalman_on_parts(parts, x0, P0)
    del parts
    inn = (nu, S) if settings.consistency else None
    return _estimate("kf_linear", drive, prep, inn, x, var, cov, settings, True,
                     {"filter": "Joseph form"}, vehicle)  # fmt: skip
