"""`sideslip simulate`: a drive with reference columns from the truth model."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Annotated

import typer

from sideslip.cli.app import app, guarded, note, progress_bar


@app.command("simulate")
@guarded
def simulate_cmd(
    scenario: Annotated[str, typer.Argument(help="Scenario name (see `sideslip scenarios`).")],
    out: Annotated[Path, typer.Option("--out", help="Output drive, .parquet or .csv.")],
    seed: Annotated[int, typer.Option("--seed", help="Random seed.")] = 0,
    vehicle: Annotated[
        str | None, typer.Option("--vehicle", help="Vehicle preset or TOML (default: the scenario's).")
    ] = None,
) -> None:
    """Simulate a scenario and write a drive with reference columns."""
    import sideslip.simulate as sim
    from sideslip.drive import save_drive
    from sideslip.outputs import check_outputs, table_outputs
    from sideslip.vehicle import load_vehicle

    check_outputs(table_outputs(out), [vehicle])
    veh = load_vehicle(vehicle) if vehicle else None
    start = time.perf_counter()
    with progress_bar(f"simulating {scenario}", None) as advance:
        drive = sim.simulate(scenario, seed=seed, vehicle=veh)
        advance(0, f"writing {out.name}")
        save_drive(drive, out)
    note(
        f"wrote {out}: {len(drive)} rows, {drive.t[-1] - drive.t[0]:.1f} s, "
        f"scenario {scenario}, seed {seed} ({time.perf_counter() - start:.1f} s)"
    )
