"""`sideslip convert`: outside recordings (datasets, MDF4, CSV) into drives."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from sideslip.cli.app import app, console, guarded
from sideslip.errors import InputError


@app.command("convert")
@guarded
def convert_cmd(
    fmt: Annotated[str, typer.Argument(metavar="FORMAT", help="Input format (see --help).")],
    src: Annotated[Path, typer.Argument(metavar="SRC", help="Recording: dataset folder or file.")],
    out: Annotated[Path, typer.Option("--out", help="Output drive, .parquet or .csv.")],
    map_path: Annotated[Path | None, typer.Option("--map", help="Channel map TOML (mdf4, csv).")] = None,
    vehicle: Annotated[str | None, typer.Option("--vehicle", help="Vehicle preset or TOML.")] = None,
) -> None:
    """Turn an outside recording into a drive.  Formats: comma2k19, revs, mdf4, csv."""
    from sideslip.drive import save_drive
    from sideslip.io import FORMATS, convert
    from sideslip.vehicle import load_vehicle

    if fmt not in FORMATS:
        raise InputError(fmt, f"unknown format: expected one of {', '.join(FORMATS)}")
    veh = load_vehicle(vehicle) if vehicle else None
    drive = convert(fmt, src, veh, map_path)
    save_drive(drive, out)
    console.print(f"wrote {out}: {len(drive)} rows, {drive.t[-1] - drive.t[0]:.1f} s")
