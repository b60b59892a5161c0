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

from collections.abc import Mapping

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


def blocked_consistency(t: FloatArray, nis: FloatArray, dof: FloatArray, window_s: float,
                        causal: bool) -> tuple[FloatArray, FloatArray, dict[str, object]]:
    """:func:`~sideslip.filters.consistency.nis_consistency` on ``BLOCK_S`` blocks of rows.

    Sums of NIS and of degrees of freedom per block are what the windowed test sums anyway, so
    the result equals the per-row test up to the window edges (one block, 0.25 s); the chi^2 bound is
    then evaluated per block, not per row (it dominated the observers' run time).  Returns
    per-row (health, inflation) and the summary.
    """
    n = t.size
    if n == 0:
        return np.zeros(0), np.ones(0), {}
    block = np.floor((t - t[0]) / BLOCK_S).astype(np.intp)
    uniq, inv = np.unique(block, return_inverse=True)
    ok = np.isfinite(nis) & (dof > 0)
    sum_nis = np.bincount(inv, weights=np.where(ok, nis, 0.0), minlength=uniq.size)
    sum_dof = np.bincount(inv, weights=np.where(ok, dof, 0.0), minlength=uniq.size)
    t_block = np.bincount(inv, weights=t, minlength=uniq.size) / np.bincount(inv, minlength=uniq.size)
    cons = nis_consistency(t_block, np.where(sum_dof > 0, sum_nis, np.nan), sum_dof,
                           window_s=window_s, causal=causal)
    summary = cons.summary(t_block)
    return cons.health[inv], cons.inflation[inv], summary


def stale_health(t: FloatArray, fresh: BoolArray, full_s: float = STALE_FULL_S,
                 level: float = STALE) -> FloatArray:
    """Per-row gap term: ``level`` x min(1, seconds since the last fresh row / ``full_s``) --
    but 0 while fresh samples arrive at their normal rate (gaps up to twice the median
    interval between fresh rows, or 0.1 s)."""
    n = t.size
    if n == 0:
        return np.zeros(0)
    rows = np.flatnonzero(fresh)
    if rows.size == 0:
        return np.full(n, level)
    last = np.full(n, -1, dtype=np.intp)
    last[rows] = rows
    np.maximum.accumulate(last, out=last)
    since = np.where(last >= 0, t - t[np.maximum(last, 0)], t - t[0] + full_s)
    normal = max(2.0 * float(np.median(np.diff(t[rows]))) if rows.size > 1 else 0.0, 0.1)
    return np.asarray(level * np.clip((since - normal) / full_s, 0.0, 1.0), dtype=float)


def _robust_scale(x: FloatArray) -> float:
    x = x[np.isfinite(x)]
    if x.size < 10:
        return float("inf")
    return 1.4826 * float(np.median(np.abs(x - np.median(x))))


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
    a fresh sample of the inputs (steering, IMU), for the sensor-gap term.
    """
    n = t.size
    nis = np.zeros(n)
    dof = np.zeros(n)
    scales: dict[str, float] = {}
    for name, res in residuals.items():
        ok = observed & np.isfinite(res)
        scale = max(_robust_scale(res[ok]), FLOOR.get(name, 0.0))
        scales[name] = scale
        if not np.isfinite(scale) or scale <= 0:
            continue
        z = np.where(ok, res / scale, 0.0)
        nis += z * z
        dof += ok
    nis_health, _, summary = blocked_consistency(t, np.where(dof > 0, nis, np.nan), dof,
                                                 WINDOW_S, causal=True)
    sat = np.clip((np.abs(ay_m) / G - SAT_ON_G) / (SAT_FULL_G - SAT_ON_G), 0.0, 1.0)
    health = np.where(observed, np.maximum(nis_health, sat), NOT_OBSERVED)
    weak_term = np.zeros(n) if weak is None else np.where(observed, WEAK * weak, 0.0)
    fresh_any = np.zeros(n, dtype=bool)
    for res in residuals.values():
        fresh_any |= np.isfinite(res)
    gap = stale_health(t, fresh_any | ~observed)
    if inputs_fresh is not None:
        gap = np.maximum(gap, stale_health(t, inputs_fresh | ~observed))
    gap = np.where(observed, gap, 0.0)
    health = np.clip(np.maximum(np.maximum(health, weak_term), gap), 0.0, 1.0)
    summary.update(
        criterion="output error (measured vs predicted outputs) over its drive-wide robust "
        "scale, windowed NIS 2 s trailing, chi2 99 %; saturation; not observed",
        residual_scales={k: float(v) for k, v in scales.items()},
        saturated_share=float(np.mean(observed & (sat > 0))) if n else 0.0,
        not_observed_share=float(np.mean(~observed)) if n else 0.0,
        weak_observability_share=float(np.mean(weak_term > 0)) if n else 0.0,
        sensor_gap_share=float(np.mean(gap > 0)) if n else 0.0,
    )
    return np.asarray(health, dtype=float), summary
