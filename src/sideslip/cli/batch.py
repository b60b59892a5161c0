"""`sideslip batch`: a fleet's drives in parallel, with a summary table."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Annotated, Any

import typer

from sideslip.cli.app import app, console, err_console, guarded, say
from sideslip.errors import InputError


@app.command("batch")
@guarded
def batch_cmd(
    drives: Annotated[list[Path], typer.Argument(metavar="DRIVE...", help="Drive tables (many).")],
    vehicle: Annotated[str, typer.Option("--vehicle", help="Vehicle preset name or TOML path.")],
    out_dir: Annotated[Path, typer.Option("--out-dir", help="Folder for estimates and summary.")],
    method: Annotated[
        list[str] | None, typer.Option("--method", help="Method to run (repeatable; default all possible).")
    ] = None,
    workers: Annotated[int, typer.Option("--workers", help="Worker processes (default: CPUs).")] = 0,
    use_dask: Annotated[
        bool, typer.Option("--dask", help="Run on a local Dask cluster (extra 'fleet').")
    ] = False,
) -> None:
    """Estimate (and evaluate) many drives in parallel; write a summary table.

    A drive that fails validation is listed with its one-line error; the others go on.  Exits 1
    when any drive failed.
    """
    import os

    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    from sideslip.batch import run_batch
    from sideslip.methods.registry import all_methods
    from sideslip.vehicle import load_vehicle

    load_vehicle(vehicle)  # a bad vehicle file fails once, here, not in every worker
    registry = all_methods()
    for name in method or []:
        if name not in registry:
            raise InputError("--method", f"unknown method '{name}': expected one of {', '.join(registry)}")
    if use_dask:
        import importlib.util

        if importlib.util.find_spec("distributed") is None:
            raise InputError("--dask", "dask.distributed is not installed: pip install 'sideslip[fleet]'")
    n_workers = workers if workers > 0 else min(len(drives), os.cpu_count() or 1)
    start = time.perf_counter()
    failed: list[str] = []
    with Progress(
        TextColumn("[progress.description]{task.description}"), BarColumn(), MofNCompleteColumn(),
        TimeElapsedColumn(), console=err_console,
    ) as progress:  # fmt: skip
        task = progress.add_task("drives", total=len(drives))

        def tick(res: Any) -> None:
            if res.error:
                failed.append(res.error)
            progress.advance(task)

        results = run_batch([str(d) for d in drives], vehicle, out_dir, method, n_workers, use_dask, tick)
    rows = sum(r.rows for r in results)
    elapsed = time.perf_counter() - start
    console.print(
        f"{len(results) - len(failed)} of {len(results)} drives done, {rows:,} rows in "
        f"{elapsed:.1f} s ({rows / max(elapsed, 1e-9):,.0f} rows/s with {n_workers} workers); "
        f"summary: {out_dir / 'summary.csv'}"
    )
    for line in failed:
        say(f"error: {line}")
    if failed:
        raise typer.Exit(1)
