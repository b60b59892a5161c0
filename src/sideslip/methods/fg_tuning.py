"""Noise tuning of the seed-002 graph from the drive itself, and its consistency check.

Why not the likelihood.  The graph's factor sigmas are not sensor noise: the lateral-
acceleration factor compares a *linear* tyre model with the measured acceleration, and its
error is slowly varying (it grows as the tyres leave their linear range and with a wrong
cornering stiffness), not white.  The innovation likelihood treats 100 samples per second as
independent evidence and so always prefers a small a_y sigma that fits every sample (about
1 m/s^2 on seed 002's lap, beta RMSE 1.09 deg against the paper's 0.57 deg).

Criterion: the yaw rate the model predicts ahead.  For each candidate pair (a_y-factor sigma,
beta dynamic-factor sigma) the Kalman filter of the graph runs over the drive; every
``stride`` rows its state is propagated ``horizon_s`` ahead with the model and the steering
alone (no measurement), and compared with the gyro sample there.  The pair whose prediction
error has the least variance is chosen (the variance, not the mean square: a constant gyro bias,
which the model lacks, shifts every candidate's error alike and would otherwise decide; raw
phone gyros carry several deg/s of it).  A beta that is wrong (because the a_y factor pulled it to
a wrong tyre relation, or because the dynamic factors let it drift) predicts the yaw
acceleration wrongly through the yaw-moment equation (A21 beta, paper eq 6) and shows in the
gyro a few tenths of a second later, where the gyro is an independent, precise cue; a model
error that is slow cannot be hidden by the filter's gains, because nothing is measured during
the horizon.  The horizon (0.3 s) spans a few of the single-track model's time constants
(m V / (cf + cr) and Iz V / (cf lf^2 + cr lr^2), 0.05-0.2 s for cars at 10-60 m/s) so the
prediction is dominated by the model, not by the last gyro sample.  Cost: one filter pass
per candidate plus ``horizon / stride`` propagations per row, O(N) (10 candidates).

Consistency.  Whatever the tuning, the model can stop fitting somewhere (tyres at the limit,
a wrong vehicle file, a banked road).  :func:`block_consistency` sums the graph's Kalman
innovations over short blocks and tests them with the windowed NIS of
:func:`sideslip.filters.consistency.nis_consistency` (inflation of the variance where the
window's NIS exceeds its chi^2 bound, and ``health``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import NDArray

from sideslip.filters.consistency import Consistency, nis_consistency
from sideslip.filters.kalman import predict_ws_nb, update_scalar_ws_nb

FloatArray = NDArray[np.float64]

SIGMA_FIELDS = ("yaw_rate", "lateral_acceleration", "model_beta", "model_yaw_rate")
# Values of each named preset for the four sigmas (FactorGraphSettings' docstring has units).
PRESETS: dict[str, dict[str, float]] = {
    # the paper authors' published sigmas (seed 002 code, main.cpp defaults; DATA_NOTES)
    "paper": {"yaw_rate": 1e-2, "lateral_acceleration": 7.0, "model_beta": 4e-3,
              "model_yaw_rate": 0.9e-2},
    # fixed values from physics (the FactorGraphSettings docstring), this package's old default
    "physics": {"yaw_rate": 0.01, "lateral_acceleration": 0.5, "model_beta": 0.001,
                "model_yaw_rate": 0.01},
}  # fmt: skip
# "auto": the fields searched, and the grid.  The two yaw-rate sigmas are not searched (the
# criterion below prefers ever looser yaw dynamics: measured, it picks 0.003 .. 0.02 at the
# grid's edge); they take the paper's published values, which lie within the physics preset's
# argument (0.01 "of order"): yaw-rate observation 1e-2, yaw-rate dynamic 0.9e-2.
AUTO_LATERAL_ACCELERATION = (0.2, 0.5, 1.5, 4.0, 7.0)  # m/s^2, spans "trusted" .. "ignored"
AUTO_MODEL_BETA = (1e-3, 4e-3)  # rad per 0.01 s step: the physics and the paper's value
HORIZON_S = 0.3
STRIDE = 5
CRITERION = (
    f"least variance of the error of the gyro yaw rate predicted {HORIZON_S:g} s ahead by the "
    "graph's Kalman filter and model (no measurement during the horizon), over a grid of "
    "a_y-factor and beta-model sigmas"
)


@dataclass(frozen=True)
class Tuning:
    """The sigmas chosen for a drive, the criterion and every candidate's score."""

    sigmas: dict[str, float]
    source: dict[str, str]
    criterion: str | None
    candidates: list[dict[str, float]]

    def params(self) -> dict[str, object]:
        out: dict[str, object] = {"sigmas": self.sigmas, "sigma_source": self.source}
        if self.criterion is not None:
            out["criterion"] = self.criterion
            out["candidates"] = self.candidates
        return out


