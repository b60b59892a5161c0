"""Self-contained HTML report: metrics, sideslip/roll/yaw against the reference, trajectory,
uncertainty calibration, identified parameters.  One file, plotly.js inlined, no network."""

from __future__ import annotations

import html
import json
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import plotly.graph_objects as go
from plotly.offline import get_plotlyjs

from sideslip.drive import COLUMNS, Drive, _atomic_write
from sideslip.evaluate import METRIC_NAMES, SPEED_GATE, evaluate_all, forward_speed
from sideslip.frames import wrap_angle

MAX_POINTS = 2500  # per trace: keeps the file small and the page responsive
PALETTE = (
    "#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f",
    "#bcbd22", "#17becf", "#393b79", "#637939", "#8c6d31", "#843c39", "#7b4173", "#3182bd",
)  # fmt: skip

Series = Mapping[str, Mapping[str, np.ndarray]]


def _stride(n: int) -> slice:
    return slice(None, None, max(1, math.ceil(n / MAX_POINTS)))


def _figure(title: str, ytitle: str, xtitle: str = "time (s)") -> go.Figure:
    fig = go.Figure()
    fig.update_layout(
        title=title,
        xaxis_title=xtitle,
        yaxis_title=ytitle,
        template="plotly_white",
        height=420,
        margin={"l": 60, "r": 20, "t": 50, "b": 50},
        legend={"orientation": "h", "y": -0.2},
    )
    return fig


def _colour(i: int) -> str:
    return PALETTE[i % len(PALETTE)]


SHOWN = 5  # methods drawn by default (the best by beta RMSE); the others: click the legend


def _visible(rank: int) -> bool | str:
    return True if rank < SHOWN else "legendonly"


def _robust_range(values: list[np.ndarray], pad: float) -> list[float] | None:
    """A y-range holding the bulk of the shown curves, so that one drifting method (the
    open-loop baseline) does not flatten the others; zoom out to see all."""
    finite = [v[np.isfinite(v)] for v in values]
    finite = [v for v in finite if v.size]
    if not finite:
        return None
    lo = float(np.median([np.percentile(v, 0.5) for v in finite]))
    hi = float(np.median([np.percentile(v, 99.5) for v in finite]))
    span = max(hi - lo, pad)
    return [lo - 0.25 * span, hi + 0.25 * span]


def _time_plot(
    drive: Drive,
    est: Series,
    order: list[str],
    key: str,
    ref: str | None,
    title: str,
    scale: float,
) -> go.Figure | None:
    methods = [m for m in order if key in est[m]]
    if not methods:
        return None
    fig = _figure(title, "deg")
    s = _stride(len(drive))
    t = drive.t[s]
    shown = []
    if ref and ref in drive:
        y_ref = drive[ref][s] * scale
        fig.add_scatter(x=t, y=y_ref, name="reference", line={"color": "black", "width": 3})
        shown.append(y_ref)
    for i, m in enumerate(methods):
        y = est[m][key][s] * scale
        fig.add_scatter(
            x=t, y=y, name=m, line={"color": _colour(i), "width": 1.5}, visible=_visible(i)
        )
        if i < SHOWN:
            shown.append(y)
    rng = _robust_range(shown, 0.5)
    if rng:
        fig.update_yaxes(range=rng)
    return fig


def _error_plot(
    drive: Drive, est: Series, order: list[str], key: str, ref: str, title: str
) -> go.Figure | None:
    methods = [m for m in order if key in est[m]]
    if not methods or ref not in drive:
        return None
    fig = _figure(title, "error (deg)")
    s = _stride(len(drive))
    t = drive.t[s]
    gate = forward_speed(drive) > SPEED_GATE
    shown = []
    for i, m in enumerate(methods):
        err = np.degrees(wrap_angle(est[m][key] - drive[ref]))
        err = np.where(gate, err, np.nan)[s]
        fig.add_scatter(
            x=t, y=err, name=m, line={"color": _colour(i), "width": 1.2},
            visible=_visible(i), legendgroup=m,
        )  # fmt: skip
        if i < SHOWN:
            shown.append(err)
        std = est[m].get(f"{key}_std")
        if std is not None:
            band = 2 * np.degrees(std[s])
            fig.add_scatter(
                x=np.concatenate([t, t[::-1]]),
                y=np.concatenate([band, -band[::-1]]),
                fill="toself",
                fillcolor=_colour(i),
                opacity=0.15,
                line={"width": 0},
                name=f"{m} ±2σ",
                hoverinfo="skip",
                visible=_visible(i),
                legendgroup=m,
                showlegend=False,
            )
    rng = _robust_range(shown, 0.2)
    if rng:
        fig.update_yaxes(range=rng)
    return fig


