"""`sideslip evaluate`: estimates against the drive's reference columns."""

from __future__ import annotations

import enum
import io
import json
import math
from pathlib import Path
from typing import Annotated, Any

import numpy as np
import typer
from rich import box
from rich.table import Table

from sideslip.cli.app import app, console, guarded, note, write_output
from sideslip.errors import InputError


def _parse_windows(values: list[str] | None) -> list[Any]:
    from sideslip.windows import parse_window

    return [parse_window(v) for v in values or []]


def _check_has_estimates(est: dict[str, Any], est_path: Path) -> None:
    """An estimate table holds METHOD.series columns; a drive given twice holds none."""
    if not any(name for name in est):
        raise InputError(str(est_path), "holds no estimates: expected the columns METHOD.beta ... "
                         "that `sideslip estimate` writes (a drive given twice?)")


def _check_same_time_base(drive: Any, est: dict[str, Any], est_path: Path) -> None:
    _check_has_estimates(est, est_path)
    t_est = est[""]["t"]
    if t_est.size != len(drive) or not np.allclose(t_est, drive.t, rtol=0, atol=1e-6):
        raise InputError(
            str(est_path),
            "expected the drive's time stamps (estimate made from another drive?)",
            column="t",
        )


# metric, short header (the table must fit 80 columns), legend text
TERMINAL_METRICS = (
    ("beta_rmse_deg", "β rms", "β rms/β max: sideslip RMS/max error, °"),
    ("beta_max_err_deg", "β max", ""),
    ("roll_rmse_deg", "roll", "roll, yaw: RMS error, °"),
    ("yaw_rmse_deg", "yaw", ""),
    ("pos_rmse_m", "pos", "pos: position RMS error, m"),
    ("xtrack_100m_p95_m", "xt95", "xt95: 95th percentile cross-track error after 100 m, m"),
)
NAME_WIDTH = 21  # the longest method name (kinematic_integration)


def _cell(value: float) -> str:
    if not math.isfinite(value):
        return "-"
    return f"{value:.3f}" if abs(value) < 100 else f"{value:.1f}"


def metrics_table(results: dict[str, dict[str, float]], title: str) -> Table:
    """A compact table of the headline metrics, methods sorted by beta RMSE; fits 80 columns.

    Every metric (the contract's and the extra ones) goes to the JSON/CSV and the report; the
    terminal shows six, under short headers explained by the caption (the legend line).
    """
    cols = [(k, label, leg) for k, label, leg in TERMINAL_METRICS if any(k in r for r in results.values())]
    legend = "; ".join(leg for k, _, leg in cols if leg) + ". Best in green."
    table = Table(
        title=title, caption=legend, box=box.SIMPLE_HEAD, pad_edge=False, padding=(0, 1),
        caption_justify="left", title_justify="left",
    )  # fmt: skip
    table.add_column("method", no_wrap=True, min_width=6, max_width=NAME_WIDTH)
    for _, label, _ in cols:
        table.add_column(label, justify="right", no_wrap=True)
    order = sorted(results, key=lambda m: results[m].get("beta_rmse_deg", float("inf")))
    best = {k: min((abs(r[k]) for r in results.values() if k in r), default=None) for k, _, _ in cols}
    for method in order:
        vals = results[method]
        cells = []
        for k, _, _ in cols:
            if k not in vals:
                cells.append("-")
            elif best[k] is not None and abs(vals[k]) == best[k] and len(results) > 1:
                cells.append(f"[bold green]{_cell(vals[k])}[/]")
            else:
                cells.append(_cell(vals[k]))
        table.add_row(method, *cells)
    return table


def metrics_csv(results: dict[str, dict[str, float]]) -> str:
    """One row per method, one column per metric (every metric any method has)."""
    from sideslip.evaluate import METRIC_NAMES

    names = [k for k in METRIC_NAMES if any(k in r for r in results.values())]
    names += sorted({k for r in results.values() for k in r} - set(names))
    buf = io.StringIO()
    buf.write(",".join(["method", *names]) + "\n")
    for method, vals in results.items():
        row = [method] + [f"{vals[k]:.6g}" if k in vals else "" for k in names]
        buf.write(",".join(row) + "\n")
    return buf.getvalue()


class Format(enum.StrEnum):
    table = "table"
    json = "json"
    csv = "csv"


@app.command("evaluate")
@guarded
def evaluate_cmd(
    drive_path: Annotated[Path, typer.Argument(metavar="DRIVE", help="Drive with reference columns.")],
    est_path: Annotated[Path, typer.Argument(metavar="EST", help="Estimate table from `sideslip estimate`.")],
    json_out: Annotated[
        str | None, typer.Option("--json", help="Write method -> metric -> value JSON ('-': stdout).")
    ] = None,
    fmt: Annotated[
        Format, typer.Option("--format", help="What to print on stdout: table, json or csv.")
    ] = Format.table,
    window: Annotated[
        list[str] | None,
        typer.Option(
            "--window",
            help="T0:T1 (s, the drive's time stamps): every metric on these rows only; repeatable.",
        ),
    ] = None,
) -> None:
    """Compare estimates to the drive's reference columns; print a metrics table."""
    from sideslip.drive import load_drive
    from sideslip.estimate import load_estimates
    from sideslip.outputs import check_outputs
    from sideslip.windows import check_windows, evaluate_windows

    windows = _parse_windows(window)
    check_outputs([json_out], [drive_path, est_path])
    drive = load_drive(drive_path)
    check_windows(drive, windows)
    est = load_estimates(est_path)
    _check_same_time_base(drive, est, est_path)
    if not any(c.startswith("ref_") for c in drive.columns()):
        raise InputError(
            str(drive_path), "expected reference columns (ref_beta, ref_e, ...) to evaluate against"
        )
    results = evaluate_windows(drive, est, windows)
    text = json.dumps(results, indent=2)
    if json_out is not None and json_out != "-":
        where = write_output(json_out, text + "\n")
    if fmt is Format.json or json_out == "-":
        write_output("-", text + "\n")
    if fmt is Format.csv:
        write_output("-", metrics_csv(results))
    elif fmt is Format.table and json_out != "-":
        span = ", ".join(f"{w.t0:g}-{w.t1:g} s" for w in windows)
        title = f"metrics: {est_path.name} vs {drive_path.name}" + (f" ({span})" if span else "")
        console.print(metrics_table(results, title))
    if json_out is not None and json_out != "-":
        note(f"wrote {where}")
