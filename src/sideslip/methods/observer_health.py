"""Health of the seed 003 observers: what an observer without a covariance can check itself.

The Luenberger observers of :mod:`sideslip.methods.observers` carry no covariance, so the
windowed-NIS convention of the filters cannot be applied as is.  What they can check:

* **output error** -- the measured outputs against the observer's prediction of them: the yaw
  rate ``r - r_hat`` (all three bicycle observers), the lateral acceleration
  ``a_y - (C_2 x_hat + D_2 u)`` (modified observers), the wheel speed ``v_x,wheel - v_x_hat``
  (kinematic observer).  Each residual is normalised by its own robust scale over the drive's
  observed rows (1.4826 MAD, floored at the sensor-noise level ``*_FLOOR``), squared, and
  tested in 2 s trailing windows against the chi^2 bound
  (:func:`sideslip.filters.consistency.nis_consistency`, ``causal=True``: the observers are
  causal).  A window flags where the model fits much worse than it does on the rest of this
  drive -- a tyre leaving its linear range, a bank the model does not know, a sensor fault.
  (It cannot see an error the whole drive shares, such as a cornering stiffness 30 % off
  everywhere: the modified observer is built to keep beta's error free of it, eq 36.)
* **saturation** -- the linear single track holds below about 0.4 g (``models.single_track``);
  health rises linearly from 0 at ``SAT_ON_G`` to 1 at ``SAT_FULL_G`` of |a_y,m|.
* **not observed** -- below the speed gate, at standstill and reversing the observers are not
  run and output the kinematic no-slip value: health ``NOT_OBSERVED`` (0.5) -- usable (the
  no-slip value is right at walking pace) but not an observer estimate.
* **weak observability** (kinematic observer) -- with |r| below ``R_OBSERVABLE`` the lateral
  velocity is unobservable (rank loss, module ``observers``): health rises to ``WEAK`` (0.3)
  as |r| -> 0.

* **sensor gaps** -- rows without a fresh sample of the measured outputs (held values, the
  observer open loop): health rises to ``STALE`` (0.5) over ``STALE_FULL_S`` s since the last
  fresh sample (:func:`stale_health`, also used by the other methods of this family).

``health`` is the largest of these per row; ``params["health"]`` gives the NIS summary and the
share of rows each reason flagged.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numba
import numpy as np
from numpy.typing import NDArray

from sideslip.filters.consistency import nis_consistency
from sideslip.vehicle import G

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

WINDOW_S = 2.0  # s: trailing NIS window
SAT_ON_G = 0.4  # |a_y| in g where the linear single track starts to fail
SAT_FULL_G = 0.8  # |a_y| in g where it is unusable
NOT_OBSERVED = 0.5
WEAK = 0.3
# sensor-noise floors of the residual scales (default MEMS/CAN grades, sensors module)
FLOOR = {"r": np.radians(0.1), "ay": 0.05, "vx": 0.05}


STALE = 0.5
STALE_FULL_S = 1.0  # s without a fresh sample at which the gap term reaches STALE
BLOCK_S = 0.25  # s: NIS summed per block before the windowed test (the chi^2 bound per block)


@numba.njit(cache=True)
def _block_sums_nb(
    t: FloatArray, nis: FloatArray, dof: FloatArray, block_s: float
) -> tuple[NDArray[np.intp], FloatArray, FloatArray, FloatArray, bool]:  # pragma: no cover
    """Rows grouped in blocks floor((t - t_0) / block_s) of a non-decreasing ``t``: per-row
    block index, and per block the sums of the finite NIS (with dof > 0) and of their dof and
    the mean time.  The last item is False (and the rest unusable) if ``t`` decreases."""
    n = t.size
    inv = np.empty(n, dtype=np.intp)
    # blocks of a non-decreasing t: at most the last row's block index + 1 (and n)
    size = min(n, max(1, math.floor((t[n - 1] - t[0]) / block_s) + 1)) if n else 0
    sum_nis = np.zeros(size)
    sum_dof = np.zeros(size)
    sum_t = np.zeros(size)
    count = np.zeros(size)
    j = -1
    prev = 0
    for k in range(n):
        b = math.floor((t[k] - t[0]) / block_s)
        if j < 0 or b != prev:
            if (j >= 0 and b < prev) or j + 1 >= size:
                return inv, sum_nis, sum_dof, sum_t, False
            j += 1
            prev = b
        inv[k] = j
        if math.isfinite(nis[k]) and dof[k] > 0:
            sum_nis[j] += nis[k]
            sum_dof[j] += dof[k]
        sum_t[j] += t[k]
        count[j] += 1.0
    m = j + 1
    return inv, sum_nis[:m], sum_dof[:m], sum_t[:m] / count[:m], True


def blocked_consistency(t: FloatArray, nis: FloatArray, dof: FloatArray, window_s: float,
                        causal: bool) -> tuple[FloatArray, FloatArray, dict[str, object]]:
    """:func:`~sideslip.filters.consistency.nis_consistency` on ``BLOCK_S`` blocks of rows.

    Sums of NIS and of degrees of freedom per block are what the windowed test sums anyway, so
    the result equals the per-row test up to the window edges (one block, 0.25 s); the chi^2 bound is
    then evaluated per block, not per row (it dominated the observers' run time).  Returns
    per-row (health, inflation) and the summary.  The blocks are summed in one compiled pass
    (time stamps are increasing); an unsorted ``t`` falls back to sorting the block indices.
    """
    n = t.size
    if n == 0:
        return np.zeros(0), np.ones(0), {}
    inv, sum_nis, sum_dof, t_block, ordered = _block_sums_nb(
        np.asarray(t, dtype=float), np.asarray(nis, dtype=float), np.asarray(dof, dtype=float),
        BLOCK_S)
    if not ordered:
        block = np.floor((t - t[0]) / BLOCK_S).astype(np.intp)
        uniq, inv = np.unique(block, return_inverse=True)
        ok = np.isfinite(nis) & (dof > 0)
        sum_nis = np.asarray(np.bincount(inv, weights=np.where(ok, nis, 0.0),
                                         minlength=uniq.size), dtype=float)
        sum_dof = np.asarray(np.bincount(inv, weights=np.where(ok, dof, 0.0),
                                         minlength=uniq.size), dtype=float)
        t_block = np.asarray(np.bincount(inv, weights=t, minlength=uniq.size)
                             / np.bincount(inv, minlength=uniq.size), dtype=float)
    cons = nis_consistency(t_block, np.where(sum_dof > 0, sum_nis, np.nan), sum_dof,
                           window_s=window_s, causal=causal)
    summary = cons.summary(t_block)
    return cons.health[inv], cons.inflation[inv], summary


@numba.njit(cache=True)
def _stale_nb(t: FloatArray, fresh: BoolArray, full_s: float, level: float
              ) -> FloatArray:  # pragma: no cover - compiled
    """The per-row gap term of :func:`stale_health` (``fresh`` has at least one True)."""
    n = t.size
    n_fresh = 0
    for k in range(n):
        n_fresh += fresh[k]
    normal = 0.1
    if n_fresh > 1:
        gaps = np.empty(n_fresh - 1)  # intervals between consecutive fresh rows
        m = 0
        prev = -1
        for k in range(n):
            if fresh[k]:
                if prev >= 0:
                    gaps[m] = t[k] - t[prev]
                    m += 1
                prev = k
        normal = max(2.0 * np.median(gaps), 0.1)
    out = np.empty(n)
    last = -1
    for k in range(n):
        if fresh[k]:
            last = k
        since = t[k] - t[last] if last >= 0 else t[k] - t[0] + full_s
        out[k] = level * min(max((since - normal) / full_s, 0.0), 1.0)
    return out


def stale_health(t: FloatArray, fresh: BoolArray, full_s: float = STALE_FULL_S,
                 level: float = STALE) -> FloatArray:
    """Per-row gap term: ``level`` x min(1, seconds since the last fresh row / ``full_s``) --
    but 0 while fresh samples arrive at their normal rate (gaps up to twice the median
    interval between fresh rows, or 0.1 s).  One compiled pass."""
    n = t.size
    if n == 0:
        return np.zeros(0)
    fresh = np.asarray(fresh, dtype=np.bool_)
    if not fresh.any():
        return np.full(n, level)
    return np.asarray(_stale_nb(np.asarray(t, dtype=float), fresh, float(full_s), float(level)))


def _robust_scale(x: FloatArray) -> float:
    x = x[np.isfinite(x)]
    if x.size < 10:
        return float("inf")
    return 1.4826 * float(np.median(np.abs(x - np.median(x))))


@numba.njit(cache=True)
def _observed_finite_nb(res: FloatArray, observed: BoolArray) -> FloatArray:  # pragma: no cover
    """The finite values of ``res`` on the observed rows (``res[observed & isfinite(res)]``)."""
    out = np.empty(res.size)
    m = 0
    for k in range(res.size):
        if observed[k] and math.isfinite(res[k]):
            out[m] = res[k]
            m += 1
    return out[:m]


@numba.njit(cache=True)
def _accumulate_nb(res: FloatArray, observed: BoolArray, scale: float, nis: FloatArray,
                   dof: FloatArray, fresh_any: BoolArray) -> None:  # pragma: no cover
    """In place: ``nis += (res / scale)^2`` and ``dof += 1`` on the observed rows with a finite
    residual (none when ``scale`` is not a positive number); ``fresh_any |= isfinite(res)``."""
    use = math.isfinite(scale) and scale > 0.0
    for k in range(res.size):
        finite = math.isfinite(res[k])
        if finite:
            fresh_any[k] = True
        if use and finite and observed[k]:
            z = res[k] / scale
            nis[k] += z * z
            dof[k] += 1.0


@numba.njit(cache=True)
def _nan_max(a: float, b: float) -> float:  # pragma: no cover - compiled
    """``np.maximum`` of two floats (NaN if either is)."""
    if math.isnan(a) or math.isnan(b):
        return math.nan
    return a if a >= b else b


@numba.njit(cache=True)
def _combine_nb(observed: BoolArray, nis_health: FloatArray, ay_m: FloatArray,
                weak: FloatArray, gap: FloatArray) -> tuple[FloatArray, int, int, int]:  # pragma: no cover
    """Per-row health from the terms of :func:`observer_health` (``weak`` zeros when there is
    no weak-observability term; ``gap`` the stale term on every row), and the number of
    observed rows that are saturated, weakly observable and in a sensor gap."""
    n = observed.size
    health = np.empty(n)
    n_sat = 0
    n_weak = 0
    n_gap = 0
    for k in range(n):
        sat = min(max((abs(ay_m[k]) / G - SAT_ON_G) / (SAT_FULL_G - SAT_ON_G), 0.0), 1.0)
        if observed[k]:
            h = _nan_max(nis_health[k], sat)
            w = WEAK * weak[k]
            g = gap[k]
            n_sat += sat > 0.0
        else:
            h = NOT_OBSERVED
            w = 0.0
            g = 0.0
        n_weak += w > 0.0
        n_gap += g > 0.0
        h = _nan_max(_nan_max(h, w), g)
        health[k] = h if math.isnan(h) else min(max(h, 0.0), 1.0)
    return health, n_sat, n_weak, n_gap


def observer_health(
    t: FloatArray,
    observed: BoolArray,
    residuals: Mapping[str, FloatArray],
    ay_m: FloatArray,
    weak: FloatArray | None = None,
    inputs_fresh: BoolArray | None = None,
) -> tuple[FloatArray, dict[str, object]]:
    """(health per row, params summary) from the checks of the module docstring.

    ``observed``: rows where the observer ran; ``residuals``: name (``r``, ``ay``, ``vx``) ->
    per-row output error (NaN where no fresh sample); ``ay_m`` lateral specific force (m/s^2);
    ``weak``: optional per-row weak-observability share in [0, 1]; ``inputs_fresh``: rows with
    a fresh sample of the inputs (steering, IMU), for the sensor-gap term.  The per-row terms
    are combined in compiled passes (no per-term temporaries of the drive's length).
    """
    n = t.size
    observed = np.asarray(observed, dtype=np.bool_)
    nis = np.zeros(n)
    dof = np.zeros(n)
    fresh_any = np.zeros(n, dtype=np.bool_)
    scales: dict[str, float] = {}
    for name, res in residuals.items():
        res = np.asarray(res, dtype=float)
        scale = max(_robust_scale(_observed_finite_nb(res, observed)), FLOOR.get(name, 0.0))
        scales[name] = scale
        _accumulate_nb(res, observed, float(scale), nis, dof, fresh_any)
    # rows with dof = 0 hold nis = 0 and are skipped by the block sums like NaN
    nis_health, _, summary = blocked_consistency(t, nis, dof, WINDOW_S, causal=True)
    not_observed = ~observed
    gap = stale_health(t, fresh_any | not_observed)
    if inputs_fresh is not None:
        np.maximum(gap, stale_health(t, inputs_fresh | not_observed), out=gap)
    health, n_sat, n_weak, n_gap = _combine_nb(
        observed, np.asarray(nis_health, dtype=float), np.asarray(ay_m, dtype=float),
        np.zeros(n) if weak is None else np.asarray(weak, dtype=float), gap)
    summary.update(
        criterion="output error (measured vs predicted outputs) over its drive-wide robust "
        "scale, windowed NIS 2 s trailing, chi2 99 %; saturation; not observed",
        residual_scales={k: float(v) for k, v in scales.items()},
        saturated_share=n_sat / n if n else 0.0,
        not_observed_share=float(np.mean(not_observed)) if n else 0.0,
        weak_observability_share=n_weak / n if n else 0.0,
        sensor_gap_share=n_gap / n if n else 0.0,
    )
    return np.asarray(health, dtype=float), summary
