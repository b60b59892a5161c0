"""Metrics of contract section 4: estimates against the reference columns of a drive.

Every metric is computed only on rows where the reference exists and the vehicle moves forward
faster than a stated gate: sideslip is ill-defined at walking pace (beta = atan2(v_y, v_x) is
dominated by noise as v_x -> 0), so beta, roll and yaw metrics use ``SPEED_GATE``.

The 100 m cross-track metric follows seed 000 (Takikawa et al. 2021, Sec. "Evaluation"): a
dead-reckoned segment starts every 10 m of reference path, is aligned to the reference at its
start (position and heading), and its error after 100 m of reference path is measured
orthogonally to the reference path.

Beyond the contract's names, a method that reports its own 1-sigma (``beta_std``) gets
``beta_within_1sigma`` and ``beta_within_2sigma``: the shares of the gated rows whose error
lies inside one and two of those sigmas (a calibrated Gaussian: 0.683 and 0.954).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from sideslip.drive import Drive
from sideslip.frames import wrap_angle
from sideslip.signals import vehicle_speed

FloatArray = NDArray[np.float64]

SPEED_GATE = 5.0  # m/s: metrics of beta, roll and yaw only above this forward speed
XTRACK_SEGMENT_M = 100.0
XTRACK_STEP_M = 10.0

METRIC_NAMES = (
    "beta_rmse_deg", "beta_mean_err_deg", "beta_std_err_deg", "beta_max_err_deg",
    "roll_rmse_deg", "roll_mean_err_deg", "roll_std_err_deg", "yaw_rmse_deg", "pos_rmse_m",
    "xtrack_100m_p95_m", "xtrack_100m_max_m",
)  # fmt: skip


@dataclass(frozen=True)
class Window:
    """A time window [t0, t1] in s (e.g. a GNSS outage) for per-window position errors."""

    t0: float
    t1: float

    @property
    def label(self) -> str:
        return f"{self.t0:g}-{self.t1:g}"


def forward_speed(drive: Drive) -> FloatArray:
    """Forward speed for gating: reference v_x when present, else the measured speed."""
    if "ref_vx" in drive:
        return np.nan_to_num(drive["ref_vx"], nan=0.0)
    return vehicle_speed(drive)


def _stats(err: FloatArray, prefix: str, to_deg: bool = True) -> dict[str, float]:
    scale = np.degrees(1.0) if to_deg else 1.0
    e = err * scale
    if e.size == 0:
        return {}
    return {
        f"{prefix}_rmse_deg": float(np.sqrt(np.mean(e**2))),
        f"{prefix}_mean_err_deg": float(np.mean(e)),
        f"{prefix}_std_err_deg": float(np.std(e)),
        f"{prefix}_max_err_deg": float(np.max(np.abs(e))),
    }


def angle_errors(drive: Drive, estimate: FloatArray, ref_column: str, gate: float = SPEED_GATE) -> FloatArray:
    """Wrapped errors estimate - reference (rad) on gated rows with a finite reference."""
    ref = drive.get(ref_column)
    if ref is None:
        return np.zeros(0)
    ok = np.isfinite(ref) & np.isfinite(estimate) & (forward_speed(drive) > gate)
    return wrap_angle(estimate[ok] - ref[ok])


def sigma_shares(
    drive: Drive, estimate: FloatArray, std: FloatArray, ref_column: str, gate: float = SPEED_GATE
) -> tuple[float, float, int] | None:
    """Shares of the gated rows (finite reference, finite positive ``std``) whose wrapped error
    ``|estimate - reference|`` is inside 1 and 2 ``std`` (same unit, rad for angles), and the
    number of those rows; None where there are none."""
    ref = drive.get(ref_column)
    if ref is None:
        return None
    ok = np.isfinite(ref) & np.isfinite(estimate) & np.isfinite(std) & (std > 0)
    ok &= forward_speed(drive) > gate
    if not ok.any():
        return None
    z = np.abs(wrap_angle(estimate[ok] - ref[ok])) / std[ok]
    return float(np.mean(z < 1.0)), float(np.mean(z < 2.0)), int(ok.sum())


def _path_tangent(e: FloatArray, n: FloatArray) -> tuple[FloatArray, FloatArray]:
    de, dn = np.gradient(e), np.gradient(n)
    norm = np.hypot(de, dn)
    norm[norm == 0] = 1.0
    return de / norm, dn / norm


def xtrack_100m(
    drive: Drive,
    e: FloatArray,
    n: FloatArray,
    yaw: FloatArray | None = None,
    segment_m: float = XTRACK_SEGMENT_M,
    step_m: float = XTRACK_STEP_M,
) -> FloatArray:
    """Cross-track errors (m, signed, left of the reference path positive) of 100 m segments.

    For each start point (every ``step_m`` of reference path length), the estimated trajectory
    from that row is translated to the reference position and, when ``yaw`` is given, rotated
    by (ref_yaw - yaw) at the start, i.e. the dead reckoning is re-initialised from the
    reference.  The error at the row where the reference has travelled ``segment_m`` further is
    projected on the normal of the reference path there.  Rows without reference are skipped.
    """
    if "ref_e" not in drive or "ref_n" not in drive:
        return np.zeros(0)
    re_, rn = drive["ref_e"], drive["ref_n"]
    ok = np.isfinite(re_) & np.isfinite(rn) & np.isfinite(e) & np.isfinite(n)
    if ok.sum() < 2:
        return np.zeros(0)
    idx = np.flatnonzero(ok)
    re_, rn, ee, en = re_[idx], rn[idx], e[idx], n[idx]
    s = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(re_), np.diff(rn)))])
    if s[-1] < segment_m:
        return np.zeros(0)
    starts_s = np.arange(0.0, s[-1] - segment_m, step_m)
    i0 = np.searchsorted(s, starts_s)
    i1 = np.searchsorted(s, s[i0] + segment_m)
    keep = i1 < s.size
    i0, i1 = i0[keep], i1[keep]
    de, dn = ee[i1] - ee[i0], en[i1] - en[i0]
    if yaw is not None and "ref_yaw" in drive:
        ref_yaw = drive["ref_yaw"][idx]
        rot = wrap_angle(np.nan_to_num(ref_yaw[i0] - yaw[idx][i0]))
        c, sn = np.cos(rot), np.sin(rot)
        de, dn = c * de - sn * dn, sn * de + c * dn
    end_e = re_[i0] + de
    end_n = rn[i0] + dn
    te, tn = _path_tangent(re_, rn)
    err_e, err_n = end_e - re_[i1], end_n - rn[i1]
    return np.asarray(te[i1] * err_n - tn[i1] * err_e, dtype=float)


def window_errors(
    drive: Drive, e: FloatArray, n: FloatArray, windows: Sequence[Window]
) -> list[dict[str, float]]:
    """Horizontal position error (m) in each window: mean, max and at the window's end."""
    out: list[dict[str, float]] = []
    if "ref_e" not in drive or "ref_n" not in drive:
        return out
    err = np.hypot(e - drive["ref_e"], n - drive["ref_n"])
    for w in windows:
        rows = (drive.t >= w.t0) & (drive.t <= w.t1) & np.isfinite(err)
        if not rows.any():
            continue
        werr = err[rows]
        out.append(
            {
                "t0": w.t0,
                "t1": w.t1,
                "mean_m": float(np.mean(werr)),
                "max_m": float(np.max(werr)),
                "end_m": float(werr[-1]),
            }
        )
    return out


