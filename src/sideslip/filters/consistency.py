"""Filter consistency on a drive: windowed NIS against chi^2 bounds, covariance inflation, health.

A filter whose model fits the data produces innovations ``nu_k`` with normalised innovation
squared ``NIS_k = nu_k' S_k^-1 nu_k ~ chi^2(m_k)`` (Bar-Shalom, Li, Kirubarajan, *Estimation
with Applications to Tracking and Navigation*, 2001, sec. 5.4).  Summed over a sliding window of
``W`` seconds the sum is ``chi^2(sum m_k)``; where it exceeds the upper bound the model has
stopped fitting (tyres past their linear range, a wrong vehicle file, a banked road) and the
filter's covariance understates the error by about the ratio ``sum NIS / sum m``.

:func:`nis_consistency` turns a method's per-row NIS into

* ``inflation`` (>= 1, per row): the factor on the *variance* of the state estimate, equal to
  the window's mean NIS per degree of freedom where that mean is beyond the chi^2 bound, else 1;
* ``health`` (0 good ... 1 unusable, per row): 0 inside the bound, rising with the log of the
  excess to 1 at ``unusable_ratio`` times the expected NIS.

Everything is cumulative sums: O(N) in the drive's length, no loop in Python.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import stats

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Consistency:
    """Result of :func:`nis_consistency`, per row of the drive.

    ``mean_nis``: windowed NIS per degree of freedom (1 when consistent; NaN-free: rows whose
    window holds no innovation get 1).  ``inflation``: variance factor >= 1.  ``health``: 0 ... 1.
    ``flagged``: rows whose windowed NIS is beyond the bound.  ``bound``: the chi^2 upper bound
    per degree of freedom each row was tested against.
    """

    mean_nis: FloatArray
    inflation: FloatArray
    health: FloatArray
    flagged: NDArray[np.bool_]
    bound: FloatArray

    def worst(self, other: Consistency) -> Consistency:
        """Row by row the worse of two tests of the same rows (another channel's own test):
        flagged where either is, the larger inflation and health, the larger mean NIS with
        its bound."""
        mine = self.mean_nis / self.bound >= other.mean_nis / other.bound
        return Consistency(
            np.where(mine, self.mean_nis, other.mean_nis),
            np.maximum(self.inflation, other.inflation),
            np.maximum(self.health, other.health),
            self.flagged | other.flagged,
            np.where(mine, self.bound, other.bound),
        )

    def summary(self, t: FloatArray) -> dict[str, object]:
        """Params entry: share of flagged rows and the flagged spans (start, end in s)."""
        spans: list[list[float]] = []
        f = self.flagged
        if f.any():
            edges = np.flatnonzero(np.diff(np.r_[0, f.astype(np.int8), 0]))
            for a, b in zip(edges[::2], edges[1::2], strict=True):
                spans.append([float(t[a]), float(t[b - 1])])
        return {
            "criterion": "windowed NIS beyond the chi2 upper bound",
            "flagged_share": float(f.mean()) if f.size else 0.0,
            "flagged_spans_s": spans[:200],
            "n_flagged_spans": len(spans),
            "max_inflation": float(self.inflation.max()) if f.size else 1.0,
        }


def _window_sum(values: FloatArray, t: FloatArray, half_window_s: float) -> FloatArray:
    """Centred sliding sums of ``values`` over ``|t_j - t_i| <= half_window_s`` (O(N))."""
    c = np.concatenate(([0.0], np.cumsum(values)))
    lo = np.searchsorted(t, t - half_window_s, side="left")
    hi = np.searchsorted(t, t + half_window_s, side="right")
    return np.asarray(c[hi] - c[lo], dtype=float)


def nis_consistency(
    t: ArrayLike,
    nis: ArrayLike,
    dof: ArrayLike | int = 1,
    *,
    window_s: float = 2.0,
    probability: float = 0.99,
    unusable_ratio: float = 10.0,
    causal: bool = False,
) -> Consistency:
    """Windowed NIS test of a filter's innovations (module docstring).

    ``t`` (N,) s, increasing.  ``nis`` (N,) the NIS of each row's update (NaN or 0 with
    ``dof = 0`` where the row had none).  ``dof`` (N,) or scalar: measurement dimension per row.
    ``window_s``: width of the sliding window, s (centred; trailing when ``causal``).
    ``probability``: of the chi^2 bound.  ``unusable_ratio``: windowed NIS per dof at which
    ``health`` reaches 1.
    """
    t = np.asarray(t, dtype=float)
    nis = np.asarray(nis, dtype=float)
    dof_arr = np.broadcast_to(np.asarray(dof, dtype=float), nis.shape).astype(float)
    ok = np.isfinite(nis) & (dof_arr > 0)
    nis_v = np.where(ok, np.maximum(nis, 0.0), 0.0)
    dof_v = np.where(ok, dof_arr, 0.0)
    if causal:
        c_n = np.concatenate(([0.0], np.cumsum(nis_v)))
        c_d = np.concatenate(([0.0], np.cumsum(dof_v)))
        lo = np.searchsorted(t, t - window_s, side="left")
        hi = np.arange(1, t.size + 1)
        sum_nis, sum_dof = c_n[hi] - c_n[lo], c_d[hi] - c_d[lo]
    else:
        sum_nis = _window_sum(nis_v, t, 0.5 * window_s)
        sum_dof = _window_sum(dof_v, t, 0.5 * window_s)
    has = sum_dof > 0
    safe_dof = np.where(has, sum_dof, 1.0)
    mean_nis = np.where(has, sum_nis / safe_dof, 1.0)
    # one chi^2 quantile per distinct window size, not per row (windows share their sizes)
    sizes, where = np.unique(safe_dof, return_inverse=True)
    bound = np.where(has, (stats.chi2.ppf(probability, sizes) / sizes)[where], np.inf)
    flagged = has & (mean_nis > bound)
    inflation = np.where(flagged, mean_nis, 1.0)
    excess = np.log(np.maximum(mean_nis / np.where(has, bound, 1.0), 1.0))
    health = np.where(flagged, np.clip(excess / np.log(unusable_ratio), 0.0, 1.0), 0.0)
    return Consistency(mean_nis, inflation, health, flagged, bound)
