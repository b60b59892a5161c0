"""`sideslip bench`: samples per second and peak memory of every method."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from sideslip.cli.app import app, console, guarded


@app.command("bench")
@guarded
def bench_cmd(
    hours: Annotated[
        float, typer.Option("--hours", help="Length of the benchmark drive, h (over 1.25 h: tiled).")
    ] = 1.0,
    method: Annotated[list[str] | None, typer.Option("--method", help="Only these methods.")] = None,
    out: Annotated[
        Path | None, typer.Option("--out", help="Folder for bench.json and bench.md (default: print only).")
    ] = None,
    cache: Annotated[
        Path | None,
        typer.Option("--cache", help="Folder caching the simulated drive (default ~/.cache/sideslip/bench)."),
    ] = None,
    memory: Annotated[
        bool, typer.Option("--memory/--no-memory", help="Measure each method's peak memory (a child each).")
    ] = True,
    repeat: Annotated[
        int, typer.Option("--repeat", min=1, help="Runs per method; the fastest is reported.")
    ] = 3,
) -> None:
    """Time every method on a simulated drive: samples/s, peak memory, peer-library ratio."""
    from sideslip.bench import run_bench
    from sideslip.errors import InputError
    from sideslip.methods.registry import all_methods

    registry = all_methods()
    for name in method or []:
        if name not in registry:
            raise InputError("--method", f"unknown method '{name}': expected one of {', '.join(registry)}")
    run_bench(
        hours=hours, methods=method, console=console, memory=memory, out_dir=out, cache=cache, repeat=repeat
    )
