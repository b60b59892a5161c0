"""`sideslip evaluate`: estimates against the drive's reference columns."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Any

import numpy as np
import typer
from rich.table import Table

from sideslip.cli.app import app, console, err_console, guarded
from sideslip.errors import InputError


def _parse_windows(values: list[str] | None) -> list[Any]:
    from sideslip.evaluate import Window

    out = []
    for v in values or []:
        try:
            a, b = (float(x) for x in v.split(":"))
        except ValueError:
            raise InputError("--window", f"'{v}': expected T0:T1 in seconds, e.g. 120:150") from None
        if not b > a:
            raise InputError("--window", f"'{v}': expected T1 > T0")
        out.append(Window(a, b))
    return out


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


TERMINAL_METRICS = (
    ("beta_rmse_deg", "β RMSE °"),
    ("beta_max_err_deg", "β max °"),
    ("roll_rmse_deg", "roll RMSE °"),
    ("yaw_rmse_deg", "yaw RMSE °"),
    ("pos_rmse_m", "pos RMSE m"),
    ("xtrack_100m_p95_m", "xtrack p95 m"),
)


def metrics_table(results: dict[str, dict[str, float]], title: str) -> Table:
    """A compact rich table of the headline metrics, methods sorted by beta RMSE.

    Every metric (the contract's and the extra ones) goes to the JSON and the report; the
    terminal shows the six that fit a normal terminal width.
    """
    cols = [(k, label) for k, label in TERMINAL_METRICS if any(k in r for r in results.values())]
    table = Table(title=title)
    table.add_column("method", no_wrap=True)
    for _, label in cols:
        table.add_column(label, justify="right", no_wrap=True)
    order = sorted(results, key=lambda m: results[m].get("beta_rmse_deg", float("inf")))
    best = {k: min((abs(r[k]) for r in results.values() if k in r), default=None) for k, _ in cols}
    for method in order:
        vals = results[method]
        cells = []
        for k, _ in cols:
            if k not in vals:
                cells.append("-")
            elif best[k] is not None and abs(vals[k]) == best[k] and len(results) > 1:
                cells.append(f"[bold green]{vals[k]:.3f}[/]")
            else:
                cells.append(f"{vals[k]:.3f}")
        table.add_row(method, *cells)
    return table


@app.command("evaluate")
@guarded
def evaluate_cmd(
    drive_path: Annotated[Path, typer.Argument(metavar="DRIVE", help="Drive with reference columns.")],
    est_path: Annotated[Path, typer.Argument(metavar="EST", help="Estimate table from `sideslip estimate`.")],
    json_out: Annotated[
        Path | None, typer.Option("--json", help="Write method -> metric -> value JSON ('-': stdout).")
    ] = None,
    window: Annotated[
        list[str] | None,
        typer.Option("--window", help="T0:T1 window (s) for per-window position errors, repeatable."),
    ] = None,
) -> None:
    """Compare estimates to the drive's reference columns; print a metrics table."""
    from sideslip.drive import _atomic_write, load_drive
    from sideslip.estimate import load_estimates
    from sideslip.evaluate import evaluate_all
    from sideslip.outputs import check_outputs

    windows = _parse_windows(window)
    check_outputs([json_out], [drive_path, est_path])
    drive = load_drive(drive_path)
    est = load_estimates(est_path)
    _check_has_estimates(est, est_path)
    t_est = est[""]["t"]
    if t_est.size != len(drive) or not np.allclose(t_est, drive.t, rtol=0, atol=1e-6):
        raise InputError(
            str(est_path),
            "expected the drive's time stamps (estimate made from another drive?)",
            column="t",
        )
    if not any(c.startswith("ref_") for c in drive.columns()):
        raise InputError(
            str(drive_path), "expected reference columns (ref_beta, ref_e, ...) to evaluate against"
        )
    results = evaluate_all(drive, est, windows)
    shown = err_console if str(json_out) == "-" else console  # `--json -`: JSON alone on stdout
    shown.print(metrics_table(results, f"metrics: {est_path.name} vs {drive_path.name}"))
    if json_out is not None:
        _atomic_write(json_out, lambda tmp: tmp.write_text(json.dumps(results, indent=2)))
        if str(json_out) != "-":
            console.print(f"wrote {json_out}")
