"""`sideslip report`: a self-contained HTML report of a drive and its estimates, and/or static
PNG/SVG figures for papers (``--static DIR``)."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Annotated

import typer

from sideslip.cli.app import app, guarded, note, progress_bar, write_output
from sideslip.cli.evaluate import _check_same_time_base
from sideslip.errors import InputError


@app.command("report")
@guarded
def report_cmd(
    drive_path: Annotated[Path, typer.Argument(metavar="DRIVE")],
    est_path: Annotated[Path, typer.Argument(metavar="EST")],
    out: Annotated[Path | None, typer.Option("--out", help="Output HTML file.")] = None,
    static: Annotated[
        Path | None, typer.Option("--static", help="Also write PNG and SVG figures into this folder.")
    ] = None,
) -> None:
    """Write a self-contained HTML report with plots (and static figures with --static)."""
    from sideslip.drive import load_drive
    from sideslip.estimate import load_estimates, params_path
    from sideslip.outputs import check_outputs

    if out is None and static is None:
        raise InputError("--out", "expected --out report.html and/or --static DIR")
    if out is not None and out.suffix.lower() not in (".html", ".htm"):
        raise InputError(str(out), "expected an output path ending in .html")
    if static is not None and static.exists() and not static.is_dir():
        raise InputError(str(static), "expected a folder for the static figures")
    check_outputs([out], [drive_path, est_path], folders=[static])
    drive = load_drive(drive_path)
    est = load_estimates(est_path)
    _check_same_time_base(drive, est, est_path)
    params = None
    pj = params_path(est_path)
    if pj.is_file():
        try:
            params = json.loads(pj.read_text())
        except (OSError, json.JSONDecodeError) as exc:
            raise InputError(str(pj), f"expected the estimate's parameter JSON ({exc})") from None
    inputs = [drive_path, est_path] + ([pj] if params is not None else [])
    command = " ".join(["sideslip", *sys.argv[1:]])
    if out is not None:
        from sideslip.report.html import render_report

        with progress_bar("report", None) as advance:
            text = render_report(
                drive, est, params, command=command, inputs=inputs,
                progress=lambda step: advance(0, f"report: {step}"),
            )  # fmt: skip
        note(f"wrote {write_output(out, text)} ({len(text.encode()) / 1e6:.1f} MB)")
    if static is not None:
        from sideslip.report.static import write_static

        with progress_bar("figures", None) as advance:
            written = write_static(drive, est, static, progress=lambda step: advance(0, f"figures: {step}"))
        note(f"wrote {len(written)} figures to {static}: " + ", ".join(p.name for p in written))