@numba.njit(cache=True)
def gyro_prediction_error(
    F: FloatArray,
    g: FloatArray,
    wq: FloatArray,
    Hu: FloatArray,
    zu: FloatArray,
    wu: FloatArray,
    x0: FloatArray,
    P0: FloatArray,
    horizon: int,
    stride: int,
    score: NDArray[np.bool_],
) -> tuple[float, int, float]:
    """Kalman filter of the chain factors; every ``stride`` rows the updated state is
    propagated ``horizon`` steps with F, g only and its yaw rate (row 0 of the unary factors)
    compared with the gyro there.  Returns (sum of squared errors, count, sum of errors) over
    rows where ``score`` (the target row's flag) holds and a gyro sample is present."""
    n = Hu.shape[0]
    M = Hu.shape[1]
    nx = Hu.shape[2]
    x = x0.copy()
    P = P0.copy()
    Q = np.zeros((nx, nx))
    work = np.empty((2 * nx + 2, nx))
    y = np.zeros(nx)
    sse = 0.0
    se = 0.0
    count = 0
    for k in range(n):
        for m in range(M):
            w = wu[k, m]
            if w == 0.0:
                continue
            innov = zu[k, m]
            for i in range(nx):
                innov -= Hu[k, m, i] * x[i]
            update_scalar_ws_nb(x, P, innov, Hu[k, m], 1.0 / w, work)
        e = k + horizon
        if k % stride == 0 and e < n and wu[e, 0] != 0.0 and score[e]:
            for i in range(nx):
                y[i] = x[i]
            across_gap = False
            for j in range(k, e):
                if F[j, 0, 0] == 0.0 and F[j, 1, 1] == 0.0:  # a time gap: no prediction
                    across_gap = True
                    break
                b0 = g[j, 0] + F[j, 0, 0] * y[0] + F[j, 0, 1] * y[1]
                y[1] = g[j, 1] + F[j, 1, 0] * y[0] + F[j, 1, 1] * y[1]
                y[0] = b0
            if not across_gap:
                d = zu[e, 0]
                for i in range(nx):
                    d -= Hu[e, 0, i] * y[i]
                sse += d * d
                se += d
                count += 1
        if k < n - 1:
            for i in range(nx):
                Q[i, i] = 1.0 / wq[k, i]
            predict_ws_nb(x, P, F[k], Q, g[k], work)
    return sse, count, se


