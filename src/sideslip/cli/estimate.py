"""`sideslip estimate`: run methods on a drive and write their estimates."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Annotated, Any

import typer

from sideslip.cli.app import app, console, guarded, say
from sideslip.errors import InputError


def settings_from_cli(config: Path | None, assignments: list[str] | None) -> dict[str, Any]:
    """Method -> settings object from ``--config FILE`` then ``--set M.FIELD=VALUE`` (which wins).

    Checked before any method runs: an unknown method, field or out-of-range value is one line.
    """
    from sideslip.methods.registry import resolve_settings
    from sideslip.settings import load_settings_file, parse_assignment

    merged: dict[str, dict[str, Any]] = {}
    if config is not None:
        for name, table in load_settings_file(config).items():
            merged.setdefault(name, {}).update(table)
        resolve_settings(merged, str(config))  # name the file in its own errors
    for text in assignments or []:
        name, field, value = parse_assignment(text)
        merged.setdefault(name, {})[field] = value
    return resolve_settings(merged, "--set" if assignments else str(config))


def run_methods(
    drive: Any,
    vehicle: Any,
    names: list[str] | None,
    quiet: bool = False,
    settings: dict[str, Any] | None = None,
) -> list[Any]:
    """Run the named methods (or all the drive allows), reporting skipped ones; returns estimates.

    ``settings``: method name -> settings object (see :func:`settings_from_cli`).
    """
    from sideslip.methods.registry import all_methods, run_method, why_not

    settings = settings or {}

    registry = all_methods()
    if names:
        unknown = [n for n in names if n not in registry]
        if unknown:
            raise InputError(
                "--method", f"unknown method '{unknown[0]}': expected one of {', '.join(registry)}"
            )
        chosen = [registry[n] for n in names]
    else:
        chosen = list(registry.values())
    estimates = []
    for m in chosen:
        reason = why_not(m, drive, vehicle)
        if reason is not None:
            if names:
                run_method(m, drive, vehicle)  # raises the precise one-line error
            if not quiet:
                say(f"skipped {m.name}: {reason}")
            continue
        start = time.perf_counter()
        est = run_method(m, drive, vehicle, settings.get(m.name))
        if not quiet:
            say(f"ran {m.name} ({time.perf_counter() - start:.2f} s)")
        estimates.append(est)
    if not estimates:
        raise InputError(drive.path, "no method can run on this drive (see the skipped reasons above)")
    return estimates


@app.command("estimate")
@guarded
def estimate_cmd(
    drive_path: Annotated[Path, typer.Argument(metavar="DRIVE", help="Drive table, .parquet or .csv.")],
    vehicle: Annotated[str, typer.Option("--vehicle", help="Vehicle preset name or TOML path.")],
    out: Annotated[Path, typer.Option("--out", help="Estimate table, .parquet or .csv.")],
    method: Annotated[
        list[str] | None, typer.Option("--method", help="Method to run (repeatable; default all possible).")
    ] = None,
    set_: Annotated[
        list[str] | None,
        typer.Option("--set", help="A method setting, METHOD.FIELD=VALUE (repeatable; wins over --config)."),
    ] = None,
    config: Annotated[
        Path | None, typer.Option("--config", help="Settings TOML: one [method] table of FIELD = VALUE.")
    ] = None,
) -> None:
    """Run estimation methods on a drive and write their estimates (+ .params.json)."""
    from sideslip.drive import load_drive, meta_path
    from sideslip.estimate import save_estimates
    from sideslip.outputs import check_outputs, estimate_outputs, output_group
    from sideslip.vehicle import load_vehicle

    if out.suffix.lower() not in (".csv", ".parquet", ".pq"):
        raise InputError(str(out), "expected an output path ending in .csv or .parquet")
    check_outputs(estimate_outputs(out), [drive_path, meta_path(drive_path), vehicle, config])
    chosen_settings = settings_from_cli(config, set_)
    veh = load_vehicle(vehicle)
    drive = load_drive(drive_path)
    estimates = run_methods(drive, veh, method, settings=chosen_settings)
    with output_group():  # the table and its .params.json appear together, or neither
        params = save_estimates(drive.t, estimates, out, {"drive": str(drive_path), "vehicle": vehicle})
    console.print(f"wrote {out} ({len(estimates)} methods) and {params}")
