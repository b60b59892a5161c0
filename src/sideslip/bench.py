"""`sideslip bench`: samples per second and peak memory of every method on a long drive.

The benchmark drive is simulated once (``BENCH_SCENARIO``, stretched to the asked length) and
cached under ``benchmarks/cache/``.  Each method is first run on a one-minute slice (numba
compilation and caches warm up), then timed on the whole drive; its peak memory is measured in
a second run under ``tracemalloc`` (numpy buffers included).  Peer libraries (FilterPy, GTSAM)
run the same model on the same data in the same process when installed; their speed is shown
as a ratio.  Results go to ``benchmarks/results/bench.json`` and ``bench.md``.
"""

from __future__ import annotations

import datetime as _dt
import gc
import importlib
import json
import os
import pkgutil
import platform
import time
import tracemalloc
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.table import Table

from sideslip.drive import Drive, load_drive, save_drive
from sideslip.methods.registry import all_methods, run_method, why_not
from sideslip.vehicle import load_vehicle

BENCH_SCENARIO = "endurance"
MAX_HOURS = 1.25  # the endurance route is about 110 km long
RESULTS = Path("benchmarks") / "results"
CACHE = Path("benchmarks") / "cache"


def bench_drive(hours: float, console: Console | None = None) -> tuple[Drive, dict[str, float]]:
    """The cached benchmark drive of ``hours`` hours, and how long simulating/loading took."""
    import sideslip.simulate as sim
    from sideslip.errors import InputError

    if not 0.0 < hours <= MAX_HOURS:
        raise InputError("--hours", f"{hours:g}: expected more than 0 and at most {MAX_HOURS:g} h")
    CACHE.mkdir(parents=True, exist_ok=True)
    path = CACHE / f"{BENCH_SCENARIO}_{hours:g}h.parquet"
    timings: dict[str, float] = {}
    if not path.exists():
        if console:
            console.print(f"simulating a {hours:g} h drive (cached in {path}) ...")
        start = time.perf_counter()
        drive = sim.simulate(BENCH_SCENARIO, seed=0, duration_s=hours * 3600.0)
        timings["simulate_s"] = time.perf_counter() - start
        save_drive(drive, path)
    start = time.perf_counter()
    drive = load_drive(path)
    timings["load_parquet_s"] = time.perf_counter() - start
    timings["rows"] = float(len(drive))
    timings["columns"] = float(len(list(drive.columns())))
    return drive, timings


def _peers() -> dict[str, list[Any]]:
    """method name -> peer modules (``sideslip.peers.*`` with PEER_FOR, NAME, run)."""
    out: dict[str, list[Any]] = {}
    try:
        import sideslip.peers as pkg
    except ImportError:
        return out
    for info in pkgutil.iter_modules(pkg.__path__):
        try:
            mod = importlib.import_module(f"sideslip.peers.{info.name}")
        except ImportError:
            continue  # the peer library is not installed
        for method in getattr(mod, "PEER_FOR", ()):
            out.setdefault(method, []).append(mod)
    return out


def _timed(func: Any, *args: Any) -> tuple[float, Any]:
    gc.collect()
    start = time.perf_counter()
    result = func(*args)
    return time.perf_counter() - start, result


def _peak_mb(func: Any, *args: Any) -> float:
    gc.collect()
    tracemalloc.start()
    try:
        func(*args)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    return peak / 1e6


