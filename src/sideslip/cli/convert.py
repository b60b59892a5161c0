"""`sideslip convert`: outside recordings (datasets, MDF4, CSV, ROS bags) into drives."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from sideslip.cli.app import app, guarded, note, say, write_output
from sideslip.errors import InputError


@app.command("convert")
@guarded
def convert_cmd(
    fmt: Annotated[str | None, typer.Argument(metavar="FORMAT", help="Input format (see --help).")] = None,
    src: Annotated[
        Path | None, typer.Argument(metavar="SRC", help="Recording: dataset folder or file.")
    ] = None,
    out: Annotated[Path | None, typer.Option("--out", help="Output drive, .parquet or .csv.")] = None,
    map_path: Annotated[
        Path | None, typer.Option("--map", help="Channel map TOML (csv, mdf4, rosbag).")
    ] = None,
    vehicle: Annotated[str | None, typer.Option("--vehicle", help="Vehicle preset or TOML.")] = None,
    template: Annotated[
        str | None,
        typer.Option("--template", metavar="FORMAT", help="Print a commented map for csv, mdf4 or rosbag."),
    ] = None,
) -> None:
    """Turn an outside recording into a drive.  Formats: comma2k19, csv, mdf4, revs, rosbag.

    Start a map with `sideslip convert --template csv > map.toml` (or mdf4, rosbag).
    """
    from sideslip.io import FORMATS, convert
    from sideslip.io import template as map_template

    if template is not None:
        write_output("-", map_template(template))
        return
    if fmt is None or src is None or out is None:
        raise InputError("convert", "expected FORMAT SRC --out DRIVE (or --template FORMAT)")
    from sideslip.drive import save_drive
    from sideslip.outputs import check_outputs, table_outputs
    from sideslip.vehicle import load_vehicle

    if fmt not in FORMATS:
        raise InputError(fmt, f"unknown format: expected one of {', '.join(FORMATS)}")
    check_outputs(table_outputs(out), [src, map_path, vehicle])
    veh = load_vehicle(vehicle) if vehicle else None
    drive = convert(fmt, src, veh, map_path)
    for line in drive.meta.get("warnings", []):
        say(f"warning: {line}")
    save_drive(drive, out)
    note(f"wrote {out}: {len(drive)} rows, {drive.t[-1] - drive.t[0]:.1f} s")
