"""Static figures for papers (``sideslip report --static DIR``): PNG (200 dpi) and SVG.

The same content as the HTML report's main plots, drawn with matplotlib (no pyplot state, no
display): sideslip against the reference with the best methods' 1σ bands, the error
distribution per method, the uncertainty calibration, roll, and the ENU trajectory.  Time is
from the drive's start; GNSS outages are shaded.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from sideslip.drive import Drive, _atomic_write
from sideslip.evaluate import evaluate_all
from sideslip.report.figures import PALETTE, robust_range
from sideslip.report.series import (
    Ranking,
    calibration,
    decimate,
    gated_errors_deg,
    gnss_outages,
    histogram,
    rank,
    stride_indices,
    time_axis,
)

Series = Mapping[str, Mapping[str, Any]]
DEG = math.degrees(1.0)
FORMATS = ("png", "svg")
DPI = 200


def _new(width: float = 7.0, height: float = 3.2) -> Any:
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height), layout="constrained")
    return fig, fig.add_subplot()


def _shade(ax: Any, outages: Sequence[tuple[float, float]]) -> None:
    for k, (a, b) in enumerate(outages):
        ax.axvspan(a, b, color="#d62728", alpha=0.12, lw=0, label="GNSS outage" if k == 0 else None)


def _colour(ranking: Ranking, m: str) -> str:
    return PALETTE[ranking.colour_index.get(m, 0) % len(PALETTE)]


def _shown(ranking: Ranking, est: Series, key: str) -> list[str]:
    return [m for m in ranking.order if m in ranking.shown and key in est[m]]


def _angle_figure(
    drive: Drive, est: Series, ranking: Ranking, key: str, ref: str, ylabel: str,
    outages: Sequence[tuple[float, float]],
) -> Any | None:  # fmt: skip
    methods = _shown(ranking, est, key)
    if not methods:
        return None
    fig, ax = _new()
    t = time_axis(drive)
    shown = []
    if ref in drive:
        y = drive[ref] * DEG
        shown.append(y)
        if np.isfinite(y).mean() < 0.5:
            ok = np.isfinite(y)
            ax.plot(t[ok], y[ok], "k.", ms=2, label="reference")
        else:
            ax.plot(*decimate(t, y), "k-", lw=1.8, label="reference")
    for m in methods:
        y = est[m][key] * DEG
        c = _colour(ranking, m)
        std = est[m].get(f"{key}_std")
        if std is not None:
            s = stride_indices(t.size)
            ax.fill_between(t[s], (y - std * DEG)[s], (y + std * DEG)[s], color=c, alpha=0.18, lw=0)
        ax.plot(*decimate(t, y), color=c, lw=1.0, label=m + (" (±1σ)" if std is not None else ""))
        shown.append(y)
    _shade(ax, outages)
    rng = robust_range(shown, 0.5)
    if rng:
        ax.set_ylim(*rng)
    ax.set_xlabel("time from start (s)")
    ax.set_ylabel(ylabel)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncols=3, loc="best")
    return fig


def _histogram_figure(drive: Drive, est: Series, ranking: Ranking) -> Any | None:
    methods = [m for m in ranking.order if "beta" in est[m]] if "ref_beta" in drive else []
    errors = {m: gated_errors_deg(drive, est[m]["beta"], "ref_beta") for m in methods}
    errors = {m: e for m, e in errors.items() if e.size}
    if not errors:
        return None
    show = [m for m in ranking.order if m in errors][:6]
    edges = histogram([errors[m] for m in show])
    cols = min(3, len(show))
    rows = math.ceil(len(show) / cols)
    from matplotlib.figure import Figure

    fig = Figure(figsize=(7.0, 1.9 * rows + 0.4), layout="constrained")
    axes = fig.subplots(rows, cols, squeeze=False, sharex=True)
    for k, ax in enumerate(axes.flat):
        if k >= len(show):
            ax.set_visible(False)
            continue
        m = show[k]
        e = np.clip(errors[m], edges[0], edges[-1])
        ax.hist(e, bins=edges, color=_colour(ranking, m), alpha=0.8, weights=np.full(e.size, 1 / e.size))
        ax.axvline(0, color="k", lw=0.6, ls=":")
        ax.set_title(f"{m}: RMS {np.sqrt(np.mean(errors[m] ** 2)):.3f}°", fontsize=8)
        ax.tick_params(labelsize=7)
    fig.supxlabel("β error (deg)", fontsize=8)
    fig.supylabel("share of samples", fontsize=8)
    return fig


def _calibration_figure(drive: Drive, est: Series) -> Any | None:
    cal = sorted(calibration(drive, est), key=lambda c: c.method)
    if not cal:
        return None
    fig, ax = _new(7.0, 0.25 * len(cal) + 1.2)
    y = np.arange(len(cal))
    ax.barh(y + 0.2, [c.within_2sigma for c in cal], 0.4, color="#9ecae1", label="|e| < 2σ")
    ax.barh(y - 0.2, [c.within_1sigma for c in cal], 0.4, color="#3182bd", label="|e| < 1σ")
    ax.axvline(0.954, color="k", ls="--", lw=0.8)
    ax.axvline(0.683, color="k", ls=":", lw=0.8)
    ax.set_yticks(y, [c.method for c in cal], fontsize=7)
    ax.set_xlim(0, 1)
    ax.set_xlabel("share of β errors inside the method's own σ (lines: Gaussian 68.3 %, 95.4 %)")
    ax.legend(fontsize=7, loc="lower left")
    return fig


def _map_figure(drive: Drive, est: Series, ranking: Ranking) -> Any | None:
    methods = [m for m in ranking.order if m in ranking.shown and "e" in est[m] and "n" in est[m]]
    if not methods and "ref_e" not in drive:
        return None
    fig, ax = _new(5.5, 5.0)
    s = stride_indices(len(drive))
    if "ref_e" in drive and "ref_n" in drive:
        ax.plot(drive["ref_e"][s], drive["ref_n"][s], "k-", lw=2.0, label="reference")
    for m in methods:
        ax.plot(est[m]["e"][s], est[m]["n"][s], color=_colour(ranking, m), lw=1.0, label=m)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("east (m)")
    ax.set_ylabel("north (m)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    return fig


def write_static(
    drive: Drive,
    est: Series,
    out_dir: str | Path,
    formats: Sequence[str] = FORMATS,
    progress: Callable[[str], None] | None = None,
) -> list[Path]:
    """Write the figures as ``<name>.png`` and ``<name>.svg`` into ``out_dir``; returns the
    files written (each atomically)."""
    tell = progress or (lambda _step: None)
    est = {m: s for m, s in est.items() if m}
    results = evaluate_all(drive, est)
    methods = list(est)
    o = gnss_outages(drive)
    beta_rank = rank(methods, results, "beta_rmse_deg")
    roll_rank = rank(methods, results, "roll_rmse_deg")
    pos_rank = rank(methods, results, "pos_rmse_m")
    builders: list[tuple[str, Callable[[], Any]]] = [
        ("beta", lambda: _angle_figure(drive, est, beta_rank, "beta", "ref_beta", "sideslip β (deg)", o)),
        ("beta_error_histogram", lambda: _histogram_figure(drive, est, beta_rank)),
        ("beta_calibration", lambda: _calibration_figure(drive, est)),
        ("roll", lambda: _angle_figure(drive, est, roll_rank, "roll", "ref_roll", "roll (deg)", o)),
        ("trajectory", lambda: _map_figure(drive, est, pos_rank)),
    ]
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []
    for name, build in builders:
        tell(name)
        fig = build()
        if fig is None:
            continue
        for fmt in formats:
            path = out / f"{name}.{fmt}"
            def save(tmp: Path, f: Any = fig, x: str = fmt) -> None:
                f.savefig(tmp, format=x, dpi=DPI)

            _atomic_write(path, save)
            written.append(path)
    return written
