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
Memory: no method holds the whole drive's factors.  The tuning, the batch assembly and the
Kalman filter build the graph in chunks of ``GRAPH_CHUNK`` rows (bit-identical to the whole
graph at once); fg_batch keeps only the banded normal equations (64 B/row) and its outputs.
Both use the same settings here (the paper tuned its KF and FG differently, its Section 4).

Noise settings (:class:`~sideslip.methods.fg_settings.FactorGraphSettings`, in its own module):
``preset`` "auto" (default) identifies the a_y and beta-model sigmas from the drive
(:mod:`sideslip.methods.fg_tuning`: least error of the gyro predicted 0.3 s ahead), "paper" is
the authors' published set, "physics" fixed values argued in the dataclass; explicit values
override. Model sigmas are per ``reference_dt`` step and scale with sqrt(dt/reference_dt).
Honest 1-sigma: block sums of the graph's Kalman innovations over 2 s windows inflate the
variance where the model stops fitting (``health``), and a vehicle file's stiffness error,
which no test on the drive can see, adds (``stiffness_rel_sigma`` x slip angle)^2 to beta's
variance; where the test fails, the linear tyre relation itself is in doubt (an axle near its
friction slips more than F / C: ``limit_rel_sigma`` x health joins that relative error), and
an accelerometer offset the a_y factor reads as tyre force adds its slip
(``accel_offset_sigma`` x m / (C_f + C_r)).

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

from collections.abc import Iterator
from dataclasses import asdict, dataclass, replace
from functools import cached_property

import numpy as np
from numpy.typing import NDArray

from sideslip.calibrate.result import Fitted
from sideslip.calibrate.sensors import drive_gyro_bias, gyro_zero_params, subtracted_zero
from sideslip.calibrate.steer_zero import drive_steer_offset, steer_zero_params, subtracted_offset
from sideslip.drive import Drive
from sideslip.estimate import Estimate
from sideslip.filters.banded import add_chain_factors, fixed_lag_chain, solve_chain
from sideslip.methods.fg_kernels import band_marginals, chain_factors, one_sigma
from sideslip.methods.fg_settings import DEFAULT_SETTINGS, FactorGraphSettings
from sideslip.methods.fg_tuning import (
    BLOCK_S,
    SIGMA_FIELDS,
    WINDOW_S,
    Tuning,
    UnitChunk,
    block_consistency,
    chain_innovations,
    chain_kalman,
    chain_kalman_into,
    choose_sigmas,
)
from sideslip.methods.registry import SPEED, register
from sideslip.signals import hold, vehicle_speed
from sideslip.vehicle import Vehicle

FloatArray = NDArray[np.float64]

PAPER = "seed 002 (Leanza, Reina, Blanco-Claraco 2021), eqs 4-7, 16-18"
COLUMNS = ("wz", "ay", "steer", SPEED)
VEHICLE_PARAMS = ("mass", "yaw_inertia", "lf", "lr", "cf", "cr")


