"""Evaluation windows: ``--window T0:T1`` restricts every metric to the rows inside.

Times are the drive's own time stamps ``t`` (s).  A window must lie within the drive; several
windows pool their rows.  The 100 m cross-track segments (seed 000's metric) never span two
windows: they are computed in each window and pooled.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from sideslip.drive import Drive
from sideslip.errors import InputError
from sideslip.evaluate import Window, evaluate_all, xtrack_100m

Series = Mapping[str, Mapping[str, Any]]


def parse_window(text: str, where: str = "--window") -> Window:
    """``"120:150"`` -> ``Window(120, 150)``; anything else is one InputError line."""
    try:
        a, b = (float(x) for x in text.split(":"))
    except ValueError:
        raise InputError(where, f"'{text}': expected T0:T1 in seconds, e.g. 120:150") from None
    if not (np.isfinite(a) and np.isfinite(b)) or not b > a:
        raise InputError(where, f"'{text}': expected T1 > T0")
    return Window(a, b)


def check_windows(drive: Drive, windows: Sequence[Window], where: str = "--window") -> None:
    """Each window must lie inside the drive's time span and hold at least two rows."""
    t0, t1 = float(drive.t[0]), float(drive.t[-1])
    tol = drive.dt_median * (1 + 1e-9)  # one sample: "0:20" fits a drive whose last stamp is 19.98
    for w in windows:
        rows = int(np.count_nonzero((drive.t >= w.t0) & (drive.t <= w.t1)))
        if w.t0 < t0 - tol or w.t1 > t1 + tol or rows < 2:
            hint = f" (time from the start is t - {t0:g})" if abs(t0) > 1.0 else ""
            raise InputError(
                where,
                f"'{w.t0:g}:{w.t1:g}' is outside the drive {drive.path}: expected T0:T1 within its "
                f"time stamps {t0:g}:{t1:g} s{hint}",
            )


def _mask(t: np.ndarray, windows: Sequence[Window]) -> np.ndarray:
    keep = np.zeros(t.size, dtype=bool)
    for w in windows:
        keep |= (t >= w.t0) & (t <= w.t1)
    return keep


def restrict(drive: Drive, series: Series, windows: Sequence[Window]) -> tuple[Drive, dict[str, Any]]:
    """The drive and the estimates on the rows inside ``windows`` only."""
    keep = _mask(drive.t, windows)
    d = Drive(drive.t[keep], {k: np.asarray(v)[keep] for k, v in drive.data.items()}, drive.meta, drive.path)
    out: dict[str, Any] = {}
    for m, s in series.items():
        out[m] = {k: np.asarray(v)[keep] for k, v in s.items()}
    return d, out


def evaluate_windows(drive: Drive, series: Series, windows: Sequence[Window]) -> dict[str, dict[str, float]]:
    """Every metric of :func:`sideslip.evaluate.evaluate_all` on the rows inside ``windows``."""
    if not windows:
        return evaluate_all(drive, series)
    check_windows(drive, windows)
    d, s = restrict(drive, series, windows)
    results = evaluate_all(d, s, windows)
    if len(windows) > 1:  # cross-track segments within one window each, then pooled
        for method, res in results.items():
            ms = series[method]
            if not ("e" in ms and "n" in ms):
                continue
            pooled = []
            for w in windows:
                dw, sw = restrict(drive, {method: ms}, [w])
                xt = xtrack_100m(dw, sw[method]["e"], sw[method]["n"], sw[method].get("yaw"))
                pooled.append(np.abs(xt))
            xt_all = np.concatenate(pooled) if pooled else np.zeros(0)
            for key in ("xtrack_100m_p95_m", "xtrack_100m_max_m", "xtrack_100m_mean_m"):
                res.pop(key, None)
            if xt_all.size:
                res["xtrack_100m_p95_m"] = float(np.percentile(xt_all, 95))
                res["xtrack_100m_max_m"] = float(np.max(xt_all))
                res["xtrack_100m_mean_m"] = float(np.mean(xt_all))
    return results
