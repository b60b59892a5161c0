"""`sideslip demo`: the first thing a new user runs."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Annotated

import typer

from sideslip.cli.app import app, console, guarded
from sideslip.cli.estimate import run_methods
from sideslip.cli.evaluate import metrics_table


@app.command("demo")
@guarded
def demo_cmd(
    scenario: Annotated[str, typer.Option("--scenario", help="Scenario to run.")] = "demo",
    out_dir: Annotated[Path, typer.Option("--out-dir", help="Where to write the files.")] = Path("out"),
    seed: Annotated[int, typer.Option("--seed")] = 0,
) -> None:
    """Simulate a built-in scenario, run every method, print metrics, write the report."""
    import sideslip.simulate as sim
    from sideslip.drive import _atomic_write, save_drive
    from sideslip.estimate import save_estimates
    from sideslip.evaluate import evaluate_all
    from sideslip.outputs import check_outputs
    from sideslip.vehicle import load_vehicle

    check_outputs([], folders=[out_dir])
    start = time.perf_counter()
    drive = sim.simulate(scenario, seed=seed)
    vehicle = load_vehicle(drive.meta["vehicle"])
    out_dir.mkdir(parents=True, exist_ok=True)
    drive_path = out_dir / f"{scenario}.parquet"
    save_drive(drive, drive_path)
    console.print(f"simulated {scenario} ({drive.t[-1]:.0f} s, vehicle {vehicle.name}) -> {drive_path}")
    estimates = run_methods(drive, vehicle, None)
    est_path = out_dir / f"{scenario}_estimates.parquet"
    save_estimates(drive.t, estimates, est_path, {"drive": str(drive_path), "vehicle": vehicle.name})
    series = {e.method: dict(e.series) for e in estimates}
    results = evaluate_all(drive, series)
    console.print(metrics_table(results, f"metrics on scenario '{scenario}'"))
    _atomic_write(
        out_dir / f"{scenario}_metrics.json", lambda tmp: tmp.write_text(json.dumps(results, indent=2))
    )
    from sideslip.report.html import write_report

    report = out_dir / f"{scenario}_report.html"
    write_report(drive, {"": {"t": drive.t}, **series}, report, {e.method: dict(e.params) for e in estimates})
    console.print(f"report: {report}")
    console.print(f"done in {time.perf_counter() - start:.1f} s")
