"""`sideslip demo`: the first thing a new user runs."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Annotated

import typer

from sideslip.cli.app import app, console, guarded, note, progress_bar, write_output
from sideslip.cli.estimate import run_estimates
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
    from sideslip.drive import save_drive
    from sideslip.evaluate import evaluate_all
    from sideslip.outputs import check_outputs
    from sideslip.report.html import write_report
    from sideslip.vehicle import load_vehicle

    check_outputs([], folders=[out_dir])
    start = time.perf_counter()
    with progress_bar(f"simulating {scenario}", None):
        drive = sim.simulate(scenario, seed=seed)
    vehicle = load_vehicle(drive.meta["vehicle"])
    out_dir.mkdir(parents=True, exist_ok=True)
    drive_path = out_dir / f"{scenario}.parquet"
    save_drive(drive, drive_path)
    note(f"simulated {scenario} ({drive.t[-1]:.0f} s, vehicle {vehicle.name}) -> {drive_path}")
    result = run_estimates(drive, vehicle, None)
    est_path = out_dir / f"{scenario}_estimates.parquet"
    params_file = result.save(est_path, {"drive": str(drive_path), "vehicle": vehicle.name})
    series = result.series()
    results = evaluate_all(drive, series)
    console.print(metrics_table(results, f"metrics on scenario '{scenario}'"))
    write_output(out_dir / f"{scenario}_metrics.json", json.dumps(results, indent=2) + "\n")
    report = out_dir / f"{scenario}_report.html"
    with progress_bar("report", None) as advance:
        write_report(
            drive, series, report, {**result.params, "_skipped": dict(result.skipped)},
            inputs=[drive_path, est_path, params_file],
            progress=lambda step: advance(0, f"report: {step}"),
        )  # fmt: skip
    note(f"report: {report}")
    note(f"done in {time.perf_counter() - start:.1f} s")
