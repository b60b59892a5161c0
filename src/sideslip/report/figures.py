"""The report's plotly figures.  Time is from the drive's start (s); GNSS outages are shaded on
every time plot; each figure draws the reference and the best methods (see
:class:`~sideslip.report.series.Ranking`) and keeps the others one legend click away."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import plotly.graph_objects as go

from sideslip.drive import Drive
from sideslip.evaluate import SPEED_GATE, forward_speed
from sideslip.frames import wrap_angle
from sideslip.report.series import (
    BAND_POINTS,
    Ranking,
    Series,
    decimate,
    gated_errors_deg,
    histogram,
    is_sparse,
    stride_indices,
    time_axis,
)

PALETTE = (
    "#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f",
    "#bcbd22", "#17becf", "#393b79", "#637939", "#8c6d31", "#843c39", "#7b4173", "#3182bd",
    "#e6550d", "#31a354", "#756bb1", "#636363",
)  # fmt: skip
OUTAGE_FILL = "rgba(214, 39, 40, 0.12)"
DEG = math.degrees(1.0)


def colour(i: int) -> str:
    return PALETTE[i % len(PALETTE)]


def _rgba(hex_colour: str, alpha: float) -> str:
    r, g, b = (int(hex_colour[i : i + 2], 16) for i in (1, 3, 5))
    return f"rgba({r},{g},{b},{alpha})"


def _f32(values: np.ndarray) -> np.ndarray:
    """Plotted values as float32 (half the bytes; far finer than a plot's pixels)."""
    return np.asarray(values, dtype=np.float32)


def figure(title: str, ytitle: str, xtitle: str = "time from start (s)", height: int = 400) -> go.Figure:
    fig = go.Figure()
    fig.update_layout(
        title={"text": title, "x": 0.01, "xanchor": "left"},
        template="plotly_white",
        height=height,
        margin={"l": 55, "r": 10, "t": 45, "b": 40},
        legend={"orientation": "h", "y": -0.18, "x": 0, "font": {"size": 11}},
        hovermode="closest",
        xaxis={"title": {"text": xtitle}, "exponentformat": "none", "separatethousands": False},
        yaxis={"title": {"text": ytitle}, "exponentformat": "none"},
    )
    return fig


def shade_outages(fig: go.Figure, outages: Sequence[tuple[float, float]]) -> None:
    """GNSS outages as red bands over the plot's height (one legend entry for all)."""
    for k, (a, b) in enumerate(outages):
        fig.add_shape(
            type="rect", x0=a, x1=b, y0=0, y1=1, xref="x", yref="paper", fillcolor=OUTAGE_FILL,
            line={"width": 0}, layer="below", name="GNSS outage", legendgroup="outage",
            showlegend=k == 0,
        )  # fmt: skip


def robust_range(values: list[np.ndarray], pad: float) -> list[float] | None:
    """A y-range holding the bulk of the shown curves, so that one drifting method does not
    flatten the others (double-click to see all)."""
    finite = [v[np.isfinite(v)] for v in values]
    finite = [v for v in finite if v.size]
    if not finite:
        return None
    lo = float(np.median([np.percentile(v, 0.5) for v in finite]))
    hi = float(np.median([np.percentile(v, 99.5) for v in finite]))
    span = max(hi - lo, pad)
    return [lo - 0.2 * span, hi + 0.2 * span]


def _reference(fig: go.Figure, t: np.ndarray, y: np.ndarray) -> np.ndarray:
    """The reference: a line, or markers when it has samples on few rows (e.g. 20 Hz truth)."""
    if is_sparse(y):
        rows = np.flatnonzero(np.isfinite(y))
        rows = rows[stride_indices(rows.size)]
        fig.add_scatter(
            x=_f32(t[rows]), y=_f32(y[rows]), name="reference", mode="markers",
            marker={"color": "black", "size": 4},
        )  # fmt: skip
        return y[rows]
    td, yd = decimate(t, y)
    fig.add_scatter(x=_f32(td), y=_f32(yd), name="reference", line={"color": "black", "width": 2.5})
    return yd


def time_plot(
    drive: Drive,
    est: Series,
    ranking: Ranking,
    key: str,
    ref: str | None,
    title: str,
    outages: Sequence[tuple[float, float]],
    band: bool = True,
) -> go.Figure | None:
    """Angle ``key`` (deg) of every method against the reference, each with its own 1σ band."""
    methods = [m for m in ranking.order if key in est[m]]
    if not methods:
        return None
    fig = figure(title, "deg")
    t = time_axis(drive)
    shown: list[np.ndarray] = []
    if ref and ref in drive:
        shown.append(_reference(fig, t, drive[ref] * DEG))
    for m in methods:
        i = ranking.colour_index.get(m, 0)
        y = est[m][key] * DEG
        vis = ranking.visible(m)
        std = est[m].get(f"{key}_std")
        if band and std is not None:
            s = stride_indices(t.size, BAND_POINTS)
            ts, up, lo = t[s], (y + std * DEG)[s], (y - std * DEG)[s]
            fig.add_scatter(
                x=_f32(np.concatenate([ts, ts[::-1]])), y=_f32(np.concatenate([up, lo[::-1]])),
                fill="toself", fillcolor=_rgba(colour(i), 0.18), line={"width": 0}, name=f"{m} ±1σ",
                hoverinfo="skip", visible=vis, legendgroup=m, showlegend=False,
            )  # fmt: skip
        td, yd = decimate(t, y)
        fig.add_scatter(
            x=_f32(td), y=_f32(yd), name=m, line={"color": colour(i), "width": 1.5},
            visible=vis, legendgroup=m,
        )  # fmt: skip
        if vis is True:
            shown.append(yd)
    shade_outages(fig, outages)
    rng = robust_range(shown, 0.5)
    if rng:
        fig.update_yaxes(range=rng)
    return fig


def error_plot(
    drive: Drive, est: Series, ranking: Ranking, key: str, ref: str, title: str,
    outages: Sequence[tuple[float, float]],
) -> go.Figure | None:  # fmt: skip
    """Error (deg) over time above the speed gate, each method with its own 1σ band."""
    methods = [m for m in ranking.order if key in est[m]]
    if not methods or ref not in drive:
        return None
    fig = figure(title, "error (deg)")
    t = time_axis(drive)
    gate = forward_speed(drive) > SPEED_GATE
    sparse_ref = is_sparse(drive[ref])
    shown = []
    for m in methods:
        i = ranking.colour_index.get(m, 0)
        err = np.where(gate, np.degrees(wrap_angle(est[m][key] - drive[ref])), np.nan)
        vis = ranking.visible(m)
        std = est[m].get(f"{key}_std")
        if std is not None:
            s = stride_indices(t.size, BAND_POINTS)
            ts, band = t[s], (std * DEG)[s]
            fig.add_scatter(
                x=_f32(np.concatenate([ts, ts[::-1]])), y=_f32(np.concatenate([band, -band[::-1]])),
                fill="toself", fillcolor=_rgba(colour(i), 0.15), line={"width": 0}, name=f"{m} ±1σ",
                hoverinfo="skip", visible=vis, legendgroup=m, showlegend=False,
            )  # fmt: skip
        if sparse_ref:  # errors exist only where the reference has a sample: markers
            rows = np.flatnonzero(np.isfinite(err))
            rows = rows[stride_indices(rows.size)]
            td, ed = t[rows], err[rows]
            style: dict[str, object] = {"mode": "markers", "marker": {"color": colour(i), "size": 3}}
        else:
            td, ed = decimate(t, err)
            style = {"line": {"color": colour(i), "width": 1.2}}
        fig.add_scatter(x=_f32(td), y=_f32(ed), name=m, visible=vis, legendgroup=m, **style)
        if vis is True:
            shown.append(ed)
    shade_outages(fig, outages)
    rng = robust_range(shown, 0.2)
    if rng:
        fig.update_yaxes(range=rng)
    return fig


def error_histogram(
    drive: Drive, est: Series, ranking: Ranking, key: str, ref: str, title: str
) -> go.Figure | None:
    """Distribution of each method's error (deg, share per bin) on the metrics' rows."""
    methods = [m for m in ranking.order if key in est[m]]
    if not methods or ref not in drive:
        return None
    errors = {m: gated_errors_deg(drive, est[m][key], ref) for m in methods}
    errors = {m: e for m, e in errors.items() if e.size}
    if not errors:
        return None
    edges = histogram([errors[m] for m in errors if m in ranking.shown] or list(errors.values()))
    centres = 0.5 * (edges[1:] + edges[:-1])
    fig = figure(title, "share of samples", xtitle="error (deg)", height=360)
    for m in methods:
        i = ranking.colour_index.get(m, 0)
        if m not in errors:
            continue
        counts, _ = np.histogram(np.clip(errors[m], edges[0], edges[-1]), bins=edges)
        share = counts / max(1, errors[m].size)
        fig.add_scatter(
            x=_f32(centres), y=_f32(share), name=m, line={"color": colour(i), "width": 1.6, "shape": "hvh"},
            visible=ranking.visible(m), legendgroup=m,
        )  # fmt: skip
    fig.add_vline(x=0.0, line={"color": "#444", "width": 1, "dash": "dot"})
    return fig


def _outage_rows(t: np.ndarray, outages: Sequence[tuple[float, float]]) -> np.ndarray:
    inside = np.zeros(t.size, dtype=bool)
    for a, b in outages:
        inside |= (t >= a) & (t <= b)
    return inside


def map_plot(
    drive: Drive, est: Series, ranking: Ranking, outages: Sequence[tuple[float, float]]
) -> go.Figure | None:
    """The trajectory on an equal-aspect East/North plot, like a map; outage stretches in red."""
    methods = [m for m in ranking.order if "e" in est[m] and "n" in est[m]]
    has_ref = "ref_e" in drive and "ref_n" in drive
    has_gnss = "gnss_e" in drive and "gnss_n" in drive
    if not (methods or has_ref or has_gnss):
        return None
    fig = figure("Trajectory (local East/North, m)", "north (m)", "east (m)", height=560)
    fig.update_yaxes(scaleanchor="x", scaleratio=1)
    fig.update_layout(plot_bgcolor="#f4f1ea", xaxis={"gridcolor": "#fff"}, yaxis={"gridcolor": "#fff"})
    t = time_axis(drive)
    s = stride_indices(t.size)
    if has_ref:
        fig.add_scatter(
            x=_f32(drive["ref_e"][s]), y=_f32(drive["ref_n"][s]), name="reference",
            line={"color": "black", "width": 3},
        )  # fmt: skip
    if has_gnss:
        ok = np.flatnonzero(np.isfinite(drive["gnss_e"]) & np.isfinite(drive["gnss_n"]))
        ok = ok[stride_indices(ok.size)]
        fig.add_scatter(
            x=_f32(drive["gnss_e"][ok]), y=_f32(drive["gnss_n"][ok]), mode="markers", name="GNSS fixes",
            marker={"size": 3, "color": "#888"},
        )  # fmt: skip
    for m in methods:
        i = ranking.colour_index.get(m, 0)
        fig.add_scatter(
            x=_f32(est[m]["e"][s]), y=_f32(est[m]["n"][s]), name=m,
            line={"color": colour(i), "width": 1.5}, visible=ranking.visible(m),
        )  # fmt: skip
    path = ("ref_e", "ref_n") if has_ref else None
    if path is None and methods:
        e, n = est[methods[0]]["e"], est[methods[0]]["n"]
    elif path is not None:
        e, n = drive[path[0]], drive[path[1]]
    if outages and (path is not None or methods):
        inside = _outage_rows(t, outages)
        e_out = np.where(inside, e, np.nan)[s]
        n_out = np.where(inside, n, np.nan)[s]
        fig.add_scatter(
            x=_f32(e_out), y=_f32(n_out), name="GNSS outage", connectgaps=False,
            line={"color": "rgba(214,39,40,0.6)", "width": 8}, legendgroup="outage",
        )  # fmt: skip
    if has_ref or methods:
        fig.add_scatter(
            x=_f32(e[:1]), y=_f32(n[:1]), mode="markers+text", text=["start"], textposition="top center",
            marker={"symbol": "circle-open", "size": 12, "color": "black"}, name="start", showlegend=False,
        )  # fmt: skip
    return fig


def speed_plot(drive: Drive, outages: Sequence[tuple[float, float]]) -> go.Figure:
    """Measured speed with the GNSS outages shaded."""
    from sideslip.signals import vehicle_speed

    fig = figure("Speed and GNSS availability", "m/s", height=320)
    t = time_axis(drive)
    v = vehicle_speed(drive)
    td, vd = decimate(t, v)
    fig.add_scatter(x=_f32(td), y=_f32(vd), name="measured speed", line={"color": "#1f77b4"})
    fig.add_hline(y=SPEED_GATE, line={"color": "#999", "dash": "dot", "width": 1})
    shade_outages(fig, outages)
    return fig
