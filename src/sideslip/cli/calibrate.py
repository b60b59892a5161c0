"""`sideslip calibrate`: fit a vehicle file (and the sensor calibration) to one drive."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Annotated, Any

import typer

from sideslip.cli.app import app, console, guarded, say
from sideslip.errors import InputError

# parameter -> (label, unit shown, factor from SI)
_SHOWN: dict[str, tuple[str, str, float]] = {
    "cf": ("cf", "kN/rad", 1e-3),
    "cr": ("cr", "kN/rad", 1e-3),
    "steering_ratio": ("steering ratio", "-", 1.0),
    "steer_scale": ("steer scale", "-", 1.0),
    "steer_offset_rad": ("steer offset", "deg", 180.0 / math.pi),
    "understeer_gradient": ("understeer grad.", "deg/g", 180.0 / math.pi * 9.80665),
    "slip_gain_k_s2_m": ("slip gain K", "ms^2/m", 1e3),
    "roll_gradient_rad_per_m_s2": ("roll gradient", "deg/g", 180.0 / math.pi * 9.80665),
    "roll_stiffness": ("roll stiffness", "kNm/rad", 1e-3),
    "wheel_speed_scale": ("wheel-speed scale", "-", 1.0),
    "gyro_bias_rad_s": ("gyro bias", "deg/s", 180.0 / math.pi),
    "gyro_scale": ("gyro scale", "-", 1.0),
    "imu_yaw_misalignment_rad": ("IMU yaw mount", "deg", 180.0 / math.pi),
    "imu_roll_misalignment_rad": ("IMU roll mount", "deg", 180.0 / math.pi),
}


def _num(x: float, factor: float) -> str:
    return f"{x * factor:.4g}" if math.isfinite(x) else "-"


def calibration_table(cal: Any) -> Any:
    """A rich table of the fits (80 columns): parameter, was, fitted, 1-sigma, rows."""
    from rich.table import Table

    table = Table(title="calibration (1-sigma; 'left' = not told by the drive)", title_justify="left")
    table.add_column("parameter", no_wrap=True)
    table.add_column("unit", no_wrap=True)
    table.add_column("was", justify="right", no_wrap=True)
    table.add_column("fitted", justify="right", no_wrap=True)
    table.add_column("1-sigma", justify="right", no_wrap=True)
    table.add_column("rows", justify="right", no_wrap=True)
    for f in cal.fitted:
        label, unit, factor = _SHOWN.get(f.name, (f.name, f.unit, 1.0))
        if f.informed:
            table.add_row(
                label, unit, _num(f.before, factor), _num(f.value, factor), _num(f.sigma, factor), str(f.rows)
            )
        else:
            table.add_row(label, unit, _num(f.before, factor), "left", "-", "0", style="dim")
    return table


@app.command("calibrate")
@guarded
def calibrate_cmd(
    drive_path: Annotated[Path, typer.Argument(metavar="DRIVE", help="Drive table, .parquet or .csv.")],
    vehicle: Annotated[str, typer.Option("--vehicle", help="Starting (rough) vehicle: preset or TOML path.")],
    out: Annotated[Path, typer.Option("--out", help="Fitted vehicle file to write, .toml.")],
    json_out: Annotated[
        Path | None, typer.Option("--json", help="Also write every fit (value, sigma, rows, source) as JSON.")
    ] = None,
) -> None:
    """Identify the vehicle's effective tyre stiffness, steering, roll and sensor calibration
    from a drive; write a fitted vehicle file (comments give value, 1-sigma, rows, source)."""
    from sideslip.calibrate import calibrate, calibration_toml
    from sideslip.drive import load_drive
    from sideslip.vehicle import load_vehicle, save_vehicle_text

    if out.suffix.lower() != ".toml":
        raise InputError(str(out), "expected an output path ending in .toml")
    if json_out is not None and json_out.suffix.lower() != ".json":
        raise InputError(str(json_out), "expected a --json path ending in .json")
    veh = load_vehicle(vehicle)
    drive = load_drive(drive_path)
    cal = calibrate(drive, veh)
    text = calibration_toml(cal, drive_path.name, vehicle)
    save_vehicle_text(text, out)
    if json_out is not None:
        payload = {"drive": str(drive_path), "vehicle": vehicle, "fitted_vehicle": str(out), **cal.params()}
        save_vehicle_json(payload, json_out)
    console.print(calibration_table(cal))
    for note in cal.notes:
        say(f"note: {note}")
    console.print(f"wrote {out}" + (f" and {json_out}" if json_out is not None else ""))


def save_vehicle_json(payload: dict[str, Any], path: Path) -> None:
    """Write the calibration JSON atomically (temporary file, then rename)."""
    import os
    import tempfile

    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".part")
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            json.dump(payload, fh, indent=2)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