def run_bench(
    hours: float = 1.0,
    methods: list[str] | None = None,
    console: Console | None = None,
    memory: bool = True,
) -> dict[str, Any]:
    """Time every (or the named) method; print a table; write benchmarks/results/bench.*."""
    console = console or Console()
    drive, timings = bench_drive(hours, console)
    vehicle = load_vehicle(drive.meta["vehicle"])
    n = len(drive)
    warm = drive.slice(0, min(n, int(60.0 / max(drive.dt_median, 1e-3))))
    registry = all_methods()
    peers = _peers()
    rows: list[dict[str, Any]] = []
    for name, method in registry.items():
        if methods and name not in methods:
            continue
        reason = why_not(method, drive, vehicle)
        if reason:
            rows.append({"method": name, "skipped": reason})
            continue
        run_method(method, warm, vehicle)
        elapsed, _ = _timed(run_method, method, drive, vehicle)
        row: dict[str, Any] = {
            "method": name,
            "seconds": elapsed,
            "samples_per_s": n / elapsed,
        }
        if memory:
            row["peak_mb"] = _peak_mb(run_method, method, drive, vehicle)
        for peer in peers.get(name, []):
            peer.run(warm, vehicle)
            p_elapsed, _ = _timed(peer.run, drive, vehicle)
            row.setdefault("peers", []).append(
                {
                    "peer": peer.NAME,
                    "seconds": p_elapsed,
                    "samples_per_s": n / p_elapsed,
                    "speed_ratio": p_elapsed / elapsed,
                }
            )
        rows.append(row)
        console.print(f"  {name}: {n / elapsed:,.0f} samples/s")
    result = {
        "date": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
        "machine": {
            "platform": platform.platform(),
            "processor": platform.processor() or platform.machine(),
            "cpus": os.cpu_count(),
            "python": platform.python_version(),
        },
        "drive": {"scenario": BENCH_SCENARIO, "hours": hours, **timings},
        "methods": rows,
    }
    _print(console, result)
    if methods:
        console.print("partial run (--method): results printed, benchmarks/results/ left as it is")
        return result
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / "bench.json").write_text(json.dumps(result, indent=2))
    (RESULTS / "bench.md").write_text(_markdown(result))
    console.print(f"wrote {RESULTS / 'bench.json'} and {RESULTS / 'bench.md'}")
    return result


def _peer_text(row: dict[str, Any]) -> str:
    parts = []
    for p in row.get("peers", []):
        parts.append(f"{p['peer']}: {p['samples_per_s']:,.0f}/s (ours {p['speed_ratio']:.1f}x faster)")
    return "; ".join(parts) or "-"


def _print(console: Console, result: dict[str, Any]) -> None:
    d = result["drive"]
    table = Table(title=f"sideslip bench: {d['hours']:g} h drive, {int(d['rows']):,} rows")
    for col in ("method", "samples/s", "seconds", "peak MB", "peer library"):
        table.add_column(col, justify="left" if col in ("method", "peer library") else "right")
    for row in result["methods"]:
        if "skipped" in row:
            table.add_row(row["method"], "-", "-", "-", f"skipped: {row['skipped']}")
            continue
        table.add_row(
            row["method"],
            f"{row['samples_per_s']:,.0f}",
            f"{row['seconds']:.2f}",
            f"{row['peak_mb']:.0f}" if "peak_mb" in row else "-",
            _peer_text(row),
        )
    console.print(table)
    extra = [f"load parquet {d['load_parquet_s']:.2f} s"]
    if "simulate_s" in d:
        extra.append(f"simulate {d['simulate_s']:.1f} s")
    console.print("drive: " + ", ".join(extra))


def _markdown(result: dict[str, Any]) -> str:
    d = result["drive"]
    m = result["machine"]
    lines = [
        "# sideslip bench results",
        "",
        f"Measured {result['date']} on {m['processor']} ({m['cpus']} CPUs), Python {m['python']}.",
        f"Drive: scenario `{d['scenario']}`, {d['hours']:g} h, {int(d['rows']):,} rows, "
        f"{int(d['columns'])} columns; Parquet load {d['load_parquet_s']:.2f} s"
        + (f"; simulation {d['simulate_s']:.1f} s" if "simulate_s" in d else "")
        + ".",
        "",
        "| method | samples/s | seconds | peak MB | peer library |",
        "|---|---:|---:|---:|---|",
    ]
    for row in result["methods"]:
        if "skipped" in row:
            lines.append(f"| {row['method']} | - | - | - | skipped: {row['skipped']} |")
        else:
            peak = f"{row['peak_mb']:.0f}" if "peak_mb" in row else "-"
            lines.append(
                f"| {row['method']} | {row['samples_per_s']:,.0f} | {row['seconds']:.2f} | "
                f"{peak} | {_peer_text(row)} |"
            )
    return "\n".join(lines) + "\n"