LAG_CHUNK = 4096  # rows per chunk of the streamed fixed-lag smoother
# rows per chunk of the graph built at once by the tuning, the batch assembly and the filter
# (the graph is never held for the whole drive: ~250 B/row of factors and weights)
GRAPH_CHUNK = 16384


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

    @cached_property
    def wq(self) -> FloatArray:
        """Weights 1/sigma^2 of the dynamic factors, (N-1, 2) (computed once per graph)."""
        return np.asarray(1.0 / self.sigma_q**2, dtype=float)

    @cached_property
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
    (length N - 1); ``wz`` and ``ay`` the raw samples as the drive stores them (float32 in a
    compact drive, float64 otherwise; NaN where the sensor has no fresh sample); ``gyro_zero``
    the drive's gyro zero the yaw-rate factors subtract (None: not asked for,
    ``FactorGraphSettings.zero_gyro``); ``steer_zero`` the drive's steering offset, already
    subtracted from ``delta`` where significant (None: not asked for,
    ``FactorGraphSettings.zero_steer``).
    """

    t: FloatArray
    delta: FloatArray
    v_dynamics: FloatArray
    v_measurement: FloatArray
    time_gap: NDArray[np.bool_]
    low_speed: NDArray[np.bool_]
    wz: NDArray[np.floating]
    ay: NDArray[np.floating]
    gyro_zero: Fitted | None = None
    steer_zero: Fitted | None = None

    @property
    def wz_zero(self) -> float:
        """rad/s subtracted from every gyro sample (:func:`~sideslip.calibrate.sensors.subtracted_zero`)."""
        return subtracted_zero(self.gyro_zero) if self.gyro_zero is not None else 0.0


def _as_stored_float(values: object) -> NDArray[np.floating]:
    """A column as stored when it is float32 or float64, else as float64."""
    arr = np.asarray(values)
    return arr if arr.dtype in (np.float32, np.float64) else arr.astype(float)


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
    # the sensor samples as stored (float32 in a compact drive): the compiled factor pass reads
    # each one into double precision exactly, so no float64 copy of the drive is kept
    wz, ay = (_as_stored_float(drive.data[k]) for k in ("wz", "ay"))
    zero = drive_gyro_bias(drive, vehicle) if settings.zero_gyro else None
    steer_zero = drive_steer_offset(drive, vehicle, zero) if settings.zero_steer else None
    if steer_zero is not None:
        delta = delta - subtracted_offset(steer_zero)
    return GraphInputs(t, delta, v_dynamics, v_measurement, gap, low, wz, ay, zero, steer_zero)


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
    # the single-track matrices row by row inside the compiled pass: dynamics at their speed
    # (clamped higher where forward Euler needs it, module docstring), a_y at the model speed
    model = np.array([vehicle.mass, vehicle.yaw_inertia, vehicle.lf, vehicle.lr, vehicle.cf,
                      vehicle.cr, settings.speed_gate], dtype=float)  # fmt: skip
    gap = inputs.time_gap[start : start + n - 1]
    sigmas = np.array([settings.sigma(k) for k in ("model_beta", "model_yaw_rate", "yaw_rate",
                                                   "lateral_acceleration")])  # fmt: skip
    F, g, sigma_q, Hu, zu, sigma_u = chain_factors(
        t, inputs.v_dynamics[sl], inputs.v_measurement[sl], model, delta, low, gap,
        inputs.wz[sl], inputs.ay[sl], sigmas,
        settings.reference_dt, settings.low_speed_inflation, settings.prior_beta,
        settings.prior_yaw_rate, settings.low_speed_beta,
    )  # fmt: skip
    zu[:, 0] -= inputs.wz_zero  # the drive's gyro zero (rows without a sample have sigma inf)
    # low-speed kinematic sideslip (unary on beta_k)
    zu[low, 2] = np.arctan(vehicle.lr * np.tan(np.clip(delta[low], -1.2, 1.2)) / vehicle.wheelbase)
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
    """A drive ready to solve: inputs, settings with every sigma resolved and how they were
    chosen.  ``unit_scaled``: the tuning searched the sigmas on the graph built with unit
    sigmas, and the graph is built that way and rescaled (:func:`_reweighted`), exactly as
    the tuning saw it."""

    inputs: GraphInputs
    settings: FactorGraphSettings
    tuning: Tuning
    unit_scaled: bool


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


def prepare(
    drive: Drive, vehicle: Vehicle, settings: FactorGraphSettings = DEFAULT_SETTINGS
) -> Prepared:
    """Inputs of ``drive`` and the sigmas of ``settings``: from the preset or set, or, for
    "auto", identified from the drive (:func:`sideslip.methods.fg_tuning.choose_sigmas`, on
    the unit-sigma graph built chunk by chunk: nothing of the graph is kept)."""
    inputs = graph_inputs(drive, vehicle, settings)
    fixed = settings.fixed_sigmas()
    if all(v is not None for v in fixed.values()):
        label = "set" if settings.preset == "auto" else f"{settings.preset} preset"
        source = {k: ("set" if getattr(settings, k) is not None else label) for k in fixed}
        values = {k: float(v) for k, v in fixed.items() if v is not None}
        return Prepared(inputs, settings.with_sigmas(values), Tuning(values, source, None, []), False)
    unit_settings = settings.with_sigmas(dict.fromkeys(SIGMA_FIELDS, 1.0))

    def unit_chunks(look_ahead: int) -> Iterator[UnitChunk]:
        n = inputs.t.size
        for a in range(0, n, GRAPH_CHUNK):
            b = min(a + GRAPH_CHUNK, n)
            unit = build_graph(inputs, vehicle, unit_settings, a, min(b + look_ahead, n))
            yield a, b - a, unit.F, unit.g, unit.wq, unit.Hu, unit.zu, unit.wu

    dt = float(np.median(np.diff(inputs.t))) if inputs.t.size > 1 else settings.reference_dt
    sigma0 = np.array([settings.prior_beta, settings.prior_yaw_rate])
    tuning = choose_sigmas(fixed, unit_chunks, np.zeros(2), np.diag(sigma0**2), dt,
                           ~inputs.low_speed, inputs.time_gap)  # fmt: skip
    return Prepared(inputs, settings.with_sigmas(tuning.sigmas), tuning, tuning.criterion is not None)


def sideslip_graph(
    drive: Drive, vehicle: Vehicle, settings: FactorGraphSettings = DEFAULT_SETTINGS
) -> SideslipGraph:
    """The whole seed-002 graph of ``drive`` (the peers; the methods build it in chunks)."""
    return _graph(prepare(drive, vehicle, settings), vehicle)


def _graph(prep: Prepared, vehicle: Vehicle, start: int = 0, stop: int | None = None) -> SideslipGraph:
    """The graph of rows ``start .. stop-1`` with the prepared sigmas (the unit-sigma graph
    rescaled when the tuning chose them on it: the same numbers as the tuning's graph)."""
    if not prep.unit_scaled:
        return build_graph(prep.inputs, vehicle, prep.settings, start, stop)
    unit = build_graph(prep.inputs, vehicle, prep.settings.with_sigmas(dict.fromkeys(SIGMA_FIELDS, 1.0)),
                       start, stop)  # fmt: skip
    return _reweighted(unit, prep.settings, prep.inputs.time_gap[start : start + unit.F.shape[0]])


def _chunks(
    prep: Prepared, vehicle: Vehicle, chunk: int = GRAPH_CHUNK
) -> Iterator[tuple[int, int, int, SideslipGraph]]:
    """``(a, b, lo, graph)`` for consecutive chunks of rows a .. b-1: the graph of rows
    lo = max(a - 1, 0) .. b (one row either side where the drive has it: the dynamic factor
    into row a and the one out of row b - 1)."""
    n = prep.inputs.t.size
    for a in range(0, n, chunk):
        b = min(a + chunk, n)
        lo = max(a - 1, 0)
        yield a, b, lo, _graph(prep, vehicle, lo, min(b + 1, n))


def solve_batch(graph: SideslipGraph) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Batch solution: ``(x, var, cov)``: (N, 2) means and marginal variances and the (N,)
    beta-r covariance of each row; one banded Cholesky + selected inverse."""
    n = graph.Hu.shape[0]
    lam0, eta0 = graph.prior_information
    ab, rhs = _prior_band(n, lam0, eta0)
    add_chain_factors(ab, rhs, graph.F, graph.g, graph.wq, graph.Hu, graph.zu, graph.wu, 0, 0)
    return _solve_band(ab, rhs)


def _prior_band(n: int, lam0: FloatArray, eta0: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Zero normal equations of an n-state chain (2 states each) holding the prior on x_0."""
    ab = np.zeros((4, 2 * n))
    rhs = np.zeros(2 * n)
    for i in range(2):
        rhs[i] += eta0[i]
        for j in range(i + 1):
            ab[i - j, j] += lam0[i, j]
    return ab, rhs


def _solve_band(ab: FloatArray, rhs: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Means, marginal variances and beta-r covariances from the normal equations, which
    the banded Cholesky and the substitutions overwrite (no copies)."""
    x, cb = solve_chain(ab, rhs, overwrite=True)
    var, cov = band_marginals(cb, 2)
    return x.reshape(-1, 2), var, cov


def _batch_pass(
    prep: Prepared, vehicle: Vehicle, with_innovations: bool, chunk: int = GRAPH_CHUNK
) -> tuple[FloatArray, FloatArray, FloatArray, tuple[FloatArray, FloatArray] | None]:
    """:func:`solve_batch` of the prepared graph assembled chunk by chunk (bit-identical,
    :func:`sideslip.filters.banded.add_chain_factors`), with ``with_innovations`` the
    graph's Kalman innovations of the gyro and a_y factors from the same chunks (the numbers
    of one :func:`~sideslip.methods.fg_tuning.chain_innovations` pass): the normal equations
    (64 B/row) are the only whole-drive array besides the outputs."""
    n = prep.inputs.t.size
    s = prep.settings
    sigma0 = np.array([s.prior_beta, s.prior_yaw_rate])
    lam0 = np.diag(1.0 / sigma0**2)
    ab, rhs = _prior_band(n, lam0, lam0 @ np.zeros(2))
    nu = np.full((n, 2), np.nan) if with_innovations else np.zeros((0, 2))
    S = np.full((n, 2), np.nan) if with_innovations else np.zeros((0, 2))
    x_kf, P_kf = np.zeros(2), np.diag(sigma0**2)
    for a, b, lo, graph in _chunks(prep, vehicle, chunk):
        add_chain_factors(ab, rhs, graph.F[: b - 1 - lo], graph.g, graph.wq, graph.Hu[: b - lo],
                          graph.zu, graph.wu, lo, a - lo)  # fmt: skip
        if with_innovations:  # the filter's prediction carries across the chunk boundary
            o, m = a - lo, b - a
            nu[a:b], S[a:b], x_kf, P_kf = chain_innovations(
                graph.F[o : o + m], graph.g[o : o + m], graph.wq[o : o + m], graph.Hu[o : o + m],
                graph.zu[o : o + m], graph.wu[o : o + m], x_kf, P_kf, 2,
            )  # fmt: skip
    x, var, cov = _solve_band(ab, rhs)
    return x, var, cov, ((nu, S) if with_innovations else None)


def _kalman_pass(
    prep: Prepared, vehicle: Vehicle, with_innovations: bool, chunk: int = GRAPH_CHUNK
) -> tuple[FloatArray, FloatArray, FloatArray, tuple[FloatArray, FloatArray] | None]:
    """:func:`solve_kalman` of the prepared graph, built and filtered chunk by chunk (the
    prediction carries across the boundaries: bit-identical); the innovations and S of the
    gyro and a_y factors only with ``with_innovations``."""
    n = prep.inputs.t.size
    s = prep.settings
    x = np.zeros((n, 2))
    var = np.zeros((n, 2))
    cov = np.zeros(n)
    n_keep = 2 if with_innovations else 0
    nu = np.full((n, n_keep), np.nan)
    S = np.full((n, n_keep), np.nan)
    x_kf, P_kf = np.zeros(2), np.diag(np.array([s.prior_beta, s.prior_yaw_rate]) ** 2)
    for a, b, lo, graph in _chunks(prep, vehicle, chunk):
        o, m = a - lo, b - a
        chain_kalman_into(
            graph.F[o : o + m], graph.g[o : o + m], graph.wq[o : o + m], graph.Hu[o : o + m],
            graph.zu[o : o + m], graph.wu[o : o + m], x_kf, P_kf, x[a:b], var[a:b], cov[a:b],
            nu[a:b], S[a:b],
        )  # fmt: skip
    return x, var, cov, ((nu, S) if with_innovations else None)


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
    x, var, cov, _ = _lag_pass(inputs, vehicle, settings, chunk, False)
    return x, var, cov


def _lag_pass(
    inputs: GraphInputs,
    vehicle: Vehicle,
    settings: FactorGraphSettings,
    chunk: int,
    with_innovations: bool,
) -> tuple[FloatArray, FloatArray, FloatArray, tuple[FloatArray, FloatArray] | None]:
    """:func:`solve_lag`, and with ``with_innovations`` the graph's Kalman innovations and
    their variances (:func:`solve_kalman`'s) from the same chunks' factors: the filter runs
    over each chunk's own rows and its prediction carries into the next chunk, so nothing is
    built twice (identical to one :func:`solve_kalman` pass over the whole graph)."""
    n = inputs.t.size
    lag = int(settings.window)
    x = np.zeros((n, 2))
    var = np.zeros((n, 2))
    cov = np.zeros(n)
    nu = np.full((n, 2), np.nan) if with_innovations else np.zeros((0, 2))
    S = np.full((n, 2), np.nan) if with_innovations else np.zeros((0, 2))
    lam = np.diag(1.0 / np.array([settings.prior_beta, settings.prior_yaw_rate]) ** 2)
    eta = np.zeros(2)  # prior mean 0
    x_kf = np.zeros(2)  # the filter's prediction at the chunk's first row
    P_kf = np.diag(np.array([settings.prior_beta, settings.prior_yaw_rate]) ** 2)
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
        if with_innovations:  # the filter's prediction carries across the chunk boundary
            m = b - a
            nu[a:b], S[a:b], x_kf, P_kf = chain_innovations(
                graph.F[:m], graph.g[:m], graph.wq[:m], graph.Hu[:m], graph.zu[:m],
                graph.wu[:m], x_kf, P_kf, 2,
            )  # fmt: skip
    return x, var, cov, ((nu, S) if with_innovations else None)


def solve_kalman(graph: SideslipGraph) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    """Kalman filter on the same factors: F, g, Q = diag(sigma_q^2), R = sigma_u^2, P0;
    ``(x, var, cov, innovation, S)`` (:func:`sideslip.methods.fg_tuning.chain_kalman`)."""
    return chain_kalman(
        graph.F, graph.g, graph.wq, graph.Hu, graph.zu, graph.wu, graph.x0,
        np.diag(graph.sigma0**2),
    )  # fmt: skip


def _zero_params(inputs: GraphInputs) -> dict[str, object]:
    out: dict[str, object] = {}
    if inputs.gyro_zero is None:
        out["gyro_zero"] = "off (FactorGraphSettings.zero_gyro): the samples as recorded"
    else:
        out.update(gyro_zero_params(inputs.gyro_zero))
    if inputs.steer_zero is None:
        out["steer_zero"] = "off (FactorGraphSettings.zero_steer): the steer as recorded"
    else:
        out.update(steer_zero_params(inputs.steer_zero))
    return out


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

    ``innovations``: the graph's Kalman-filter innovations and their variances (N, >= 2), tested
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
        **_zero_params(prep.inputs),
        **extra,
    }
    out: dict[str, FloatArray] = {"beta": x[:, 0].copy(), "r": x[:, 1].copy()}
    inn: dict[str, FloatArray] = {}
    inflation = np.ones(0)
    health = np.zeros(0)
    if innovations is not None:
        nu, S = innovations
        check = block_consistency(drive.t, nu[:, :2], S[:, :2], causal)
        inflation = check.inflation
        health = check.health
        out["health"] = health
        params["health"] = {**check.summary(drive.t), "test": (
            f"sums of the graph's Kalman innovations (gyro, a_y) over {BLOCK_S:g} s blocks, "
            f"chi2 99 % over {WINDOW_S:g} s windows; variance x NIS ratio where it fails")}
        inn = {"wz": nu[:, 0], "wz_s": S[:, 0], "ay": nu[:, 1], "ay_s": S[:, 1]}
    if settings.stiffness_rel_sigma > 0:
        params["stiffness_rel_sigma"] = settings.stiffness_rel_sigma
    offset_beta = settings.accel_offset_sigma * vehicle.mass / (vehicle.cf + vehicle.cr)
    params["beta_std_terms"] = {
        "stiffness_rel_sigma": settings.stiffness_rel_sigma,
        "limit_rel_sigma_at_health_1": settings.limit_rel_sigma if health.size else 0.0,
        "accel_offset_beta_rad": offset_beta,
    }
    out["beta_std"], out["r_std"] = one_sigma(
        x, var, inflation, prep.inputs.delta, prep.inputs.v_measurement, vehicle.lf, vehicle.lr,
        settings.stiffness_rel_sigma, health, settings.limit_rel_sigma,
        offset_beta,
    )  # fmt: skip
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
    x, var, cov, inn = _batch_pass(prep, vehicle, settings.consistency)
    return _estimate("fg_batch", drive, prep, inn, x, var, cov, settings, False,
                     {"solver": "banded Cholesky"}, vehicle)  # fmt: skip


@register(
    "fg_lag",
    columns=COLUMNS,
    summary="factor-graph fixed-lag smoother (window 5) on the linear single-track model",
    paper=PAPER,
    vehicle_params=VEHICLE_PARAMS,
    settings=FactorGraphSettings,
    accelerometer="cg_causal",
)
def fg_lag(
    drive: Drive, vehicle: Vehicle, settings: FactorGraphSettings = DEFAULT_SETTINGS
) -> Estimate:
    """Fixed-lag factor-graph smoother: each row's state from the data up to ``window`` rows
    later (an on-line delay of window x dt), oldest state marginalised into the next prior.
    The "auto" sigmas are identified off-line from the whole drive (module fg_tuning)."""
    prep = prepare(drive, vehicle, settings)
    x, var, cov, inn = _lag_pass(prep.inputs, vehicle, prep.settings, LAG_CHUNK, settings.consistency)
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
    accelerometer="cg_causal",
)
def kf_linear(
    drive: Drive, vehicle: Vehicle, settings: FactorGraphSettings = DEFAULT_SETTINGS
) -> Estimate:
    """Linear Kalman filter with F = I + dt A, Q = diag(model sigmas^2), R = factor sigmas^2."""
    prep = prepare(drive, vehicle, settings)
    x, var, cov, inn = _kalman_pass(prep, vehicle, settings.consistency)
    return _estimate("kf_linear", drive, prep, inn, x, var, cov, settings, True,
                     {"filter": "Joseph form"}, vehicle)  # fmt: skip