def _map_plot(drive: Drive, est: Series, order: list[str]) -> go.Figure | None:
    methods = [m for m in order if "e" in est[m] and "n" in est[m]]
    has_ref = "ref_e" in drive and "ref_n" in drive
    has_gnss = "gnss_e" in drive and "gnss_n" in drive
    if not (methods or has_ref or has_gnss):
        return None
    fig = _figure("Trajectory (ENU)", "north (m)", "east (m)")
    fig.update_layout(height=620)
    fig.update_yaxes(scaleanchor="x", scaleratio=1)
    s = _stride(len(drive))
    if has_ref:
        fig.add_scatter(
            x=drive["ref_e"][s], y=drive["ref_n"][s], name="reference",
            line={"color": "black", "width": 3},
        )  # fmt: skip
    if has_gnss:
        ok = np.isfinite(drive["gnss_e"])
        ge, gn = drive["gnss_e"][ok], drive["gnss_n"][ok]
        gs = _stride(ge.size)
        fig.add_scatter(
            x=ge[gs], y=gn[gs], mode="markers", name="GNSS fixes",
            marker={"size": 3, "color": "#999"},
        )  # fmt: skip
    for i, m in enumerate(methods):
        fig.add_scatter(
            x=est[m]["e"][s], y=est[m]["n"][s], name=m,
            line={"color": _colour(i), "width": 1.5}, visible=_visible(i),
        )  # fmt: skip
    return fig


def _speed_plot(drive: Drive) -> go.Figure:
    from sideslip.signals import vehicle_speed

    fig = _figure("Speed and GNSS availability", "m/s")
    s = _stride(len(drive))
    fig.add_scatter(x=drive.t[s], y=vehicle_speed(drive)[s], name="measured speed", line={"color": "#1f77b4"})
    if "gnss_e" in drive:
        rows = np.flatnonzero(np.isfinite(drive["gnss_e"]))
        if rows.size > 1:
            gaps = np.flatnonzero(np.diff(drive.t[rows]) > 5 * np.median(np.diff(drive.t[rows])))
            for g in gaps:
                fig.add_vrect(
                    x0=drive.t[rows[g]],
                    x1=drive.t[rows[g + 1]],
                    fillcolor="red",
                    opacity=0.12,
                    line_width=0,
                    annotation_text="GNSS gap",
                    annotation_position="top left",
                )
    return fig


def _coverage(drive: Drive, est: Series) -> list[tuple[str, float, float, int]]:
    """(method, share of |beta error| within 1 sigma, within 2 sigma, samples)."""
    out: list[tuple[str, float, float, int]] = []
    if "ref_beta" not in drive:
        return out
    gate = forward_speed(drive) > SPEED_GATE
    for m, series in est.items():
        if not m or "beta_std" not in series:
            continue
        ok = gate & np.isfinite(drive["ref_beta"]) & (series["beta_std"] > 0)
        if not ok.any():
            continue
        z = np.abs(wrap_angle(series["beta"][ok] - drive["ref_beta"][ok])) / series["beta_std"][ok]
        out.append((m, float(np.mean(z < 1)), float(np.mean(z < 2)), int(ok.sum())))
    return out


def _metrics_html(results: dict[str, dict[str, float]]) -> str:
    names = [k for k in METRIC_NAMES if any(k in r for r in results.values())]
    extra = sorted({k for r in results.values() for k in r} - set(METRIC_NAMES))
    cols = names + extra
    if not cols:
        return "<p>No reference columns: no metrics.</p>"
    best: dict[str, float] = {}
    for c in cols:
        vals = [abs(r[c]) for r in results.values() if c in r and math.isfinite(r[c])]
        if vals:
            best[c] = min(vals)
    head = "".join(f"<th>{html.escape(c)}</th>" for c in cols)
    body = []
    order = sorted(results, key=lambda m: results[m].get("beta_rmse_deg", math.inf))
    for m in order:
        r = results[m]
        cells = []
        for c in cols:
            if c not in r:
                cells.append("<td>–</td>")
                continue
            cls = ' class="best"' if c in best and abs(r[c]) == best[c] and len(results) > 1 else ""
            cells.append(f"<td{cls}>{r[c]:.3f}</td>")
        body.append(f"<tr><th>{html.escape(m)}</th>{''.join(cells)}</tr>")
    return f"<table><tr><th>method</th>{head}</tr>{''.join(body)}</table>"


