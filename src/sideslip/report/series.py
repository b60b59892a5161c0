"""What the report plots, computed once: time from the drive's start, decimation of plotted
series (never of metrics), GNSS outages, the ranking of methods, error statistics and the
uncertainty calibration."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from sideslip.drive import Drive
from sideslip.evaluate import SPEED_GATE, forward_speed, sigma_shares
from sideslip.frames import wrap_angle

FloatArray = NDArray[np.float64]
Series = Mapping[str, Mapping[str, np.ndarray]]

BUCKETS = 1000  # min/max decimation: at most 2 x BUCKETS points per plotted trace
BAND_POINTS = 800  # 1-sigma bands change slowly: a stride to this many points is enough
SHOWN = 3  # methods drawn by default in each plot; the others are one legend click away
DEFAULT_METHOD = "fused"  # shown by default when there is no reference to rank by
SPARSE_SHARE = 0.5  # a reference with samples on fewer rows than this is drawn as markers
# calibration verdict: shares of |error| inside 1 sigma and 2 sigma of a Gaussian are 68.3 % and
# 95.4 %; with correlated errors a drive's share scatters, so bands of about +-5 points are "ok"
CALIBRATED_2SIGMA = (0.90, 0.99)
CALIBRATED_1SIGMA = (0.55, 0.82)


def time_axis(drive: Drive) -> FloatArray:
    """Time from the drive's first row, s (what every plot shows)."""
    return np.asarray(drive.t - drive.t[0], dtype=float)


def minmax_indices(y: np.ndarray, buckets: int = BUCKETS) -> NDArray[np.intp]:
    """Row indices keeping each bucket's minimum and maximum finite value (envelope-preserving
    decimation), in time order; all rows when there are few."""
    finite = np.flatnonzero(np.isfinite(y))
    if finite.size <= 2 * buckets:
        return finite
    vals = y[finite]
    width = math.ceil(finite.size / buckets)
    pad = width * buckets - finite.size
    v = np.concatenate([vals, np.full(pad, np.nan)]).reshape(buckets, width)
    filled = ~np.all(np.isnan(v), axis=1)
    v = v[filled]
    base = np.flatnonzero(filled) * width
    lo = base + np.nanargmin(v, axis=1)
    hi = base + np.nanargmax(v, axis=1)
    keep = np.unique(np.concatenate([lo, hi]))
    return finite[keep]


def decimate(t: np.ndarray, y: np.ndarray, buckets: int = BUCKETS) -> tuple[np.ndarray, np.ndarray]:
    """(t, y) after :func:`minmax_indices`, with a NaN break wherever non-finite rows were left
    out (so a line is not drawn across standstill or a missing reference)."""
    idx = minmax_indices(y, buckets)
    if idx.size < 2:
        return t[idx], y[idx]
    missing = np.cumsum(~np.isfinite(y))
    breaks = np.flatnonzero(missing[idx[1:]] - missing[idx[:-1]] > 0) + 1
    return np.insert(t[idx], breaks, np.nan), np.insert(y[idx], breaks, np.nan)


def stride_indices(n: int, points: int = 2 * BUCKETS) -> NDArray[np.intp]:
    """Every k-th row so that at most ``points`` remain (for smooth series such as bands)."""
    return np.arange(0, n, max(1, math.ceil(n / points)))


def is_sparse(values: np.ndarray) -> bool:
    """True when a series has samples on few rows (e.g. a 20 Hz reference on a 100 Hz drive)."""
    return bool(np.isfinite(values).mean() < SPARSE_SHARE) if values.size else False


def gnss_outages(drive: Drive, min_gap_s: float = 1.0) -> list[tuple[float, float]]:
    """GNSS outages as (start, end) in time from the start, s: gaps between fixes longer than
    ``min_gap_s`` and five receiver intervals, including a missing start or end."""
    col = next((c for c in ("gnss_e", "gnss_ve") if c in drive), None)
    if col is None:
        return []
    t = time_axis(drive)
    rows = np.flatnonzero(np.isfinite(drive[col]))
    if rows.size < 2:
        return [(float(t[0]), float(t[-1]))]
    tf = t[rows]
    step = float(np.median(np.diff(tf)))
    gap = max(min_gap_s, 5.0 * step)
    out = [(float(tf[i]), float(tf[i + 1])) for i in np.flatnonzero(np.diff(tf) > gap)]
    if tf[0] - t[0] > gap:
        out.insert(0, (float(t[0]), float(tf[0])))
    if t[-1] - tf[-1] > gap:
        out.append((float(tf[-1]), float(t[-1])))
    return out


