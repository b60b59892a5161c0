"""`sideslip bench`: samples per second and peak memory of every method."""

from __future__ import annotations

from typing import Annotated

import typer

from sideslip.cli.app import app, console, guarded


@app.command("bench")
@guarded
def bench_cmd(
    hours: Annotated[float, typer.Option("--hours", help="Length of the benchmark drive, h.")] = 1.0,
    method: Annotated[list[str] | None, typer.Option("--method", help="Only these methods.")] = None,
) -> None:
    """Time every method on a simulated drive: samples/s, peak memory, peer-library ratio."""
    from sideslip.bench import run_bench

    run_bench(hours=hours, methods=method, console=console)
