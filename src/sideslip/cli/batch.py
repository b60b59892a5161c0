"""`sideslip batch`: a fleet's drives in parallel, with a summary and a per-method aggregate."""

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
    drives: Annotated[
        list[str], typer.Argument(metavar="DRIVE...", help="Drive tables (many): paths or fsspec URLs.")
    ],
    vehicle: Annotated[str, typer.Option("--vehicle", help="Vehicle preset name or TOML path.")],
    out_dir: Annotated[
        str, typer.Option("--out-dir", help="Folder (path or fsspec URL) for estimates and summaries.")
    ],
    method: Annotated[
        list[str] | None, typer.Option("--method", help="Method to run (repeatable; default all possible).")
    ] = None,
    workers: Annotated[int, typer.Option("--workers", help="Worker processes (default: CPUs).")] = 0,
    use_dask: Annotated[
        bool, typer.Option("--dask", help="Run on a local Dask cluster started here (extra 'fleet').")
    ] = False,
    scheduler: Annotated[
        str | None,
        typer.Option("--scheduler", help="Send the drives to a running Dask cluster: tcp://HOST:PORT."),
    ] = None,
    resume: Annotated[
        bool, typer.Option("--resume", help="Skip drives whose outputs are complete (checked by content).")
    ] = False,
    set_: Annotated[
        list[str] | None,
        typer.Option("--set", help="A method setting, METHOD.FIELD=VALUE (repeatable; wins over --config)."),
    ] = None,
    config: Annotated[
        Path | None, typer.Option("--config", help="Settings TOML: one [method] table of FIELD = VALUE.")
    ] = None,
) -> None:
    """Estimate (and evaluate) many drives in parallel; write a summary and an aggregate.

    Outputs: <out-dir>/<drive>_est.parquet (+ .params.json, .manifest.json) per drive, named
    after the drive's file with its parent folders where two drives share a name;
    summary.csv/.json (per drive and method) and aggregate.parquet (per method: median and
    p95 of every metric, share of drives run/resumed/not runnable/failed).  A drive that
    fails is listed with its one-line error; the others go on.  Exits 1 when any drive failed.
    """
    import os

    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    from sideslip.batch import aggregate_frame, console_lines, run_batch
    from sideslip.batch.run import check_out_dir
    from sideslip.batch.storage import join, normalise
    from sideslip.cli.estimate import settings_from_cli
    from sideslip.methods.registry import all_methods
    from sideslip.vehicle import load_vehicle

    load_vehicle(vehicle)  # a bad vehicle file fails once, here, not in every worker
    registry = all_methods()
    for name in method or []:
        if name not in registry:
            raise InputError("--method", f"unknown method '{name}': expected one of {', '.join(registry)}")
    chosen_settings = settings_from_cli(config, set_)
    if scheduler and use_dask:
        raise InputError("--scheduler", "give either --dask (a local cluster) or --scheduler, not both")
    if scheduler and not scheduler.startswith(("tcp://", "tls://", "inproc://", "ucx://", "ws://", "wss://")):
        raise InputError("--scheduler", f"{scheduler}: expected an address like tcp://HOST:PORT")
    if use_dask or scheduler:
        import importlib.util

        if importlib.util.find_spec("distributed") is None:
            raise InputError("--dask", "dask.distributed is not installed: pip install 'sideslip[fleet]'")
    check_out_dir(normalise(out_dir))
    n_workers = workers if workers > 0 else min(len(drives), os.cpu_count() or 1)
    start = time.perf_counter()
    failed: list[str] = []
    with Progress(
        TextColumn("[progress.description]{task.description}"), BarColumn(), MofNCompleteColumn(),
        TimeElapsedColumn(), console=err_console,
    ) as progress:  # fmt: skip
        task = progress.add_task("drives", total=len({normalise(d) for d in drives}))

        def tick(res: Any) -> None:
            if res.error:
                failed.append(res.error)
            progress.advance(task)

        results = run_batch(
            drives, vehicle, out_dir, method, n_workers, use_dask, tick,
            scheduler=scheduler, resume=resume, settings=chosen_settings,
        )  # fmt: skip
    rows = sum(r.rows for r in results if r.status == "run")
    resumed = sum(r.status == "resumed" for r in results)
    elapsed = time.perf_counter() - start
    names = list(method) if method else [m for m in registry if any(m in r.methods for r in results)]
    for line in console_lines(aggregate_frame(results, names)):
        console.print(line, markup=False, highlight=False, soft_wrap=True)
    engine = scheduler or (f"local Dask, {n_workers} workers" if use_dask else f"{n_workers} workers")
    out = normalise(out_dir)
    console.print(
        f"{len(results) - len(failed)} of {len(results)} drives done ({resumed} resumed), {rows:,} rows "
        f"in {elapsed:.1f} s ({rows / max(elapsed, 1e-9):,.0f} rows/s on {engine})",
        markup=False, highlight=False, soft_wrap=True,
    )  # fmt: skip
    for label, name in (("summary", "summary.csv"), ("aggregate", "aggregate.parquet")):
        console.print(f"{label}: {join(out, name)}", markup=False, highlight=False, soft_wrap=True)
    for line in failed:
        say(f"error: {line}")
    if failed:
        raise typer.Exit(1)