@dataclass(frozen=True)
class Ranking:
    """Methods in plot order and which are drawn by default; ``by`` says what ranked them
    (``None``: no reference, nothing ranked)."""

    order: tuple[str, ...]
    shown: frozenset[str]
    by: str | None
    colour_index: Mapping[str, int]  # the same colour for a method in every plot

    def visible(self, method: str) -> bool | str:
        return True if method in self.shown else "legendonly"


def rank(methods: Sequence[str], results: Mapping[str, Mapping[str, float]], metric: str) -> Ranking:
    """Best first by ``metric`` (e.g. ``beta_rmse_deg``) when a reference gave it; otherwise
    alphabetical with only :data:`DEFAULT_METHOD` (or the first) shown."""
    colours = {m: i for i, m in enumerate(sorted(methods))}
    scored = [m for m in methods if math.isfinite(results.get(m, {}).get(metric, math.nan))]
    if scored:
        best = sorted(scored, key=lambda m: results[m][metric])
        rest = sorted(m for m in methods if m not in scored)
        return Ranking(tuple(best + rest), frozenset(best[:SHOWN]), metric, colours)
    order = sorted(methods)
    default = DEFAULT_METHOD if DEFAULT_METHOD in order else (order[0] if order else "")
    return Ranking(tuple(order), frozenset([default]), None, colours)


def gated_errors_deg(drive: Drive, estimate: np.ndarray, ref: str) -> FloatArray:
    """Wrapped errors (deg) on rows with a reference above the metrics' speed gate."""
    ok = np.isfinite(drive[ref]) & np.isfinite(estimate) & (forward_speed(drive) > SPEED_GATE)
    return np.degrees(wrap_angle(estimate[ok] - drive[ref][ok]))


@dataclass(frozen=True)
class Calibration:
    """Share of sideslip errors inside the method's own 1 sigma and 2 sigma, and a verdict."""

    method: str
    within_1sigma: float
    within_2sigma: float
    samples: int

    @property
    def verdict(self) -> str:
        lo2, hi2 = CALIBRATED_2SIGMA
        lo1, hi1 = CALIBRATED_1SIGMA
        if self.within_2sigma < lo2:
            return "over-confident: σ too small"
        if self.within_2sigma > hi2 and self.within_1sigma > hi1:
            return "conservative: σ too large"
        if lo1 <= self.within_1sigma <= hi1:
            return "calibrated"
        return "calibrated at 2σ, not at 1σ (errors not Gaussian)"


def calibration(drive: Drive, est: Series, key: str = "beta", ref: str = "ref_beta") -> list[Calibration]:
    """Per method with a ``<key>_std``: how often the reference lies inside its 1σ and 2σ."""
    out: list[Calibration] = []
    if ref not in drive:
        return out
    for m, series in est.items():
        std = series.get(f"{key}_std") if m else None
        if std is None or key not in series:
            continue
        shares = sigma_shares(drive, series[key], std, ref)
        if shares is not None:
            out.append(Calibration(m, *shares))
    return out


def histogram(errors: Sequence[np.ndarray], bins: int = 60) -> FloatArray:
    """Common bin edges (deg) holding the central 99 % of every method's errors."""
    finite = [e[np.isfinite(e)] for e in errors if e.size]
    if not finite:
        return np.linspace(-1.0, 1.0, bins + 1)
    lo = float(np.median([np.percentile(e, 0.5) for e in finite]))
    hi = float(np.median([np.percentile(e, 99.5) for e in finite]))
    span = max(hi - lo, 0.1)
    return np.linspace(lo - 0.1 * span, hi + 0.1 * span, bins + 1)