def metrics(
    drive: Drive,
    series: Mapping[str, FloatArray],
    windows: Sequence[Window] = (),
    gate: float = SPEED_GATE,
) -> dict[str, float]:
    """Contract metrics for one method's series (``beta``, ``roll``, ``yaw``, ``e``, ``n`` ...)."""
    out: dict[str, float] = {}
    if "beta" in series:
        out.update(_stats(angle_errors(drive, series["beta"], "ref_beta", gate), "beta"))
        shares = None
        if "beta_std" in series:
            shares = sigma_shares(drive, series["beta"], series["beta_std"], "ref_beta", gate)
        if shares is not None:
            out["beta_within_1sigma"], out["beta_within_2sigma"] = shares[:2]
    if "roll" in series:
        stats = _stats(angle_errors(drive, series["roll"], "ref_roll", gate), "roll")
        stats.pop("roll_max_err_deg", None)
        out.update(stats)
    if "bank" in series:
        err = angle_errors(drive, series["bank"], "ref_bank", gate)
        if err.size:
            out["bank_rmse_deg"] = float(np.degrees(np.sqrt(np.mean(err**2))))
    if "yaw" in series:
        err = angle_errors(drive, series["yaw"], "ref_yaw", gate)
        if err.size:
            out["yaw_rmse_deg"] = float(np.degrees(np.sqrt(np.mean(err**2))))
    if "r" in series and "ref_r" in drive:
        ref = drive["ref_r"]
        ok = np.isfinite(ref) & (forward_speed(drive) > gate)
        if ok.any():
            out["r_rmse_degps"] = float(np.degrees(np.sqrt(np.mean((series["r"][ok] - ref[ok]) ** 2))))
    if "e" in series and "n" in series and "ref_e" in drive and "ref_n" in drive:
        e, n = series["e"], series["n"]
        err = np.hypot(e - drive["ref_e"], n - drive["ref_n"])
        ok = np.isfinite(err)
        if ok.any():
            out["pos_rmse_m"] = float(np.sqrt(np.mean(err[ok] ** 2)))
        xt = np.abs(xtrack_100m(drive, e, n, series.get("yaw")))
        if xt.size:
            out["xtrack_100m_p95_m"] = float(np.percentile(xt, 95))
            out["xtrack_100m_max_m"] = float(np.max(xt))
            out["xtrack_100m_mean_m"] = float(np.mean(xt))
        for w in window_errors(drive, e, n, windows):
            label = f"{w['t0']:g}-{w['t1']:g}"
            out[f"window_{label}_pos_mean_m"] = w["mean_m"]
            out[f"window_{label}_pos_max_m"] = w["max_m"]
    return out


def evaluate_all(
    drive: Drive,
    estimates: Mapping[str, Mapping[str, FloatArray]],
    windows: Sequence[Window] = (),
) -> dict[str, dict[str, float]]:
    """method -> metric -> value for every method in an estimate table (see load_estimates)."""
    return {method: metrics(drive, series, windows) for method, series in estimates.items() if method}


from sideslip._callable import make_callable  # noqa: E402  (last: the module must exist)

make_callable(__name__, "sideslip.api:evaluate")  # sideslip.evaluate(drive, estimates)