CSS = """
body{font-family:system-ui,-apple-system,Segoe UI,Roboto,sans-serif;margin:2em auto;max-width:1200px;
color:#222;padding:0 1em}
h1{margin-bottom:0.2em} .sub{color:#666;margin-top:0}
table{border-collapse:collapse;font-size:13px;margin:1em 0;display:block;overflow-x:auto}
th,td{border:1px solid #ddd;padding:4px 8px;text-align:right} th{background:#f5f5f5}
tr th:first-child{text-align:left} td.best{background:#d8f0d8;font-weight:600}
details{margin:0.5em 0} pre{background:#f8f8f8;padding:0.8em;overflow-x:auto;font-size:12px}
.card{border:1px solid #eee;border-radius:8px;padding:0.5em 1em;margin:1em 0}
"""


def render_report(
    drive: Drive,
    est: Series,
    params: Mapping[str, Any] | None = None,
    title: str | None = None,
) -> str:
    """The report as one HTML string."""
    results = evaluate_all(drive, {m: s for m, s in est.items() if m})
    duration = float(drive.t[-1] - drive.t[0])
    meta = dict(drive.meta)
    scenario = meta.get("scenario") or meta.get("source") or Path(drive.path).name
    title = title or f"sideslip report — {scenario}"
    methods = [m for m in est if m]
    # plots list methods best first (beta RMSE, else roll RMSE), the rest keep their order
    order = sorted(
        methods,
        key=lambda m: (
            results.get(m, {}).get("beta_rmse_deg", math.inf),
            results.get(m, {}).get("roll_rmse_deg", math.inf),
        ),
    )
    sensors = [c for c in COLUMNS if c != "t" and not c.startswith("ref_") and c in drive]
    parts = [
        f"<h1>{html.escape(title)}</h1>",
        f'<p class="sub">{len(drive):,} rows, {duration:.1f} s; '
        f"vehicle {html.escape(str(meta.get('vehicle', '?')))}; "
        f"sensors: {html.escape(', '.join(sensors))}; "
        f"methods: {html.escape(', '.join(methods))}.</p>",
        '<div class="card"><h2>Metrics</h2>',
        f"<p>Errors against the reference on rows faster than {SPEED_GATE:g} m/s; "
        "best in each column in green.</p>",
        _metrics_html(results),
        "</div>",
    ]
    cov = _coverage(drive, est)
    if cov:
        rows = "".join(
            f"<tr><th>{html.escape(m)}</th><td>{a:.1%}</td><td>{b:.1%}</td><td>{n:,}</td></tr>"
            for m, a, b, n in cov
        )
        parts.append(
            '<div class="card"><h2>Uncertainty calibration</h2><p>Share of sideslip errors inside the '
            "method's own 1σ and 2σ (a calibrated Gaussian estimate gives 68.3 % and 95.4 %).</p>"
            "<table><tr><th>method</th><th>|e| &lt; 1σ</th><th>|e| &lt; 2σ</th><th>samples</th></tr>"
            f"{rows}</table></div>"
        )
    deg = math.degrees(1.0)
    beta_err = "Sideslip error (±2σ band where the method gives one)"
    figs = [
        _time_plot(drive, est, order, "beta", "ref_beta", "Sideslip angle β", deg),
        _error_plot(drive, est, order, "beta", "ref_beta", beta_err),
        _time_plot(drive, est, order, "roll", "ref_roll", "Roll angle (body to horizontal)", deg),
        _time_plot(drive, est, order, "bank", "ref_bank", "Road bank angle", deg),
        _error_plot(drive, est, order, "yaw", "ref_yaw", "Yaw (heading) error"),
        _map_plot(drive, est, order),
        _speed_plot(drive),
    ]
    parts.append(
        f"<p>Plots show the {SHOWN} most accurate methods; click a name in a legend to show "
        "or hide any other.  Double-click a plot to zoom out to every curve.</p>"
    )
    for fig in figs:
        if fig is not None:
            parts.append(fig.to_html(full_html=False, include_plotlyjs=False, config={"responsive": True}))
    if params:
        parts.append('<div class="card"><h2>Identified parameters and diagnostics</h2>')
        for m, p in params.items():
            text = html.escape(json.dumps(p, indent=2, default=str))
            parts.append(f"<details><summary>{html.escape(m)}</summary><pre>{text}</pre></details>")
        parts.append("</div>")
    return (
        f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{html.escape(title)}</title>"
        f"<style>{CSS}</style><script>{get_plotlyjs()}</script></head><body>{''.join(parts)}"
        "<p class='sub'>Generated by sideslip.</p></body></html>"
    )


def write_report(drive: Drive, est: Series, out: str | Path, params: Mapping[str, Any] | None = None) -> None:
    """Write the report atomically to ``out`` (HTML)."""
    text = render_report(drive, est, params)
    _atomic_write(Path(out), lambda tmp: tmp.write_text(text, encoding="utf-8"))
