"""`sideslip vehicle`: start a vehicle file from a preset, list the presets."""

from __future__ import annotations

import re
from datetime import UTC, datetime
from pathlib import Path
from typing import Annotated

import typer
from rich import box
from rich.table import Table

from sideslip.cli.app import app, console, guarded, note, write_output
from sideslip.errors import InputError

vehicle_app = typer.Typer(
    help="Vehicle files: start one from a preset, list the presets.",
    no_args_is_help=True,
    context_settings={"help_option_names": ["-h", "--help"]},
)
app.add_typer(vehicle_app, name="vehicle")

MEANING = {
    "mass": "total mass",
    "yaw_inertia": "yaw moment of inertia about the CG",
    "lf": "CG to front axle",
    "lr": "CG to rear axle",
    "cf": "front cornering stiffness, per axle (2 x per tyre)",
    "cr": "rear cornering stiffness, per axle",
    "track_front": "front track width",
    "track_rear": "rear track width",
    "cg_height": "CG height above ground",
    "roll_axis_height": "roll axis height above ground at the CG",
    "roll_stiffness": "total roll stiffness (springs + anti-roll bars)",
    "roll_damping": "total roll damping",
    "roll_inertia": "roll moment of inertia about the roll axis",
    "steering_ratio": "steering-wheel angle / road-wheel angle",
    "understeer_gradient": "optional; derived from the tyres when absent",
}


def vehicle_file_text(preset: str, name: str) -> str:
    """A preset's own commented TOML under a header that says what each key means."""
    from importlib import resources

    from sideslip import __version__
    from sideslip.vehicle import OPTIONAL_PARAMETERS, PARAMETERS, preset_names

    if preset not in preset_names():
        known = ", ".join(preset_names())
        raise InputError("--preset", f"unknown preset '{preset}': expected one of {known}")
    body = (resources.files("sideslip") / "presets" / f"{preset}.toml").read_text(encoding="utf-8")
    body = re.sub(r'(?m)^name\s*=\s*".*"$', f'name = "{name}"', body, count=1)
    keys = {**PARAMETERS, **OPTIONAL_PARAMETERS}
    lines = [
        f"# Vehicle file '{name}', started from the sideslip preset '{preset}'",
        f"# (sideslip {__version__}, {datetime.now(UTC):%Y-%m-%d}).",
        "# Replace the preset's values with your car's.  SI units; one table [vehicle] (contract",
        "# section 2); [sensors] lever arms in m from the CG, vehicle axes (x fwd, y left, z up).",
        "# A key a method needs and this file lacks is named in a one-line error; keys sideslip",
        "# does not know (e.g. wheel_radius, a [notes] table) are yours and are ignored.",
        "#",
    ]
    width = max(len(k) for k in keys)
    for key, (unit, _, _) in keys.items():
        lines.append(f"#   {key:<{width}}  {unit:<12} {MEANING.get(key, '')}".rstrip())
    lines += ["#", "# The preset as shipped (its comments say where its values come from):", "", ""]
    return "\n".join(lines[:-1]) + "\n" + body


@vehicle_app.command("new")
@guarded
def vehicle_new(
    preset: Annotated[str, typer.Option("--preset", help="Preset to start from (see `vehicle presets`).")],
    out: Annotated[str, typer.Option("--out", help="Vehicle TOML to write ('-': stdout).")],
    name: Annotated[
        str | None, typer.Option("--name", help="The vehicle's name (default: the file name).")
    ] = None,
    force: Annotated[bool, typer.Option("--force", help="Replace an existing file.")] = False,
) -> None:
    """Write a commented vehicle file to edit, starting from a preset."""
    from sideslip.vehicle import load_vehicle

    if out != "-" and not out.endswith(".toml") and not out.startswith("/dev/"):
        raise InputError(out, "expected an output path ending in .toml")
    if out != "-" and Path(out).is_file() and not force:
        raise InputError(out, "exists already: expected a new file name (or --force to replace it)")
    text = vehicle_file_text(preset, name or (Path(out).stem if out != "-" else preset))
    where = write_output(out, text)
    if out != "-" and Path(out).is_file():
        load_vehicle(out)  # the file we wrote loads (it is the preset's own content)
        note(f"wrote {where}: edit the values for your car, then --vehicle {out}")


@vehicle_app.command("presets")
@guarded
def vehicle_presets() -> None:
    """List the vehicle presets shipped with sideslip."""
    from sideslip.vehicle import load_vehicle, preset_names

    table = Table(title="vehicle presets", box=box.SIMPLE_HEAD, pad_edge=False, title_justify="left")
    for col in ("preset", "mass kg", "wheelbase m", "cf kN/rad", "steering ratio"):
        table.add_column(col, justify="left" if col == "preset" else "right", no_wrap=True)
    for p in preset_names():
        v = load_vehicle(p)
        cells = (f"{v.mass:.0f}", f"{v.wheelbase:.2f}", f"{v.cf / 1e3:.0f}", f"{v.steering_ratio:.1f}")
        table.add_row(p, *cells)
    console.print(table)
