"""`sideslip report`: a self-contained HTML report of a drive and its estimates."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from sideslip.cli.app import app, console, guarded
from sideslip.cli.evaluate import _check_same_time_base
from sideslip.errors import InputError


@app.command("report")
@guarded
def report_cmd(
    drive_path: Annotated[Path, typer.Argument(metavar="DRIVE")],
    est_path: Annotated[Path, typer.Argument(metavar="EST")],
    out: Annotated[Path, typer.Option("--out", help="Output HTML file.")],
) -> None:
    """Write a self-contained HTML report with plots."""
    from sideslip.drive import load_drive
    from sideslip.estimate import load_estimates, params_path
    from sideslip.outputs import check_outputs
    from sideslip.report.html import write_report

    if out.suffix.lower() not in (".html", ".htm"):
        raise InputError(str(out), "expected an output path ending in .html")
    check_outputs([out], [drive_path, est_path])
    drive = load_drive(drive_path)
    est = load_estimates(est_path)
    _check_same_time_base(drive, est, est_path)
    params = None
    pj = params_path(est_path)
    if pj.is_file():
        params = json.loads(pj.read_text())
    write_report(drive, est, out, params)
    console.print(f"wrote {out}")