@numba.njit(cache=True)
def chain_kalman(
    F: FloatArray,
    g: FloatArray,
    wq: FloatArray,
    Hu: FloatArray,
    zu: FloatArray,
    wu: FloatArray,
    x0: FloatArray,
    P0: FloatArray,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    """Linear KF: Joseph-form scalar updates with each present unary factor, then predict
    (:func:`sideslip.filters.kalman.update_scalar_ws_nb`, :func:`~sideslip.filters.kalman.predict_ws_nb`).

    Returns the filtered means and variances (N, 2), the beta-r covariance (N,), and each
    factor's innovation and its variance S (N, M; NaN where the factor is absent).
    """
    n = Hu.shape[0]
    M = Hu.shape[1]
    nx = Hu.shape[2]
    xs = np.zeros((n, nx))
    vs = np.zeros((n, nx))
    cs = np.zeros(n)
    nu = np.full((n, M), np.nan)
    ss = np.full((n, M), np.nan)
    chain_kalman_into(F, g, wq, Hu, zu, wu, x0.copy(), P0.copy(), xs, vs, cs, nu, ss)
    return xs, vs, cs, nu, ss


@numba.njit(cache=True)
def chain_kalman_into(
    F: FloatArray,
    g: FloatArray,
    wq: FloatArray,
    Hu: FloatArray,
    zu: FloatArray,
    wu: FloatArray,
    x: FloatArray,
    P: FloatArray,
    xs: FloatArray,
    vs: FloatArray,
    cs: FloatArray,
    nu: FloatArray,
    ss: FloatArray,
) -> None:
    """:func:`chain_kalman` of the rows of ``Hu`` into the given outputs (filtered means and
    variances (N, 2), covariance (N,); innovations and S (N, <= M), of the first ``nu.shape[1]``
    factors, left untouched where a factor is absent: fill them with NaN first).

    ``x``, ``P``: the prediction at the first row, updated in place to the prediction for the
    row after the last when ``F`` holds that step (``F.shape[0] >= N``: a chunk of a longer
    chain, continued by the next call; the same arithmetic as one call over the whole chain),
    else to the last row's filtered state.
    """
    nx = Hu.shape[2]
    Q = np.zeros((nx, nx))
    work = np.empty((2 * nx + 2, nx))
    for k in range(Hu.shape[0]):
        _chain_update(k, x, P, Hu, zu, wu, nu, ss, work)
        for i in range(nx):
            xs[k, i] = x[i]
            vs[k, i] = P[i, i]
        cs[k] = P[0, 1]
        _chain_predict(k, x, P, F, g, wq, Q, work)


@numba.njit(cache=True)
def _chain_update(
    k: int, x: FloatArray, P: FloatArray, Hu: FloatArray, zu: FloatArray, wu: FloatArray,
    nu: FloatArray, ss: FloatArray, work: FloatArray,
) -> None:  # fmt: skip
    """Row ``k``'s unary factors as scalar updates of ``(x, P)`` in place; the innovation and
    its variance S of the first ``nu.shape[1]`` factors go to ``nu[k]``, ``ss[k]``."""
    nx = Hu.shape[2]
    for m in range(Hu.shape[1]):
        w = wu[k, m]
        if w == 0.0:
            continue
        innov = zu[k, m]
        for i in range(nx):
            innov -= Hu[k, m, i] * x[i]
        s = update_scalar_ws_nb(x, P, innov, Hu[k, m], 1.0 / w, work)
        if m < nu.shape[1]:
            ss[k, m] = s
            nu[k, m] = innov


@numba.njit(cache=True)
def _chain_predict(
    k: int, x: FloatArray, P: FloatArray, F: FloatArray, g: FloatArray, wq: FloatArray,
    Q: FloatArray, work: FloatArray,
) -> None:  # fmt: skip
    """The chain's step from row ``k`` to ``k + 1`` (when ``F`` holds it), in place; ``Q``
    (nx, nx) scratch, its diagonal the step's variances ``1 / wq[k]``."""
    if k < F.shape[0]:
        for i in range(x.size):
            Q[i, i] = 1.0 / wq[k, i]
        predict_ws_nb(x, P, F[k], Q, g[k], work)


@numba.njit(cache=True)
def chain_innovations(
    F: FloatArray,
    g: FloatArray,
    wq: FloatArray,
    Hu: FloatArray,
    zu: FloatArray,
    wu: FloatArray,
    x0: FloatArray,
    P0: FloatArray,
    n_factors: int,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """:func:`chain_kalman`'s innovations and their variances S of the first ``n_factors``
    unary factors (N, n_factors; NaN where absent), computed by the same steps but without
    storing the states (the consistency test needs only these).

    Also returns the filter's prediction ``(x, P)`` for the row after the last one when ``F``
    holds that step (``F.shape[0] >= N``: a chunk of a longer chain, continued by the next
    call from that prediction), else the last row's filtered state.
    """
    n = Hu.shape[0]
    nx = Hu.shape[2]
    x = x0.copy()
    P = P0.copy()
    Q = np.zeros((nx, nx))
    work = np.empty((2 * nx + 2, nx))
    nu = np.full((n, n_factors), np.nan)
    ss = np.full((n, n_factors), np.nan)
    for k in range(n):
        _chain_update(k, x, P, Hu, zu, wu, nu, ss, work)
        _chain_predict(k, x, P, F, g, wq, Q, work)
    return nu, ss, x, P


@numba.njit(cache=True)
def gyro_prediction_errors(
    F: FloatArray,
    g: FloatArray,
    wq: FloatArray,
    Hu: FloatArray,
    zu: FloatArray,
    wu: FloatArray,
    x0: FloatArray,
    P0: FloatArray,
    horizon: int,
    stride: int,
    score: NDArray[np.bool_],
    gap: NDArray[np.bool_],
    ay_scale: FloatArray,
    beta_scale: FloatArray,
) -> tuple[FloatArray, NDArray[np.int64], FloatArray]:
    """:func:`gyro_prediction_error` of every candidate c in one pass over the rows: the
    candidates' filters run side by side (independent recursions, so the processor overlaps
    them, and the factors are read once).  Candidate c divides the a_y factor's weights
    (``wu[:, 1]``) by ``ay_scale[c]`` and the beta dynamic factor's (``wq[:, 0]``, except
    across a time gap) by ``beta_scale[c]``, i.e. sigma^2 times the unit weights; each
    candidate's arithmetic is exactly that of its own :func:`gyro_prediction_error` run.
    Returns per candidate (sum of squared errors, count, sum of errors)."""
    n_cand = ay_scale.size
    nx = Hu.shape[2]
    xs = np.empty((n_cand, nx))
    Ps = np.empty((n_cand, nx, nx))
    for c in range(n_cand):
        xs[c] = x0
        Ps[c] = P0
    sse = np.zeros(n_cand)
    se = np.zeros(n_cand)
    count = np.zeros(n_cand, dtype=np.int64)
    gyro_prediction_errors_into(F, g, wq, Hu, zu, wu, Hu.shape[0], 0, horizon, stride, score, gap,
                                ay_scale, beta_scale, xs, Ps, sse, count, se)  # fmt: skip
    return sse, count, se


@numba.njit(cache=True)
def gyro_prediction_errors_into(
    F: FloatArray,
    g: FloatArray,
    wq: FloatArray,
    Hu: FloatArray,
    zu: FloatArray,
    wu: FloatArray,
    rows: int,
    first_row: int,
    horizon: int,
    stride: int,
    score: NDArray[np.bool_],
    gap: NDArray[np.bool_],
    ay_scale: FloatArray,
    beta_scale: FloatArray,
    xs: FloatArray,
    Ps: FloatArray,
    sse: FloatArray,
    count: NDArray[np.int64],
    se: FloatArray,
) -> None:
    """:func:`gyro_prediction_errors` over the first ``rows`` rows of a chunk of the chain
    that starts at row ``first_row`` of the drive (for the stride) and holds ``horizon`` rows
    of look-ahead after them unless it ends the drive; the candidates' filter states ``xs``
    (n_cand, nx), ``Ps`` (n_cand, nx, nx) carry from one chunk to the next and the sums
    ``sse``, ``count``, ``se`` accumulate (in place).  Chunk by chunk, the arithmetic is
    that of one call over the whole chain."""
    n = Hu.shape[0]
    M = Hu.shape[1]
    nx = Hu.shape[2]
    n_cand = ay_scale.size
    Q = np.zeros((nx, nx))
    work = np.empty((2 * nx + 2, nx))
    y = np.zeros(nx)
    for k in range(rows):
        e = k + horizon
        predict_here = (first_row + k) % stride == 0 and e < n and wu[e, 0] != 0.0 and score[e]
        across_gap = False
        if predict_here:
            for j in range(k, e):
                if F[j, 0, 0] == 0.0 and F[j, 1, 1] == 0.0:  # a time gap: no prediction
                    across_gap = True
                    break
        for c in range(n_cand):
            x = xs[c]
            P = Ps[c]
            for m in range(M):
                w = wu[k, m] / ay_scale[c] if m == 1 else wu[k, m]
                if w == 0.0:
                    continue
                innov = zu[k, m]
                for i in range(nx):
                    innov -= Hu[k, m, i] * x[i]
                update_scalar_ws_nb(x, P, innov, Hu[k, m], 1.0 / w, work)
            if predict_here and not across_gap:
                for i in range(nx):
                    y[i] = x[i]
                for j in range(k, e):
                    b0 = g[j, 0] + F[j, 0, 0] * y[0] + F[j, 0, 1] * y[1]
                    y[1] = g[j, 1] + F[j, 1, 0] * y[0] + F[j, 1, 1] * y[1]
                    y[0] = b0
                d = zu[e, 0]
                for i in range(nx):
                    d -= Hu[e, 0, i] * y[i]
                sse[c] += d * d
                se[c] += d
                count[c] += 1
            if k < n - 1:
                Q[0, 0] = 1.0 / (wq[k, 0] if gap[k] else wq[k, 0] / beta_scale[c])
                for i in range(1, nx):
                    Q[i, i] = 1.0 / wq[k, i]
                predict_ws_nb(x, P, F[k], Q, g[k], work)


# One chunk of the unit-sigma graph for :func:`choose_sigmas`: (first row of the drive, rows
# to score, F, g, wq_unit, Hu, zu, wu_unit) with the look-ahead rows after the scored ones.
UnitChunk = tuple[int, int, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]


def choose_sigmas(
    fixed: Mapping[str, float | None],
    unit_chunks: Callable[[int], Iterable[UnitChunk]],
    x0: FloatArray,
    P0: FloatArray,
    dt: float,
    score: NDArray[np.bool_],
    gap: NDArray[np.bool_],
) -> Tuning:
    """The "auto" sigmas (module docstring) for one drive.

    ``fixed`` maps each sigma field to a value set by the user (kept) or None (identified or
    from the physics preset).  ``unit_chunks(look_ahead)`` yields the graph built with all four
    sigmas equal to 1 in consecutive chunks (:data:`UnitChunk`, each with ``look_ahead`` rows
    after its scored rows unless it ends the drive), so only one chunk's factors are alive at
    a time; a sigma s weighs 1/s^2 times the unit weights, except across time gaps (``gap``,
    N-1), whose restart factors keep their own weights.  ``score``: rows whose gyro sample
    may be predicted (moving above the speed gate).  Nothing is built when no sigma is searched.
    """
    base = PRESETS["paper"]
    sigmas = {k: (float(v) if v is not None else base[k]) for k, v in fixed.items()}
    source = {k: ("set" if fixed[k] is not None else "paper preset") for k in fixed}
    grid_a = (sigmas["lateral_acceleration"],) if fixed["lateral_acceleration"] is not None \
        else AUTO_LATERAL_ACCELERATION
    grid_b = (sigmas["model_beta"],) if fixed["model_beta"] is not None else AUTO_MODEL_BETA
    if len(grid_a) * len(grid_b) == 1:
        return Tuning(sigmas, source, None, [])
    horizon = max(1, round(HORIZON_S / dt))
    candidates: list[dict[str, float]] = []
    best = (math.inf, grid_a[0], grid_b[0])
    pairs = [(sa, sb) for sa in grid_a for sb in grid_b]
    # every candidate's filter in one pass (sigma^2 divides the unit weights), chunk by chunk
    ay_scale = np.array([sa**2 for sa, _ in pairs])
    beta_scale = np.array([sb**2 for _, sb in pairs])
    xs = np.tile(np.asarray(x0, dtype=float), (len(pairs), 1))
    Ps = np.tile(np.asarray(P0, dtype=float), (len(pairs), 1, 1))
    sse, se = np.zeros(len(pairs)), np.zeros(len(pairs))
    count = np.zeros(len(pairs), dtype=np.int64)
    for a, rows, F, g, wq_unit, Hu, zu, wu_unit in unit_chunks(horizon):
        n_dyn = F.shape[0]
        wu = wu_unit.copy()
        wu[:, 0] = wu_unit[:, 0] / sigmas["yaw_rate"] ** 2
        wq = wq_unit.copy()
        move = ~gap[a : a + n_dyn]
        wq[move, 1] = wq_unit[move, 1] / sigmas["model_yaw_rate"] ** 2
        gyro_prediction_errors_into(
            F, g, wq, Hu, zu, wu, rows, a, horizon, STRIDE, score[a : a + Hu.shape[0]],
            gap[a : a + n_dyn], ay_scale, beta_scale, xs, Ps, sse, count, se,
        )  # fmt: skip
    for (sa, sb), s2, c, s1 in zip(pairs, sse.tolist(), count.tolist(), se.tolist(), strict=True):
        # the error's variance, not its mean square: a constant gyro bias (the model has
        # none, so the prediction decays it away over the horizon) shifts every candidate's
        # error alike and must not decide (raw phone gyros: several deg/s)
        mse = max(s2 / c - (s1 / c) ** 2, 0.0) if c else math.inf
        candidates.append({"lateral_acceleration": sa, "model_beta": sb,
                           "gyro_prediction_std_rad_s": math.sqrt(mse)})
        if mse < best[0]:
            best = (mse, sa, sb)
    if math.isfinite(best[0]):
        for name, value in (("lateral_acceleration", best[1]), ("model_beta", best[2])):
            if fixed[name] is None:
                sigmas[name] = float(value)
                source[name] = "identified (auto)"
    return Tuning(sigmas, source, CRITERION, candidates)


BLOCK_S = 0.25  # s: innovations are summed over blocks this long before the chi^2 test
WINDOW_S = 2.0  # s: sliding window of the NIS test (8 blocks per factor)


@numba.njit(cache=True)
def _block_nis(
    t: FloatArray, innov: FloatArray, S: FloatArray, block_s: float
) -> tuple[NDArray[np.int64], FloatArray, FloatArray]:
    """First row of each block (floor((t - t_0) / block_s)), and per block the NIS
    sum over factors of (sum nu)^2 / sum S and its degrees of freedom (the factors with an
    update in the block); one pass over the rows."""
    n, n_fac = innov.shape
    n_blocks = 0  # first pass: the number of blocks (the outputs are allocated to it)
    current = -1
    for k in range(n):
        b = int(np.floor((t[k] - t[0]) / block_s))
        if b != current:
            n_blocks += 1
            current = b
    start = np.empty(n_blocks, dtype=np.int64)
    nis = np.zeros(n_blocks)
    dof = np.zeros(n_blocks)
    sum_nu = np.zeros(n_fac)
    sum_s = np.zeros(n_fac)
    nb = 0
    current = -1
    for k in range(n + 1):
        b = int(np.floor((t[k] - t[0]) / block_s)) if k < n else -2
        if b != current:
            if nb > 0:  # close the previous block
                for m in range(n_fac):
                    if sum_s[m] > 0.0:
                        nis[nb - 1] += sum_nu[m] ** 2 / sum_s[m]
                        dof[nb - 1] += 1.0
                    sum_nu[m] = 0.0
                    sum_s[m] = 0.0
            if k == n:
                break
            start[nb] = k
            nb += 1
            current = b
        for m in range(n_fac):
            if np.isfinite(innov[k, m]) and np.isfinite(S[k, m]):
                sum_nu[m] += innov[k, m]
                sum_s[m] += S[k, m]
    return start, nis, dof


def block_consistency(
    t: FloatArray, innov: FloatArray, S: FloatArray, causal: bool, block_s: float = BLOCK_S
) -> Consistency:
    """Windowed NIS test of block sums of a Kalman filter's innovations, per row.

    Under the filter's model the innovations nu_k are white with variances S_k, so over a
    block the sum  z = sum nu_k / sqrt(sum S_k)  is N(0, 1) and z^2 ~ chi^2(1)
    (Bar-Shalom et al. 2001, sec. 5.4: whiteness and the NIS).  A slowly varying model error
    (tyres past their linear range, a wrong stiffness, a bank) hardly changes a single
    innovation at 100 Hz but biases many in a row, which the block sum shows sqrt(block)
    times more clearly than the per-sample NIS.  ``innov``, ``S``: (N, M), NaN where a factor
    had no update.  The blocks' z^2 (one per factor and block, dof 1 each) go through
    :func:`sideslip.filters.consistency.nis_consistency` over ``WINDOW_S`` windows (chi^2 99 %)
    at the blocks' start times, and its result is held over each block's rows.  O(N).
    """
    n = innov.shape[0]
    start, nis, dof = _block_nis(t, innov, S, block_s)
    check = nis_consistency(t[start], nis, dof, window_s=WINDOW_S, causal=causal)
    rows = np.diff(np.r_[start, n])  # rows per block
    return Consistency(np.repeat(check.mean_nis, rows), np.repeat(check.inflation, rows),
                       np.repeat(check.health, rows), np.repeat(check.flagged, rows),
                       np.repeat(check.bound, rows))  # fmt: skip
